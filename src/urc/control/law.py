"""The per-axis control law: ``step(state, setpoint, measurement, now, dt) -> (state, output)``.

Pure: the state is a frozen value and a new one is returned, so the law can be tested
tick by tick and replayed exactly. One asyncio task (the rotator service) owns it.

Two drive kinds:

* PWM: the motion profile gives a reference; a PID with anti-windup plus velocity
  feed-forward follows it; a minimum duty overcomes stiction.
* Relay (on/off, slow/fast levels): bang-bang with early cut-off by the coast distance,
  which the law learns from each stop (the Tartu controller's OVRA, set by hand there).

Both settle into a tolerance band with hysteresis: once there (or once the target has
been crossed) the motor stays off until the error exceeds ``restart_deg``, so relays do
not chatter and rotors do not hunt.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Literal

from .evolve import construct, evolve
from .profile import ProfileLimits, advance

Mode = Literal["idle", "releasing", "driving", "holding"]

#: under the minimum duty the axis must show movement within this time, else the
#: minimum rises by KICK_GAIN (breakaway torque varies with temperature, wind, wear).
KICK_WAIT_S = 0.25
KICK_GAIN = 1.25
KICK_MAX_DUTY = 0.6
#: after overshooting, creep back this many times at most, then settle where it is
#: (within restart_deg): more attempts is the hunting that wears relays out.
MAX_REVERSALS = 2
#: ahead of a target slower than the motor, wait up to this long for it to catch up
CREEP_WAIT_S = 2.0
#: after this long holding a static target the brake engages even while tracking.
BRAKE_AFTER_HOLD_S = 2.0
#: the axis counts as standing still for coast learning after this long without motion.
COAST_SETTLE_S = 0.4
#: an on/off (AC) motor is reversed only after this long switched off: reversing a
#: running motor ("plugging") strains gears and relay contacts
RELAY_REVERSE_PAUSE_S = 0.5
COAST_LEARN_GAIN = 0.4


@dataclass(frozen=True)
class AxisTuning:
    max_rate_deg_per_s: float
    min_rate_deg_per_s: float
    accel_deg_per_s2: float
    tolerance_deg: float
    restart_deg: float
    kp_per_s: float = 6.0
    ki_per_s2: float = 1.0
    #: speed-error gain (dimensionless): damping for inertia the feed-forward ignores
    kv: float = 0.5
    drive: Literal["pwm", "relay"] = "pwm"
    drive_levels: tuple[float, ...] = ()
    brake: bool = False
    brake_release_s: float = 0.0
    #: initial coast estimate for relay drives (the learnt value lives in the state).
    overshoot_deg: float = 0.0
    #: how far each burst overtakes a target slower than the motor's slowest speed
    creep_lead_deg: float = 0.1
    #: gear play the sensor does not see the motor cross (sensor on the antenna side)
    backlash_deg: float = 0.0

    @property
    def limits(self) -> ProfileLimits:
        return ProfileLimits(self.max_rate_deg_per_s, self.min_rate_deg_per_s, self.accel_deg_per_s2)

    @property
    def min_duty(self) -> float:
        return min(1.0, 1.15 * self.min_rate_deg_per_s / self.max_rate_deg_per_s)


@dataclass(frozen=True)
class Setpoint:
    """Go to ``target_deg`` (mechanical axis frame), which moves at ``rate_deg_per_s``
    from time ``t_ref_s`` on. ``seq`` changes with every new command."""

    target_deg: float
    rate_deg_per_s: float = 0.0
    t_ref_s: float = 0.0
    speed_cap_deg_per_s: float | None = None
    seq: int = 0
    #: the soft limits: a moving target stops there (a track extrapolated past its last
    #: update, a pass flown down to el 0) and is then approached like a goto to the limit
    min_deg: float = -math.inf
    max_deg: float = math.inf

    def target_at(self, now_s: float) -> float:
        return min(max(self.target_deg + self.rate_deg_per_s * (now_s - self.t_ref_s), self.min_deg),
                   self.max_deg)

    def bounded_at(self, now_s: float) -> tuple["Setpoint", float]:
        """This setpoint (a standing target at the limit once it has moved there) and its
        target at ``now_s`` (worked out once: the law asks every tick)."""
        target = self.target_at(now_s)
        if self.rate_deg_per_s == 0.0 or self.min_deg < target < self.max_deg:
            return self, target
        return replace(self, target_deg=target, rate_deg_per_s=0.0, t_ref_s=now_s), target


@dataclass(frozen=True)
class AxisState:
    mode: Mode = "idle"
    ref_deg: float = 0.0
    ref_rate_deg_per_s: float = 0.0
    integral_deg_s: float = 0.0
    seq: int = -1
    approach_sign: float = 0.0
    phase_until_s: float = 0.0
    hold_since_s: float = 0.0
    arrived: bool = False
    # relay coast learning: estimated coast per drive level, and the cut in progress
    coast_deg: tuple[float, ...] = field(default_factory=tuple)
    cut_deg: float | None = None
    cut_level: int = 0
    still_since_s: float = 0.0
    #: where the axis was when it was last seen moving (coast learning anchor)
    last_meas_deg: float = 0.0
    # stiction: the smallest duty that has been seen to turn the motor, learnt upwards
    # when the axis sits still under the present minimum (0 = start from the tuning)
    kick_duty: float = 0.0
    kick_anchor_deg: float = 0.0
    kick_since_s: float = 0.0
    #: target crossings allowed to creep back into the tolerance before settling anyway
    reversals: int = 0
    #: relay drives: the direction last driven (+1/-1, 0 never) and when it stopped
    relay_dir: int = 0
    relay_off_s: float = -math.inf


@dataclass(frozen=True)
class AxisOutput:
    duty: float
    brake_released: bool
    driving: bool


OFF = AxisOutput(0.0, False, False)
#: holding with the brake released (one value, made once: the law holds most ticks)
HOLD_BRAKE_RELEASED = AxisOutput(0.0, True, False)


def initial_state(tuning: AxisTuning, meas_deg: float) -> AxisState:
    levels = tuning.drive_levels or (1.0,)
    return AxisState(ref_deg=meas_deg, last_meas_deg=meas_deg,
                     coast_deg=tuple(tuning.overshoot_deg * lv for lv in levels))


def step(st: AxisState, sp: Setpoint | None, meas_deg: float, now_s: float, dt_s: float,
         tun: AxisTuning, meas_rate_deg_per_s: float = 0.0) -> tuple[AxisState, AxisOutput]:
    """Advance one tick. ``sp=None`` means motor off, brake on, forget the target."""
    st, out = _step(st, sp, meas_deg, now_s, dt_s, tun, meas_rate_deg_per_s)
    if out.duty == 0.0 and st.relay_off_s == math.inf:
        st = evolve(st, relay_off_s=now_s)  # the relay just opened: the reverse pause starts
    return st, out


def _step(st: AxisState, sp: Setpoint | None, meas_deg: float, now_s: float, dt_s: float,
          tun: AxisTuning, meas_rate_deg_per_s: float) -> tuple[AxisState, AxisOutput]:
    if st.cut_deg is not None:  # (a relay's coast to learn: see _learn_coast)
        st = _learn_coast(st, meas_deg, now_s, tun)
    if sp is None:
        return evolve(st, mode="idle", ref_deg=meas_deg, ref_rate_deg_per_s=0.0,
                       integral_deg_s=0.0, arrived=False), OFF
    sp, target_deg = sp.bounded_at(now_s)
    # an on/off drive follows anything slower than its top speed in bursts as well
    steady_deg_per_s = 0.9 * tun.max_rate_deg_per_s if tun.drive == "relay" else tun.min_rate_deg_per_s
    tracking = abs(sp.rate_deg_per_s) >= steady_deg_per_s
    # A target slower than the motor's slowest steady speed is followed in short bursts.
    # Each burst overtakes it by the axis's creep lead, so the error swings evenly
    # around zero instead of always lagging.
    creeping = not tracking and sp.rate_deg_per_s != 0.0
    lead_deg = math.copysign(tun.creep_lead_deg, sp.rate_deg_per_s) if creeping else 0.0
    # past the overtaking point of a slow target (a slew that came from the far side,
    # gear play that threw the antenna on): aim at the target itself, it comes to us
    ahead = creeping and (meas_deg - target_deg - lead_deg) * sp.rate_deg_per_s > 0.0
    if creeping and not ahead:
        # (never past a soft limit: a sensor may not even read beyond it, a pot at its end)
        target_deg = min(max(target_deg + lead_deg, sp.min_deg), sp.max_deg)
    error_deg = target_deg - meas_deg

    if sp.seq != st.seq:
        # A new command: plan afresh from where the axis really is.
        restart = st.mode in ("idle", "holding") or abs(st.ref_deg - meas_deg) > tun.restart_deg
        st = evolve(st, seq=sp.seq, arrived=False, reversals=0,
                     approach_sign=math.copysign(1.0, error_deg) if error_deg else 0.0,
                     mode="driving" if st.mode == "holding" else st.mode)
        if restart:
            st = evolve(st, ref_deg=meas_deg, ref_rate_deg_per_s=0.0, integral_deg_s=0.0,
                         kick_anchor_deg=meas_deg, kick_since_s=now_s)
        if st.mode != "releasing" and abs(error_deg) <= tun.tolerance_deg and not tracking:
            return _hold(st, meas_deg, now_s, tun, brake_released=st.mode == "driving")

    if st.mode in ("idle", "holding"):
        # a relay following a moving target restarts at the tolerance, not the wider
        # settling band: the target keeps walking away, so waiting costs accuracy
        band = tun.tolerance_deg if tracking or creeping else tun.restart_deg
        if ahead:
            # wait for it: driving back would start a back-and-forth (each burst leaves
            # the antenna up to a lead past the target); go back only when it would
            # take the target long to catch up
            band = max(tun.restart_deg, CREEP_WAIT_S * abs(sp.rate_deg_per_s)) + tun.creep_lead_deg
        if abs(error_deg) <= band and not (tracking and tun.drive == "pwm"):
            return _hold(st, meas_deg, now_s, tun,
                         brake_released=_keep_brake_off(st, now_s, tun, tracking or creeping))
        # (the stiction clock starts now: the time spent holding is not time stuck)
        st = evolve(st, mode="driving", ref_deg=meas_deg, ref_rate_deg_per_s=0.0,
                     integral_deg_s=0.0, arrived=False,
                     approach_sign=math.copysign(1.0, error_deg),
                     kick_anchor_deg=meas_deg, kick_since_s=now_s)

    if tun.brake and st.mode == "driving" and st.phase_until_s == 0.0:
        # The brake needs voltage (and time) to release before the motor may pull.
        st = evolve(st, mode="releasing", phase_until_s=now_s + tun.brake_release_s)
    if st.mode == "releasing":
        if now_s < st.phase_until_s:
            return evolve(st, ref_deg=meas_deg, ref_rate_deg_per_s=0.0), AxisOutput(0.0, True, True)
        st = evolve(st, mode="driving", phase_until_s=-1.0)

    if tun.drive == "relay":
        return _relay(st, target_deg, sp.rate_deg_per_s, error_deg, meas_deg, now_s, tun, creeping,
                      sp.speed_cap_deg_per_s)
    return _pwm(st, sp, target_deg, error_deg, meas_deg, meas_rate_deg_per_s, now_s, dt_s, tun, tracking,
                creeping)


def _keep_brake_off(st: AxisState, now_s: float, tun: AxisTuning, tracking: bool) -> bool:
    # While following a moving target the brake stays off for a while between bursts
    # (engaging it every few seconds wears it and adds release delays).
    return tracking and st.mode == "holding" and now_s - st.hold_since_s < BRAKE_AFTER_HOLD_S


def _hold(st: AxisState, meas_deg: float, now_s: float, tun: AxisTuning,
          brake_released: bool) -> tuple[AxisState, AxisOutput]:
    if st.mode != "holding":
        st = evolve(st, mode="holding", hold_since_s=now_s)
    st = evolve(st, ref_deg=meas_deg, ref_rate_deg_per_s=0.0, integral_deg_s=0.0, arrived=True,
                 phase_until_s=0.0 if not brake_released else st.phase_until_s)
    return st, (HOLD_BRAKE_RELEASED if brake_released and tun.brake else OFF)


def _crossed(st: AxisState, error_deg: float) -> bool:
    return st.approach_sign != 0.0 and error_deg * st.approach_sign < 0.0


def _pwm(st: AxisState, sp: Setpoint, target_deg: float, error_deg: float, meas_deg: float,
         meas_rate: float, now_s: float, dt_s: float, tun: AxisTuning, tracking: bool,
         creeping: bool) -> tuple[AxisState, AxisOutput]:
    ref, ref_rate, arrived = advance(st.ref_deg, st.ref_rate_deg_per_s, target_deg, sp.rate_deg_per_s,
                                     tun, dt_s, sp.speed_cap_deg_per_s)  # (its limits: see RateLimits)
    arrived = arrived or st.arrived
    if creeping and (abs(error_deg) <= 0.5 * tun.tolerance_deg or _crossed(st, error_deg)):
        # a creeping target's burst ends as soon as the (overtaking) aim point is
        # within half the tolerance: one count per burst keeps the error swing small
        return _hold(st, meas_deg, now_s, tun, brake_released=tun.brake)
    if arrived and not tracking:
        ref, ref_rate = target_deg, 0.0
        if abs(error_deg) <= tun.tolerance_deg:
            return _hold(st, meas_deg, now_s, tun, brake_released=False)
        if _crossed(st, error_deg):
            if st.reversals >= MAX_REVERSALS and abs(error_deg) < tun.restart_deg:
                return _hold(st, meas_deg, now_s, tun, brake_released=False)
            st = evolve(st, approach_sign=-st.approach_sign, reversals=st.reversals + 1,
                         integral_deg_s=0.0)
    follow_err = ref - meas_deg
    integral = st.integral_deg_s
    # velocity feed-forward + PI on the position error + damping on the speed error
    # (the damping brakes the inertia that velocity feed-forward alone lets overshoot)
    rate_cmd = ref_rate + tun.kp_per_s * follow_err + tun.ki_per_s2 * integral + \
        tun.kv * (ref_rate - meas_rate)
    duty = rate_cmd / tun.max_rate_deg_per_s
    if abs(duty) < 1.0:  # anti-windup: integrate only while the drive is not saturated
        integral += follow_err * dt_s
    kick = max(st.kick_duty, tun.min_duty)
    anchor, since = st.kick_anchor_deg, st.kick_since_s
    if abs(meas_deg - anchor) > 0.5 * tun.restart_deg:  # moved: more than count flicker
        anchor, since = meas_deg, now_s
    if duty and abs(duty) < kick and abs(error_deg) > tun.tolerance_deg:
        # Below this the motor hums but does not turn (stiction): push at the minimum,
        # and raise the minimum if even that leaves the axis standing.
        # (crossing the gear play at the minimum speed is not standing still)
        if now_s - since > KICK_WAIT_S + tun.backlash_deg / tun.min_rate_deg_per_s:
            kick, since = min(KICK_MAX_DUTY, kick * KICK_GAIN), now_s
        duty = math.copysign(kick, duty)
    duty = max(-1.0, min(1.0, duty))
    if creeping and duty * st.approach_sign < 0:
        # a burst after a slow target never drives back (a count flickering ahead of the
        # reference would otherwise make it hunt, the SPID counter's own direction with it)
        duty = 0.0
    st = evolve(st, mode="driving", ref_deg=ref, ref_rate_deg_per_s=ref_rate, integral_deg_s=integral,
                 arrived=arrived, kick_duty=kick, kick_anchor_deg=anchor, kick_since_s=since)
    return st, construct(AxisOutput, duty=duty, brake_released=tun.brake, driving=True)  # (every tick it drives)


def _relay(st: AxisState, target_deg: float, target_rate: float, error_deg: float, meas_deg: float,
           now_s: float, tun: AxisTuning, creeping: bool,
           speed_cap_deg_per_s: float | None = None) -> tuple[AxisState, AxisOutput]:
    levels = tun.drive_levels or (1.0,)
    remaining = error_deg * st.approach_sign
    fast, slow = len(levels) - 1, 0
    slow_rate = levels[slow] * tun.max_rate_deg_per_s
    # Go slow once within a couple of fast-coast distances plus a second of slow running,
    # unless the target itself moves faster than the slow speed can follow; and always
    # when asked for less than the top speed (a slow jog from the API, the dashboard or a
    # panel: it ran at full speed, duty 1.0, issue 36.16): a relay has no speed between
    # its levels, so anything under the fast one is the slow (pulsed) one
    slow_zone = 2.0 * st.coast_deg[fast] + slow_rate * 1.0 + tun.restart_deg
    asked_slow = speed_cap_deg_per_s is not None and speed_cap_deg_per_s < levels[fast] * tun.max_rate_deg_per_s
    level = slow if asked_slow or (remaining < slow_zone and abs(target_rate) < 0.8 * slow_rate) else fast
    if creeping:
        # a burst after a slow target ends where coasting brings the axis to the aim
        # (the target plus the creep lead), counting how far the aim moves meanwhile
        # (a stop from speed v within a coast c takes 2c/v)
        coast = st.coast_deg[level]
        coast_s = 2.0 * coast / (levels[level] * tun.max_rate_deg_per_s)
        cut = remaining <= coast - target_rate * st.approach_sign * coast_s or _crossed(st, error_deg)
    else:
        cut = (abs(error_deg) <= tun.tolerance_deg or _crossed(st, error_deg)
               or remaining <= st.coast_deg[level] + 0.5 * tun.tolerance_deg)
    if cut:
        st = evolve(st, cut_deg=meas_deg, cut_level=level, still_since_s=now_s, last_meas_deg=meas_deg)
        return _hold(st, meas_deg, now_s, tun, brake_released=False)
    # a burst never reverses: the way back, if any, starts from holding, past the
    # restart band (a relay flipping direction tick by tick is the hunting that wears it)
    direction = 1 if st.approach_sign > 0 else -1
    if st.relay_dir == -direction and now_s - st.relay_off_s < RELAY_REVERSE_PAUSE_S:
        # the other way than it last ran: off first, let it run down, then reverse
        return evolve(st, mode="driving"), AxisOutput(0.0, tun.brake, True)
    duty = math.copysign(levels[level], direction)
    st = evolve(st, mode="driving", ref_deg=target_deg, ref_rate_deg_per_s=0.0, cut_deg=None,
                 relay_dir=direction, relay_off_s=math.inf)
    return st, AxisOutput(duty, tun.brake, True)


def _learn_coast(st: AxisState, meas_deg: float, now_s: float, tun: AxisTuning) -> AxisState:
    """After a relay cut-off, measure how far the axis coasted and refine the estimate."""
    if st.cut_deg is None:
        return st
    if abs(meas_deg - st.last_meas_deg) > 0.5 * tun.tolerance_deg:  # still coasting
        return evolve(st, last_meas_deg=meas_deg, still_since_s=now_s)
    if now_s - st.still_since_s < COAST_SETTLE_S:
        return st
    coast = max(0.0, (meas_deg - st.cut_deg) * st.approach_sign)
    coasts = list(st.coast_deg)
    coasts[st.cut_level] += COAST_LEARN_GAIN * (coast - coasts[st.cut_level])
    return evolve(st, coast_deg=tuple(coasts), cut_deg=None, last_meas_deg=meas_deg)
