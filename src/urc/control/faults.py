"""Fault detection per axis: stall, runaway, sensor faults, limit switches, overcurrent.

Pure like the law: ``check(state, inputs, limits) -> (state, fault | None)``. The rotator
service latches the first fault, stops the motors and shows the reason everywhere until
an explicit clear.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from .evolve import evolve

#: consecutive unreadable ticks tolerated before the sensor counts as dead (one I2C
#: glitch must not stop a pass; three in a row is a broken wire).
SENSOR_DEAD_TICKS = 3
OVERCURRENT_HOLD_S = 0.25
#: how far outside the axis range a reading may lie before the sensor is distrusted.
RANGE_MARGIN_DEG = 10.0


@dataclass(frozen=True)
class Fault:
    kind: str  # stall, runaway, sensor_stuck, sensor_jump, sensor_range, sensor_dead,
    #            limit_switch, overcurrent, watchdog, state, power_fail, control (the
    #            control process silent or gone: shown by urc run's I/O process),
    #            driver, safety_chain, motor_power (the chain's read-back OFF while
    #            the heartbeat runs: urc.hardware.supply_watch)
    axis: str | None
    reason: str
    t_s: float

    def as_dict(self) -> dict:
        return {"kind": self.kind, "axis": self.axis, "reason": self.reason, "t_s": round(self.t_s, 3)}


@dataclass(frozen=True)
class FaultLimits:
    axis: str
    min_deg: float
    max_deg: float
    max_rate_deg_per_s: float
    min_rate_deg_per_s: float
    resolution_deg: float
    noise_deg: float
    stall_timeout_s: float = 1.5
    runaway_deg: float = 3.0
    sensor_jump_deg: float = 5.0
    overcurrent_a: float = 0.0  # 0 = not checked

    @property
    def progress_deg(self) -> float:
        """Movement that proves the axis turns: well above quantisation and noise."""
        return 2.0 * self.resolution_deg + 4.0 * self.noise_deg

    @property
    def stall_after_s(self) -> float:
        # A slow axis needs longer to show progress through a coarse sensor.
        return self.stall_timeout_s + self.progress_deg / max(self.min_rate_deg_per_s, 1e-3)


@dataclass(frozen=True)
class MonitorState:
    progress_deg: float | None = None
    progress_t_s: float = 0.0
    rest_deg: float | None = None      # where the motor was switched off
    dir_sign: float = 0.0
    dir_anchor_deg: float = 0.0
    prev_deg: float | None = None
    prev_t_s: float = 0.0
    unreadable_ticks: int = 0
    overcurrent_since_s: float | None = None
    limit_min: bool = False
    limit_max: bool = False
    #: typical current while the axis was seen turning (tells a stall from a stuck sensor)
    running_a: float | None = None


@dataclass(frozen=True)
class MonitorInputs:
    now_s: float
    meas_deg: float | None      # None: the sensor could not be read this tick
    sensor_error: str = ""
    duty: float = 0.0           # what the law asked for this tick
    min_duty: float = 0.0
    current_a: float = 0.0      # NaN: unknown this tick
    limit_min: bool = False
    limit_max: bool = False
    #: the position estimate the law will act on (filtered); None = the reading itself
    estimate_deg: float | None = None


def check(st: MonitorState, x: MonitorInputs, lim: FaultLimits) -> tuple[MonitorState, Fault | None]:
    """One tick of fault detection. At most one new fault per tick, the most basic first."""
    changes: dict = {}
    fault = _check(st, x, lim, changes)
    return (evolve(st, **changes) if changes else st), fault


def _fault(lim: FaultLimits, x: MonitorInputs, kind: str, reason: str) -> Fault:
    # (a function of its own, not a closure made in _check on every tick)
    return Fault(kind, lim.axis, f"{lim.axis}: {reason}", x.now_s)


def _check(st: MonitorState, x: MonitorInputs, lim: FaultLimits, ch: dict) -> Fault | None:
    """Detect; record state changes in ``ch`` (one ``evolve`` per tick, this runs at 50 Hz;
    the changes every tick makes are stored item by item, not through update's keywords)."""
    # Limit switches: a rising edge is a fault (the soft limits should have stopped us).
    if x.limit_min != st.limit_min or x.limit_max != st.limit_max:
        ch.update(limit_min=x.limit_min, limit_max=x.limit_max)
        if x.limit_min and not st.limit_min:
            return _fault(lim, x, "limit_switch", "lower limit switch hit")
        if x.limit_max and not st.limit_max:
            return _fault(lim, x, "limit_switch", "upper limit switch hit")

    if math.isnan(x.current_a):
        pass    # unknown (a BTS7960 below its duty floor): not seen as safe, so the hold is kept
    elif lim.overcurrent_a > 0 and x.current_a > lim.overcurrent_a:
        since = st.overcurrent_since_s if st.overcurrent_since_s is not None else x.now_s
        ch["overcurrent_since_s"] = since
        if x.now_s - since >= OVERCURRENT_HOLD_S:
            return _fault(lim, x, "overcurrent", f"motor current {x.current_a:.2f} A above {lim.overcurrent_a:.2f} A")
    elif st.overcurrent_since_s is not None:
        ch["overcurrent_since_s"] = None

    if x.meas_deg is None:
        ch["unreadable_ticks"] = st.unreadable_ticks + 1
        if st.unreadable_ticks + 1 >= SENSOR_DEAD_TICKS:
            return _fault(lim, x, "sensor_dead", f"position sensor unreadable ({x.sensor_error or 'no reading'})")
        return None
    meas = x.meas_deg
    if st.unreadable_ticks:
        ch["unreadable_ticks"] = 0

    if not (lim.min_deg - RANGE_MARGIN_DEG <= meas <= lim.max_deg + RANGE_MARGIN_DEG):
        return _fault(lim, x, "sensor_range", f"reading {meas:.2f} deg outside {lim.min_deg:g}..{lim.max_deg:g} deg")

    ch["prev_deg"], ch["prev_t_s"] = meas, x.now_s
    if st.prev_deg is not None:
        dt = max(x.now_s - st.prev_t_s, 1e-6)
        jump = abs(meas - st.prev_deg)
        if jump > lim.max_rate_deg_per_s * dt * 2.0 + lim.sensor_jump_deg:
            return _fault(lim, x, "sensor_jump", f"reading jumped {jump:.2f} deg in {dt * 1000:.0f} ms")

    est = x.estimate_deg
    if est is not None and not (lim.min_deg - RANGE_MARGIN_DEG <= est <= lim.max_deg + RANGE_MARGIN_DEG
                                and abs(est - meas) <= lim.sensor_jump_deg):
        # the filter's estimate left what the axis can physically be: no drive may act on it
        return _fault(lim, x, "sensor_range", f"position estimate {est:.2f} deg implausible (reading {meas:.2f} deg)")

    driven = abs(x.duty) >= 0.9 * x.min_duty and x.duty != 0.0
    sign = (x.duty > 0) - (x.duty < 0)
    if not driven:
        rest = st.rest_deg if st.rest_deg is not None else meas
        ch["rest_deg"], ch["progress_deg"], ch["dir_sign"] = rest, None, 0.0
        if abs(meas - rest) > lim.runaway_deg:
            return _fault(lim, x, "runaway", f"moved {meas - rest:+.2f} deg with the motor off")
        return None

    ch["rest_deg"] = None
    anchor, progress, progress_t = st.dir_anchor_deg, st.progress_deg, st.progress_t_s
    if sign != st.dir_sign:
        anchor, progress, progress_t = meas, meas, x.now_s
        ch.update(dir_sign=float(sign), dir_anchor_deg=meas)
    if (meas - anchor) * sign < -lim.runaway_deg:
        return _fault(lim, x, "runaway", f"moving the wrong way: {meas - anchor:+.2f} deg while driven "
                                         f"{'up/cw' if sign > 0 else 'down/ccw'}")
    if progress is None or abs(meas - progress) >= lim.progress_deg:
        if progress is not None and not math.isnan(x.current_a):  # turning: learn its running current
            run = abs(x.current_a) if st.running_a is None else 0.8 * st.running_a + 0.2 * abs(x.current_a)
            ch["running_a"] = run
        ch["progress_deg"], ch["progress_t_s"] = meas, x.now_s
    else:
        ch["progress_deg"], ch["progress_t_s"] = progress, progress_t
        if x.now_s - progress_t > lim.stall_after_s:
            stuck_for = x.now_s - progress_t
            if st.running_a is not None and 0 < abs(x.current_a) < 1.5 * st.running_a:
                return _fault(lim, x, "sensor_stuck", f"driven for {stuck_for:.1f} s at running current "
                                                      f"{x.current_a:.2f} A but the reading does not change")
            return _fault(lim, x, "stall", f"driven for {stuck_for:.1f} s without moving (current {x.current_a:.2f} A)")
    return None
