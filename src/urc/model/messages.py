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
    _argument_names: ClassVar[tuple[str, ...]]  # (each type's own, set on first use)

    def arguments(self) -> dict[str, Any]:
        cls = type(self)
        names = cls.__dict__.get("_argument_names")
        if names is None:  # (once per type: dataclasses.fields walks the class on every call)
            names = tuple(f.name for f in dataclasses.fields(cls))
            cls._argument_names = names
        return {name: getattr(self, name) for name in names}


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


@dataclass(frozen=True)
class FlyProgram(Request):
    """A whole planned pass to fly by the control process's own clock
    (``urc.model.program.PassProgram``: program track)."""
    METHOD: ClassVar[str] = "fly_program"
    program: Any


@dataclass(frozen=True)
class CancelProgram(Request):
    METHOD: ClassVar[str] = "cancel_program"
    program_id: int | None = None


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


# ------------------------------------------------------------------ hardware queries and procedures
@dataclass(frozen=True)
class Query(Request):
    """A hardware query or a calibration procedure: run in the control process by the
    handler :data:`urc.rotator.queries.HANDLERS` holds for its type (not a Rotator
    method), whole, in one round trip: every protocol command costs at most one."""


@dataclass(frozen=True)
class SensorCount(Query):
    """The axis sensor's own count (Tartu RDAP/RDEP) -> :class:`CountReading`."""
    axis: str


@dataclass(frozen=True)
class CountReading:
    #: the sensor's count from the axis' reference (0 deg); None: the sensor keeps none
    count: int | None
    #: one count (or sensor step), degrees; None: no sensor on that axis
    resolution_deg: float | None


@dataclass(frozen=True)
class SensorCalibrations(Query):
    """Every axis sensor's constants -> ``{axis: {name: value}}`` ({} for a sensor
    without constants)."""


@dataclass(frozen=True)
class RawVectors(Query):
    """SARCNET's raw magnetometer and accelerometer vectors, before any calibration ->
    ``((mx, my, mz), (gx, gy, gz))``, or None when the rotator has no such parts."""


@dataclass(frozen=True)
class BeginHandCalibration(Query):
    """SARCNET ``c``: the sensor board comes off the boom: stop, and take the local hold
    ``hold`` (nothing drives on its readings meanwhile) -> False, and nothing done, when
    the rotator has no raw magnetometer/accelerometer."""
    hold: str


@dataclass(frozen=True)
class Reset(Query):
    """SARCNET ``r``: list the sensors' constants, stop, clear the faults, then go
    ``home`` (a Goto or GotoPose) -> :class:`ResetOutcome`."""
    home: Goto | GotoPose


@dataclass(frozen=True)
class ResetOutcome:
    calibrations: dict   # as SensorCalibrations answers, read first
    refused: str | None  # why the rotator refused ``home`` (nothing moves), None: on its way


@dataclass(frozen=True)
class PotState(Query):
    """G4JNT: the azimuth's ratiometric pot -> :class:`PotReading`, or None when the
    azimuth sensor is not one."""


@dataclass(frozen=True)
class PotReading:
    calibration: dict  # the pot's constants (M, C, Z, K)
    last_counts: int   # the ADC count N behind its last reading


@dataclass(frozen=True)
class PotUnits(Query):
    """A pot's linearised reading P, averaged over ``samples`` reads -> float."""
    axis: str
    samples: int = 32


@dataclass(frozen=True)
class CompassField(Query):
    """A compass's raw horizontal field, averaged -> ``(bx, by)``."""
    axis: str
    samples: int = 16


@dataclass(frozen=True)
class DescribeSensors(Query):
    """Per axis: sensor kind, constants, procedures that apply -> dict."""


@dataclass(frozen=True)
class ApplyCalibration(Query):
    """Load sensor constants and re-reference the axis (calibration.apply_sensor_calibration)
    -> the new mechanical angle."""
    axis: str
    values: dict
    local: bool = False
    #: constants the sensor must have already, else NoSuchConstant and nothing is loaded
    #: (a protocol's constants meant for one kind of sensor: G4JNT's pot)
    require: tuple[str, ...] = ()


@dataclass(frozen=True)
class PotApply(Query):
    """Two-point pot calibration from (bearing_deg, P) points -> its result dict."""
    axis: str
    points: tuple


@dataclass(frozen=True)
class ApplyTwelveDirection(Query):
    """Load a SARCNET 12-direction result and save the state -> whether it reached disk;
    once loaded, the local hold ``release`` (if any) is released."""
    result: dict
    release: str | None = None


@dataclass(frozen=True)
class ControllerHome(Query):
    """Have a bridged controller home on its endstops (the SatNOGS firmware's RESET, or a
    reboot when it reports an error) -> None; refused with the reason it cannot."""


@dataclass(frozen=True)
class HardwareInfo(Query):
    """What the hardware is -> :class:`HardwareSummary` (sent once at start: asking costs
    no round trip)."""


@dataclass(frozen=True)
class HardwareSummary:
    backend: str     # sim | gpio | bridge
    simulator: bool  # a simulated world behind it (sim, or gpio emulated): faults can be injected
    state_dir: str   # where the state record is kept


@dataclass(frozen=True)
class MotorDuties(Query):
    """Each axis motor's drive as its driver holds it now -> ``{axis: duty}``: read even
    while a tick hangs (the status is the last tick's)."""


@dataclass(frozen=True)
class SimFault(Query):
    """Make the simulated hardware fail (``World.inject``)."""
    axis: str
    kind: str
    params: dict = field(default_factory=dict)


@dataclass(frozen=True)
class SimClear(Query):
    """Repair the simulated hardware (``World.clear``)."""
    axis: str
    kind: str | None = None


#: request type -> the Rotator method that runs it (queries apart: urc.rotator.queries)
COMMANDS: dict[type[Request], str] = {cls: cls.METHOD for cls in (
    Goto, GotoAz, GotoEl, GotoPose, Park, Track, TrackPose, Move, Stop, FlyProgram, CancelProgram, SetPosition,
    AdoptSensorReading,
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
    """The answer to one request: ``outcome`` is "value" or "error" (``value`` is the
    exception as exception_to_wire made it), with the status the command left
    (read-your-writes)."""

    rid: int
    outcome: str
    value: Any
    status: Any
