"""Commands from ``<base>/cmd``: parse and check one JSON object, run it through the
rotator service (the gate every protocol passes: limits, keep-out zones, local control,
faults), answer ``{"id", "ok"[, "error", "reason"]}`` for ``<base>/cmd/result``.

Anything not fully understood — not JSON, not an object, a key given twice, NaN, a wrong
type, an unknown field or command, too big — is answered with an error and moves nothing. Stop is never
refused by the gate (it may still fail if the control process is gone).
"""

from __future__ import annotations

import json
import logging
from typing import Annotated, Any, Literal, Union

from pydantic import BaseModel, ConfigDict, Field, TypeAdapter, ValidationError

from ..dispatch import Dispatcher, TrackerFailed
from ..dispatch.bodies import GotoRequest, StopRequest, TrackRequest
from ..dispatch.errors import describe
from ..errors import CommandRejected, UrcError
from ..protocols.base import RateLimitedLog

log = logging.getLogger("urc.mqtt")
bad_input = RateLimitedLog(log)

#: a command is a few dozen bytes; anything much bigger is not one
MAX_PAYLOAD_BYTES = 4096
CommandId = Union[Annotated[str, Field(max_length=64)], Annotated[int, Field(strict=True)], None]


class _Cmd(BaseModel):
    """The envelope: an id to answer with and the command's name; the body's fields are
    the API's (urc.dispatch.bodies), JSON's types taken strictly."""
    model_config = ConfigDict(extra="forbid", strict=True, frozen=True)
    id: CommandId = None


# (the body first: its fields come after the id, as the errors list them)
class Goto(GotoRequest, _Cmd):
    model_config = _Cmd.model_config
    command: Literal["goto"]


class Stop(StopRequest, _Cmd):
    """axis None: everything (tracking, a calibration, both axes)."""
    model_config = _Cmd.model_config
    command: Literal["stop"]


class Park(_Cmd):
    command: Literal["park"]


class ClearFaults(_Cmd):
    command: Literal["clear_faults"]


class Track(_Cmd):
    """Track a target: the fields of the API's POST /api/track (kind, name, norad ...),
    typed strictly here, then checked as the API checks them (TrackRequest; its rules
    judge only a body whose types are right, as before)."""
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

    def body(self) -> TrackRequest:
        """Checked as the API checks it; ValidationError if wrong."""
        return TrackRequest.model_validate(self.model_dump(exclude={"id", "command"}, exclude_none=True))

    def request(self) -> dict[str, Any]:
        return self.body().model_dump(exclude_none=True)


class TrackStop(_Cmd):
    command: Literal["track_stop"]


Command = Annotated[Goto | Stop | Park | ClearFaults | Track | TrackStop, Field(discriminator="command")]
_COMMAND = TypeAdapter(Command)
COMMANDS = ("goto", "stop", "park", "clear_faults", "track", "track_stop")


class BadCommand(ValueError):
    def __init__(self, message: str, cmd_id: Any = None):
        super().__init__(message)
        self.cmd_id = cmd_id


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
            cmd.body()
    except ValidationError as exc:
        raise BadCommand(describe(exc.errors(include_url=False), COMMANDS), cmd_id) from None
    return cmd


class CommandHandler:
    """Runs commands as the HTTP API runs them (urc.dispatch, as ``urc.api`` does), on
    the same rotator, tracker and dashboard hub. Rotator calls await the control process
    (only this command waits, never the event loop)."""

    def __init__(self, rotator: Any, tracker: Any = None, hub: Any = None):
        self.dispatch = Dispatcher(rotator, tracker, hub)
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
        except TrackerFailed as exc:  # a tracker that cannot plan, a bad element set ... (logged there)
            return self._failed(cmd, exc.cause)
        except UrcError as exc:
            bad_input.info("MQTT %s refused: %s", cmd.command, exc)
            return {"id": cmd.id, "ok": False, "error": str(exc),
                    "reason": getattr(exc, "reason", type(exc).__name__)}
        except Exception as exc:
            log.warning("MQTT %s failed: %s", cmd.command, exc, exc_info=True)
            return self._failed(cmd, exc)
        if isinstance(cmd, (Goto, Park)):  # (its end follows as one more result: urc.mqtt.outcomes)
            if self.on_motion is not None:
                self.on_motion(cmd.id, cmd.command, None if isinstance(cmd, Park) else (cmd.az_deg, cmd.el_deg))
            return {"id": cmd.id, "ok": True, "state": "accepted"}
        return {"id": cmd.id, "ok": True}

    @staticmethod
    def _failed(cmd: Any, exc: Exception) -> dict[str, Any]:
        return {"id": cmd.id, "ok": False, "error": str(exc) or type(exc).__name__, "reason": "failed"}

    async def run(self, cmd: Any) -> None:
        d = self.dispatch
        if isinstance(cmd, Goto):
            await d.goto(cmd)
        elif isinstance(cmd, Stop):
            stopped = await d.stop(cmd)
            if stopped.queued:  # (answered as the refusal it was before: reason "fault")
                raise CommandRejected(stopped.note, "fault")
        elif isinstance(cmd, Park):
            await d.park()
        elif isinstance(cmd, ClearFaults):
            await d.clear_faults()
        elif isinstance(cmd, Track):
            await d.track(cmd.body())
        elif isinstance(cmd, TrackStop):
            await d.track_stop()
        else:  # pragma: no cover - the union above is the whole list
            raise CommandRejected(f"unknown command {cmd!r}")
