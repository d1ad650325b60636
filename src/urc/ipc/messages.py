"""What crosses between the I/O process and the control process: one frozen message
type per command, procedure and query, one reply type, and the Status of each tick.

The control process runs a request by looking its type up in :data:`COMMANDS` (the
Rotator method it names) — never by a name that arrived on the wire — and refuses
one whose ``deadline_s`` has passed (a client already told "no answer" must never see
its command take effect later). A stop has no deadline: it is always applied.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any, ClassVar


@dataclass(frozen=True)
class Request:
    """Base of every request; ``METHOD`` is the Rotator method it runs."""

    METHOD: ClassVar[str] = ""

    def arguments(self) -> dict[str, Any]:
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}


# ------------------------------------------------------------------ motion commands
@dataclass(frozen=True)
class Goto(Request):
    METHOD: ClassVar[str] = "goto"
    az_deg: float
    el_deg: float


@dataclass(frozen=True)
class GotoAz(Request):
    METHOD: ClassVar[str] = "goto_az"
    az_deg: float


@dataclass(frozen=True)
class GotoEl(Request):
    METHOD: ClassVar[str] = "goto_el"
    el_deg: float


@dataclass(frozen=True)
class GotoPose(Request):
    METHOD: ClassVar[str] = "goto_pose"
    az_m_deg: float
    el_m_deg: float
    name: str = "goto_pose"
    local: bool = False


@dataclass(frozen=True)
class Park(Request):
    METHOD: ClassVar[str] = "park"
    local: bool = False


@dataclass(frozen=True)
class Track(Request):
    METHOD: ClassVar[str] = "track"
    az_deg: float
    el_deg: float
    az_rate_deg_per_s: float = 0.0
    el_rate_deg_per_s: float = 0.0
    t_ref_s: float | None = None


@dataclass(frozen=True)
class TrackPose(Request):
    METHOD: ClassVar[str] = "track_pose"
    az_m_deg: float
    el_m_deg: float
    az_rate_deg_per_s: float = 0.0
    el_rate_deg_per_s: float = 0.0
    t_ref_s: float | None = None


@dataclass(frozen=True)
class Move(Request):
    METHOD: ClassVar[str] = "move"
    axis: str
    direction: int
    speed_frac: float = 1.0
    local: bool = False


@dataclass(frozen=True)
class Stop(Request):
    METHOD: ClassVar[str] = "stop"
    axis: str | None = None


# ------------------------------------------------------------------ position and settings
@dataclass(frozen=True)
class SetPosition(Request):
    METHOD: ClassVar[str] = "set_position"
    az_deg: float | None = None
    el_deg: float | None = None
    local: bool = False


@dataclass(frozen=True)
class AdoptSensorReading(Request):
    METHOD: ClassVar[str] = "adopt_sensor_reading"
    axis: str
    local: bool = False


@dataclass(frozen=True)
class SearchFrame(Request):
    METHOD: ClassVar[str] = "search_frame"
    axis: str
    mech_deg: float


@dataclass(frozen=True)
class EndSearch(Request):
    METHOD: ClassVar[str] = "end_search"
    axis: str
    mech_deg: float | None = None


@dataclass(frozen=True)
class SetOvershoot(Request):
    METHOD: ClassVar[str] = "set_overshoot"
    axis: str
    overshoot_deg: float


@dataclass(frozen=True)
class Reconfigure(Request):
    METHOD: ClassVar[str] = "reconfigure"
    settings: Any  # a RotatorSettings (allowed by the codec)


@dataclass(frozen=True)
class ClearFaults(Request):
    METHOD: ClassVar[str] = "clear_faults"


@dataclass(frozen=True)
class HoldLocal(Request):
    METHOD: ClassVar[str] = "hold_local"
    control: str
    held: bool


@dataclass(frozen=True)
class Announce(Request):
    METHOD: ClassVar[str] = "announce"
    text: str


@dataclass(frozen=True)
class PowerFail(Request):
    METHOD: ClassVar[str] = "power_fail"
    reason: str = "power-fail input: supply lost"


@dataclass(frozen=True)
class SaveNow(Request):
    METHOD: ClassVar[str] = "save_now"
    timeout_s: float = 5.0


# ------------------------------------------------------------------ queries
@dataclass(frozen=True)
class OvershootQuery(Request):
    METHOD: ClassVar[str] = "overshoot_deg"
    axis: str


@dataclass(frozen=True)
class LocalControls(Request):
    METHOD: ClassVar[str] = "local_controls"


@dataclass(frozen=True)
class PositionUncertain(Request):
    METHOD: ClassVar[str] = "position_uncertain"


# ------------------------------------------------------------------ procedures and hardware
@dataclass(frozen=True)
class Procedure(Request):
    """A function marked ``@in_control_process`` run whole on the real rotator (steps that
    no tick may split: a calibration's read-compute-apply). Only marked functions run."""

    module: str
    qualname: str
    args: tuple = ()
    kwargs: dict = field(default_factory=dict)


@dataclass(frozen=True)
class HardwareCall(Request):
    """A hardware query or setting reached from the rotator by a path of public
    attribute names and call steps (``hw.axis("az").sensor.calibration()``)."""

    path: tuple


#: request type -> the Rotator method that runs it (procedures and hardware apart)
COMMANDS: dict[type[Request], str] = {cls: cls.METHOD for cls in (
    Goto, GotoAz, GotoEl, GotoPose, Park, Track, TrackPose, Move, Stop, SetPosition, AdoptSensorReading,
    SearchFrame, EndSearch, SetOvershoot, Reconfigure, ClearFaults, HoldLocal, Announce, PowerFail, SaveNow,
    OvershootQuery, LocalControls, PositionUncertain)}


# ------------------------------------------------------------------ envelopes
@dataclass(frozen=True)
class Envelope:
    """A request on its way: its id, and the CLOCK_MONOTONIC time (the same in both
    processes) after which it must not run (None: always run — a stop)."""

    rid: int
    deadline_s: float | None
    request: Request


@dataclass(frozen=True)
class Reply:
    """The answer to one request: ``outcome`` is "value", "ref" (something that stays in
    the control process; ``value`` is None) or "error" (``value`` is the exception as
    exception_to_wire made it), with the status the command left (read-your-writes)."""

    rid: int
    outcome: str
    value: Any
    status: Any
