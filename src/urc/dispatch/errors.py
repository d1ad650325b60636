"""Why a shared command was refused, each a CommandRejected with its reason code, so a
front end answers them as it answers the rotator's own refusals (the web: 409 with
``{"ok": false, "error", "reason"}``; MQTT: its cmd/result)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any, TypeVar

from pydantic import BaseModel, ValidationError

from ..errors import CommandRejected

B = TypeVar("B", bound=BaseModel)


class Invalid(CommandRejected):
    """The body did not validate (reason "invalid"); ``errors`` are pydantic's, each
    naming its field. Nothing was sent."""

    def __init__(self, errors: Sequence[Mapping[str, Any]]):
        self.errors = list(errors)
        super().__init__(describe(self.errors), "invalid")


class TrackingOff(CommandRejected):
    """A tracking command where urc runs no tracker."""

    def __init__(self) -> None:
        super().__init__("tracking is off: no [station] configured", "tracking")


class NotSimulated(CommandRejected):
    """Fault injection on hardware that is not simulated: there is nothing to inject into."""

    def __init__(self) -> None:
        super().__init__("fault injection exists only on the simulator (sim, or gpio emulated)", "simulator")


class TrackerFailed(CommandRejected):
    """The tracker raised something other than a UrcError (a plan that does not fit, a
    bad element set): a refusal with reason "tracking", the tracker's exception in
    ``cause``."""

    def __init__(self, cause: Exception):
        self.cause = cause
        super().__init__(f"{cause}", "tracking")


def describe(errors: Sequence[Mapping[str, Any]], commands: Sequence[str] = ()) -> str:
    """The first three of pydantic's errors, each ``field: what was wrong, found value``.
    ``commands``: the names a tagged union of commands is keyed on (left out of a field's
    path; a missing or unknown tag says which names there are)."""
    out = []
    names = ", ".join(commands)
    for e in errors[:3]:
        loc = ".".join(str(x) for x in e.get("loc", ()) if x not in commands) or "command"
        if e.get("type") == "union_tag_invalid":
            out.append(f"command: expected one of {names}, found {e['input'].get('command')!r}")
        elif e.get("type") == "union_tag_not_found":
            out.append(f"command: missing (one of {names})")
        elif e.get("type") == "extra_forbidden":
            out.append(f"{loc}: unknown field")
        else:
            out.append(f"{loc}: {e.get('msg', 'invalid')}, found {e.get('input')!r}"[:200])
    return "; ".join(out)


def parse(model: type[B], data: Any) -> B:
    """``data`` as a ``model`` body: an instance as it is, anything else validated
    (Invalid if it does not)."""
    if isinstance(data, model):
        return data
    try:
        return model.model_validate(data)
    except ValidationError as exc:
        raise Invalid(exc.errors(include_url=False)) from None
