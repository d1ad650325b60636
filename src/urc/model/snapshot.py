"""Immutable status snapshots: what every protocol, the CLI and the web page read."""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Any

from ..control.faults import Fault


@dataclass(frozen=True)
class AxisStatus:
    pos_deg: float              # mechanical frame, wrap range included
    rate_deg_per_s: float
    target_deg: float | None
    mode: str                   # idle | releasing | driving | holding
    duty: float
    brake_released: bool
    uncertainty_deg: float      # 0 when the position is known
    limit_min: bool
    limit_max: bool
    current_a: float
    #: whether the position sensor (or the bridged controller) answered this tick:
    #: False = pos_deg is the last reading, not confirmed now
    sensor_ok: bool = True
    sensor_error: str = ""      # why not ("" while it reads)


@dataclass(frozen=True)
class Status:
    t_s: float
    profile: str
    az_deg: float               # where the beam points: compass azimuth 0..360
    el_deg: float | None        # None: the rotator has no elevation axis (``axes``)
    az: AxisStatus
    el: AxisStatus | None       # None: no elevation axis
    target_az_deg: float | None
    target_el_deg: float | None
    flipped: bool
    wrap_turns: int             # how many whole turns past the first: the cable-wrap side
    moving: bool
    parked: bool
    position_known: bool
    faults: tuple[Fault, ...]
    events: tuple[str, ...]     # recent notable events (guard stops, state file problems)
    tick_late_p99_ms: float
    #: the simulator's true mechanical state (None on real hardware): benchmarks and
    #: tests compare against it; the controller itself never uses it.
    sim_truth: dict[str, Any] | None = None
    #: mechanical soft limits per axis; add ``offsets`` for the pointing frame
    limits: dict[str, tuple[float, float]] = field(default_factory=dict)
    #: mount offsets (pointing = mechanical + offset), degrees
    offsets: dict[str, float] = field(default_factory=dict)
    #: why the state record cannot be written ("" while saving works); motion goes on
    #: only as far as the last record on disk allows, then a "state" fault stops it
    state_error: str = ""
    #: control-loop timing (``urc.rotator.timing.LoopHealth.as_dict``): lateness and
    #: tick-time p99, stalls, whether the motors are held off after a stall
    loop: dict[str, Any] = field(default_factory=dict)
    #: local controls held now (front-panel buttons, IR keys): remote motion is refused
    local_control: tuple[str, ...] = ()
    #: the axes the rotator has: ("az",) for a single-axis one (turntable, HF beam)
    axes: tuple[str, ...] = ("az", "el")
    #: procedures running per axis ("reference search": the BIG-RAS homing). The axis
    #: then counts in a frame of the procedure's own: its number says nothing about
    #: where the antenna points, and every client is told its position is unknown
    procedures: dict[str, str] = field(default_factory=dict)
    #: the last stop no client's motion command asked for ({"kind": "health" | "fault",
    #: "reason", "command": what it interrupted, "t_s", "resumes": whether that command
    #: goes on by itself once urc is healthy}); None if there was none
    last_stop: dict[str, Any] | None = None
    #: the pass program flown by the control process ({"id", "name", "state": waiting |
    #: prepositioning | tracking, "aos_s", "los_s"}), None if none is loaded; and how the
    #: last one ended ({"id", "name", "why": "done" | "stopped" | "replaced by ..." ...})
    program: dict[str, Any] | None = None
    program_end: dict[str, Any] | None = None

    def position_unknown(self, axis: str | None = None) -> bool:
        """Is the position of ``axis`` (None: any axis) unknown (a procedure runs)?"""
        return bool(self.procedures) if axis is None else axis in self.procedures

    @property
    def has_el(self) -> bool:
        return "el" in self.axes

    def as_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d["faults"] = [f.as_dict() for f in self.faults]
        d["events"] = list(self.events)
        d["axes"] = list(self.axes)
        d["simulator_truth"] = d.pop("sim_truth")
        return d
