"""Commands from ``<base>/cmd``: parse and check one JSON object, run it through the
rotator service (the gate every protocol passes: limits, keep-out zones, local control,
faults), answer ``{"id", "ok"[, "error", "reason"]}`` for ``<base>/cmd/result``.

Anything not fully understood — not JSON, not an object, a key given twice, NaN, a wrong
type, an unknown field or command, too big — is answered with an error and moves nothing. Stop is never
refused by the gate (it may still fail if the control process is gone).
"""

from __future__ import annotations

import inspect
import json
import logging
from collections.abc import Mapping, Sequence
from typing import Annotated, Any, Literal, Union

from pydantic import BaseModel, ConfigDict, Field, TypeAdapter, ValidationError

from ..errors import CommandRejected, UrcError
from ..model import messages as msg
from ..model.effects import call
from ..protocols.base import RateLimitedLog
from ..web.routes_tracking import TrackRequest
from ..web.schemas import AzDeg, ElDeg

log = logging.getLogger("urc.mqtt")
bad_input = RateLimitedLog(log)

#: a command is a few dozen bytes; anything much bigger is not one
MAX_PAYLOAD_BYTES = 4096
CommandId = Union[Annotated[str, Field(max_length=64)], Annotated[int, Field(strict=True)], None]


class _Cmd(BaseModel):
    model_config = ConfigDict(extra="forbid", strict=True, frozen=True)
    id: CommandId = None


class Goto(_Cmd):
    command: Literal["goto"]
    az_deg: AzDeg
    #: None: azimuth only (the elevation keeps its target)
    el_deg: ElDeg | None = None


class Stop(_Cmd):
    command: Literal["stop"]
    #: None: everything (tracking, a calibration, both axes)
    axis: Literal["az", "el"] | None = None


class Park(_Cmd):
    command: Literal["park"]


class ClearFaults(_Cmd):
    command: Literal["clear_faults"]


class Track(_Cmd):
    """Track a target: the fields of the API's POST /api/track (kind, name, norad ...)."""
    command: Literal["track"]
    kind: str
    name: str | None = None
    norad: int | None = None
    lat_deg: float | None = Field(None, allow_inf_nan=False)
    lon_deg: float | None = Field(None, allow_inf_nan=False)
    alt_m: float | None = Field(None, allow_inf_nan=False)
    az_deg: float | None = Field(None, allow_inf_nan=False)
    el_deg: float | None = Field(None, allow_inf_nan=False)
    source: str | None = None

    def request(self) -> dict[str, Any]:
        """Checked as the API checks it (TrackRequest); ValidationError if wrong."""
        fields = self.model_dump(exclude={"id", "command"}, exclude_none=True)
        return TrackRequest.model_validate(fields).model_dump(exclude_none=True)


class TrackStop(_Cmd):
    command: Literal["track_stop"]


Command = Annotated[Goto | Stop | Park | ClearFaults | Track | TrackStop, Field(discriminator="command")]
_COMMAND = TypeAdapter(Command)
COMMANDS = ("goto", "stop", "park", "clear_faults", "track", "track_stop")


class BadCommand(ValueError):
    def __init__(self, message: str, cmd_id: Any = None):
        super().__init__(message)
        self.cmd_id = cmd_id


def _describe(errors: Sequence[Mapping[str, Any]]) -> str:
    out = []
    for e in errors[:3]:
        loc = ".".join(str(x) for x in e.get("loc", ()) if x not in COMMANDS) or "command"
        if e.get("type") == "union_tag_invalid":
            out.append(f"command: expected one of {', '.join(COMMANDS)}, found {e['input'].get('command')!r}")
        elif e.get("type") == "union_tag_not_found":
            out.append(f"command: missing (one of {', '.join(COMMANDS)})")
        elif e.get("type") == "extra_forbidden":
            out.append(f"{loc}: unknown field")
        else:
            out.append(f"{loc}: {e.get('msg', 'invalid')}, found {e.get('input')!r}"[:200])
    return "; ".join(out)


def parse_command(payload: bytes) -> Goto | Stop | Park | ClearFaults | Track | TrackStop:
    """One command from a message payload; BadCommand (with the id when it could be
    read) if it is anything else."""
    if len(payload) > MAX_PAYLOAD_BYTES:
        raise BadCommand(f"payload of {len(payload)} bytes: a command is at most {MAX_PAYLOAD_BYTES}")
    repeated: list[str] = []

    def no_repeats(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
        # json keeps the last of a repeated key; which one the sender meant is unknown
        obj: dict[str, Any] = {}
        for key, value in pairs:
            if key in obj:
                repeated.append(key)
            obj[key] = value
        return obj

    try:
        # (NaN and Infinity parse, so the error can name the field and echo the id:
        # every number field refuses them)
        doc = json.loads(payload, object_pairs_hook=no_repeats)
    except (ValueError, RecursionError) as exc:
        raise BadCommand(f"not a JSON object: {str(exc)[:120]}") from None
    if not isinstance(doc, dict):
        raise BadCommand(f"expected a JSON object, found {type(doc).__name__}")
    raw_id = doc.get("id") if "id" not in repeated else None
    cmd_id = raw_id if (isinstance(raw_id, str) and len(raw_id) <= 64) or \
        (isinstance(raw_id, int) and not isinstance(raw_id, bool)) else None
    if repeated:
        names = ", ".join(dict.fromkeys(repeated))[:120]
        raise BadCommand(f"{names}: given more than once", cmd_id)
    try:
        cmd = _COMMAND.validate_python(doc)
        if isinstance(cmd, Track):
            cmd.request()
    except ValidationError as exc:
        raise BadCommand(_describe(exc.errors(include_url=False)), cmd_id) from None
    return cmd


class CommandHandler:
    """Runs commands as the HTTP API runs them (``urc.api``), on the same rotator,
    tracker and dashboard hub. Rotator calls await the control process (only this
    command waits, never the event loop). Tracker commands are awaited as the API
    awaits them."""

    def __init__(self, rotator: Any, tracker: Any = None, hub: Any = None):
        self.rotator = rotator
        self.tracker = tracker
        self.hub = hub
        #: told of each accepted goto and park (id, command, sky target or None for park):
        #: urc.mqtt.outcomes then says how it ended
        self.on_motion: Any = None

    async def handle(self, payload: bytes) -> dict[str, Any]:
        try:
            cmd = parse_command(payload)
        except BadCommand as exc:
            bad_input.warning("MQTT command refused: %s", exc)
            return {"id": exc.cmd_id, "ok": False, "error": str(exc), "reason": "invalid"}
        try:
            await self.run(cmd)
        except UrcError as exc:
            bad_input.info("MQTT %s refused: %s", cmd.command, exc)
            return {"id": cmd.id, "ok": False, "error": str(exc),
                    "reason": getattr(exc, "reason", type(exc).__name__)}
        except Exception as exc:  # a tracker that cannot plan, a bad element set ...
            log.warning("MQTT %s failed: %s", cmd.command, exc, exc_info=True)
            return {"id": cmd.id, "ok": False, "error": str(exc) or type(exc).__name__, "reason": "failed"}
        if isinstance(cmd, (Goto, Park)):  # (its end follows as one more result: urc.mqtt.outcomes)
            if self.on_motion is not None:
                self.on_motion(cmd.id, cmd.command, None if isinstance(cmd, Park) else (cmd.az_deg, cmd.el_deg))
            return {"id": cmd.id, "ok": True, "state": "accepted"}
        return {"id": cmd.id, "ok": True}

    async def run(self, cmd: Any) -> None:
        rot = self.rotator
        if isinstance(cmd, Goto):
            if cmd.el_deg is None:
                await call(rot, msg.GotoAz(cmd.az_deg))
            else:
                await call(rot, msg.Goto(cmd.az_deg, cmd.el_deg))
        elif isinstance(cmd, Stop):
            await self._stop(cmd.axis)
        elif isinstance(cmd, Park):
            await call(rot, msg.Park())
        elif isinstance(cmd, ClearFaults):
            await call(rot, msg.ClearFaults())
        elif isinstance(cmd, Track):
            await self._tracker_call("track", cmd.request())
        elif isinstance(cmd, TrackStop):
            await self._tracker_call("stop")
        else:  # pragma: no cover - the union above is the whole list
            raise CommandRejected(f"unknown command {cmd!r}")

    async def _stop(self, axis: str | None) -> None:
        """Like POST /api/stop: without an axis, tracking, a calibration and every jog too."""
        hub = self.hub
        if axis is None:
            if hub is not None:
                await hub.cancel_procedure()
            if self.tracker is not None:
                await self._tracker_call("stop")
        if hub is not None:
            await hub.release(axis)
        await call(self.rotator, msg.Stop(axis))

    async def _tracker_call(self, name: str, *args: Any) -> None:
        if self.tracker is None:
            raise CommandRejected("tracking is off: no [station] configured", "tracking")
        # (a TrackingService's commands are coroutines: they wait off the loop)
        out = getattr(self.tracker, name)(*args)
        if inspect.isawaitable(out):
            await out
        if self.hub is not None:
            await self.hub.refresh_tracking()
