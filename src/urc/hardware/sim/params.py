"""The simulator's physical truth per profile: motors, gears, friction, sensor physics.

This is deliberately *not* caps: the controller must work without knowing any of it.
The numbers are derived from a few physical choices (gear ratio, supply, winding
resistance, inertias, backlash) plus design targets taken from the caps, so that

* the free-running speed at duty +-1 equals ``max_rate_deg_per_s``,
* the axis breaks away at ~0.8 x max(min_rate/max_rate, 0.08) duty and not below,
* the stall torque gives an acceleration far above ``accel_deg_per_s2``,
* relay (AC) motors coast about ``overshoot_deg`` after switch-off.

Torques are at the axis (gear output / antenna side), N*m; angles in degrees; damping
coefficients in N*m per (deg/s).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Literal

from ...caps import AxisCaps, RotatorCaps
from ...errors import ConfigError
from ...profiles import PROFILES
from .stepper import StepperParams, satnogs_v3_stepper

DEG2RAD = math.pi / 180.0
#: default wind torque (mean, gust 1-sigma) as a share of the antenna bearing's static
#: friction: the antenna stays put in the gear play except in rare strong gusts, and the
#: wind changes the speed of a moving axis by well under 1 %.
WIND_MEAN_SHARE = 0.25
WIND_GUST_SHARE = 0.25


@dataclass(frozen=True)
class SimSensorParams:
    """Sensor physics beyond what SensorCaps says."""

    #: True: the sensor sees the antenna (load); False: the gear/motor side of the play.
    on_load: bool = True
    #: encoder: angle (sensor side) of an index/home mark, None = no index.
    index_deg: float | None = None
    #: pot: "ratiometric" (G4JNT loaded pot, P = 4096 N/(2048-N)) or "linear".
    pot_law: Literal["ratiometric", "linear"] = "linear"
    #: pot: axis angle at wiper fraction 0 and the angle span of the wiper travel.
    pot_start_deg: float = 0.0
    pot_span_deg: float = 360.0
    #: pot: 1-sigma ADC noise, counts.
    adc_noise_counts: float = 0.0
    #: magnetometer: hard-iron offset as a fraction of the horizontal field, and the
    #: local magnetic declination (true = magnetic + declination), degrees.
    hard_iron_x: float = 0.0
    hard_iron_y: float = 0.0
    declination_deg: float = 0.0
    #: magnetometer in 3-D (the board held by hand, SARCNET calibration): hard iron
    #: along the board's z, soft iron (row-major 3x3, applied to the earth's field in
    #: the board's frame) and the field's dip below the horizon (65 deg: mid latitudes)
    hard_iron_z: float = 0.0
    soft_iron: tuple[float, ...] = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)
    dip_deg: float = 65.0
    #: accelerometer: per-axis bias (g) and scale (reads scale x g + bias)
    accel_bias_g: tuple[float, float, float] = (0.0, 0.0, 0.0)
    accel_scale: tuple[float, float, float] = (1.0, 1.0, 1.0)
    #: AS5600: probability that a read is off by one count.
    glitch_prob: float = 0.0


@dataclass(frozen=True)
class SimAxisParams:
    drive: Literal["pwm", "relay"]
    #: inertia of motor + gears reflected to the axis, and of the antenna (load), kg m^2.
    gear_j_kgm2: float
    load_j_kgm2: float
    # --- DC motor (pwm): T_out = eff*N*kt*(V - kt*N*w)/R ---
    supply_v: float = 0.0
    r_ohm: float = 1.0
    kt_nm_per_a: float = 0.0          # = ke in V s/rad
    gear_ratio: float = 1.0
    efficiency: float = 1.0
    # --- AC motor (relay): T = min(cap, slope*(sync - w)), coasts when off ---
    ac_torque_nm: float = 0.0
    ac_sync_deg_per_s: float = 0.0
    ac_slope_nm_per_deg_per_s: float = 0.0
    ac_noload_current_a: float = 0.0
    ac_stall_current_a: float = 0.0
    #: relay levels < 1 are produced by pulsing the relay on level x this period.
    relay_pulse_period_s: float = 0.5       # G4JNT: the slow speed pulses at 2 Hz
    # --- friction at the axis ---
    gear_static_nm: float = 0.0
    gear_kinetic_nm: float = 0.0
    gear_viscous_nm_per_deg_per_s: float = 0.0
    load_static_nm: float = 0.0
    load_kinetic_nm: float = 0.0
    load_viscous_nm_per_deg_per_s: float = 0.0
    backlash_deg: float = 0.0
    # --- mechanical end stops (load angle) and limit switches; None = none ---
    hard_min_deg: float | None = None
    hard_max_deg: float | None = None
    switch_min_deg: float | None = None
    switch_max_deg: float | None = None
    has_brake: bool = False
    # --- wind on the antenna: mean + Ornstein-Uhlenbeck gust (1-sigma, correlation time)
    wind_mean_nm: float = 0.0
    wind_gust_nm: float = 0.0
    wind_tau_s: float = 2.0
    sensor: SimSensorParams = SimSensorParams()
    #: a stepper axis (:mod:`.stepper`): the simulator drives it through its step/dir
    #: stage (:mod:`.stepdrive`), the step count its sensor; the DC fields above are
    #: then only its unpowered stand-in, moved to where the steps put it
    stepper: StepperParams | None = None

    @property
    def static_nm(self) -> float:
        return self.gear_static_nm + self.load_static_nm

    @property
    def kinetic_nm(self) -> float:
        return self.gear_kinetic_nm + self.load_kinetic_nm

    @property
    def stall_torque_nm(self) -> float:
        """Torque at the axis with full drive and the axis held still."""
        if self.drive == "relay":
            return self.ac_torque_nm
        return self.efficiency * self.gear_ratio * self.kt_nm_per_a * self.supply_v / self.r_ohm

    @property
    def stall_current_a(self) -> float:
        if self.drive == "relay":
            return self.ac_stall_current_a
        return self.supply_v / self.r_ohm


@dataclass(frozen=True)
class SimRotatorParams:
    name: str
    az: SimAxisParams
    el: SimAxisParams
    #: fixed physics substep; results do not depend on how often poll is called.
    substep_s: float = 0.001
    #: the wind gust process is updated this often (it is slow; saves CPU).
    wind_update_s: float = 0.01

    def axis(self, name: str) -> SimAxisParams:
        if name == "az":
            return self.az
        if name == "el":
            return self.el
        raise KeyError(name)


def breakaway_duty(ax: AxisCaps) -> float:
    """The duty below which a DC axis must not move (design target, see module doc)."""
    return max(ax.min_rate_deg_per_s / ax.max_rate_deg_per_s, 0.08)


def _dc_axis(ax: AxisCaps, *, gear_ratio: float, supply_v: float, r_ohm: float,
             motor_j_kgm2: float, load_j_kgm2: float, efficiency: float = 0.6,
             backlash_deg: float, sensor: SimSensorParams,
             hard: tuple[float, float] | None, switches: tuple[float, float] | None = None,
             stiction_margin: float = 0.8, kinetic_ratio: float = 0.7,
             viscous_share: float = 0.15, load_share: float = 0.25) -> SimAxisParams:
    """A PWM-driven DC gearmotor axis tuned to the caps.

    With A = stall torque at duty 1, friction Ts = m*d*A (d = breakaway duty), Tk = r*Ts
    and viscous Bv = s*A/w, the steady state A - Tk - Bv*w = B*w with B = eff*N^2*kt^2/R
    gives kt = c*V/(N*w) where c = 1 - r*m*d - s: the no-load speed is w/c.
    """
    w_rad = ax.max_rate_deg_per_s * DEG2RAD
    d = breakaway_duty(ax)
    c = 1.0 - kinetic_ratio * stiction_margin * d - viscous_share
    kt = c * supply_v / (gear_ratio * w_rad)
    stall_nm = efficiency * gear_ratio * kt * supply_v / r_ohm
    ts = stiction_margin * d * stall_nm
    tk = kinetic_ratio * ts
    bv = viscous_share * stall_nm / ax.max_rate_deg_per_s
    return SimAxisParams(
        drive="pwm", gear_j_kgm2=motor_j_kgm2 * gear_ratio ** 2, load_j_kgm2=load_j_kgm2,
        supply_v=supply_v, r_ohm=r_ohm, kt_nm_per_a=kt, gear_ratio=gear_ratio,
        efficiency=efficiency,
        gear_static_nm=(1 - load_share) * ts, gear_kinetic_nm=(1 - load_share) * tk,
        gear_viscous_nm_per_deg_per_s=bv,
        load_static_nm=load_share * ts, load_kinetic_nm=load_share * tk,
        backlash_deg=backlash_deg,
        hard_min_deg=hard[0] if hard else None, hard_max_deg=hard[1] if hard else None,
        switch_min_deg=switches[0] if switches else None,
        switch_max_deg=switches[1] if switches else None,
        has_brake=ax.brake,
        wind_mean_nm=WIND_MEAN_SHARE * load_share * ts,
        wind_gust_nm=WIND_GUST_SHARE * load_share * ts, sensor=sensor)


def _ac_axis(ax: AxisCaps, *, gear_j_kgm2: float, load_j_kgm2: float, coast_deg: float,
             backlash_deg: float, sensor: SimSensorParams, hard: tuple[float, float] | None,
             noload_current_a: float, stall_current_a: float, torque_ratio: float = 6.0,
             stiction_ratio: float = 1.3, load_share: float = 0.25,
             pulse_period_s: float = 0.5) -> SimAxisParams:
    """A relay-switched AC motor axis: constant torque up to speed, friction-only coast.

    Kinetic friction is chosen so that the coast from max rate is ``coast_deg``:
    Tk = J * v^2 / (2 * coast). The motor torque is ``torque_ratio`` x Tk up to just
    below the synchronous speed (4 % slip), where it falls steeply to balance friction
    exactly at max rate.
    """
    v = ax.max_rate_deg_per_s
    j = gear_j_kgm2 + load_j_kgm2
    tk = j * DEG2RAD * v * v / (2.0 * coast_deg)
    ts = stiction_ratio * tk
    sync = 1.04 * v
    slope = tk / (sync - v)
    return SimAxisParams(
        drive="relay", gear_j_kgm2=gear_j_kgm2, load_j_kgm2=load_j_kgm2,
        ac_torque_nm=torque_ratio * tk, ac_sync_deg_per_s=sync,
        ac_slope_nm_per_deg_per_s=slope, ac_noload_current_a=noload_current_a,
        ac_stall_current_a=stall_current_a, relay_pulse_period_s=pulse_period_s,
        gear_static_nm=(1 - load_share) * ts, gear_kinetic_nm=(1 - load_share) * tk,
        load_static_nm=load_share * ts, load_kinetic_nm=load_share * tk,
        backlash_deg=backlash_deg,
        hard_min_deg=hard[0] if hard else None, hard_max_deg=hard[1] if hard else None,
        has_brake=ax.brake,
        wind_mean_nm=WIND_MEAN_SHARE * load_share * ts,
        wind_gust_nm=WIND_GUST_SHARE * load_share * ts, sensor=sensor)


#: The G4JNT document's Table 1 pot: theta = (C + M P / 16384) / 10 deg with M = -15897
#: and C = 3758 (g4jnt_codec's units), so P = 0 at theta 375.8 and P = 4096 at -21.6:
#: the resistance falls as the angle grows ("the gradient is negative"). A fresh
#: simulated G4JNT therefore holds Table 1's M and C, and its stream reproduces Table 1.
G4JNT_TABLE_1_POT = SimSensorParams(on_load=True, pot_law="ratiometric", pot_start_deg=375.8,
                                    pot_span_deg=-15897 / 163840 * 4096, adc_noise_counts=0.4)


def _pot(ax: AxisCaps, law: Literal["ratiometric", "linear"], noise_counts: float,
         on_load: bool) -> SimSensorParams:
    """A pot whose coarsest ADC step equals the caps resolution, centred on the range."""
    # ratiometric: dN/dx = 2048/(1+x)^2 is smallest (512/unit) at x = 1;
    # linear: 1023 counts over the span.
    span = ax.sensor.resolution_deg * (512.0 if law == "ratiometric" else 1023.0)
    start = ax.min_deg - (span - ax.span_deg) / 2.0
    return SimSensorParams(on_load=on_load, pot_law=law, pot_start_deg=start,
                           pot_span_deg=span, adc_noise_counts=noise_counts)


def _build(caps: RotatorCaps) -> tuple[SimAxisParams, SimAxisParams]:
    """Physical choices per seed machine; unknown caps get a generic machine."""
    az, el = caps.az, caps.el
    name = caps.name
    if name == "tartu-urc":
        # Heavy 24 V gearmotors, 3000 rpm -> 6 deg/s (N = 3000), encoder on the motor side.
        enc = SimSensorParams(on_load=False)
        kw = dict(gear_ratio=3000, supply_v=24.0, r_ohm=2.0, motor_j_kgm2=1.5e-5,
                  load_j_kgm2=30.0, backlash_deg=0.05, sensor=enc)
        return (_dc_axis(az, hard=(-5.0, 405.0), **kw),  # type: ignore[arg-type]
                _dc_axis(el, hard=(-5.0, 185.0), **kw))  # type: ignore[arg-type]
    if name == "sarcnet-mini":
        # Small 12 V gearmotors (0.6 rpm), printed gears with play; az spins freely.
        mag = SimSensorParams(on_load=True, hard_iron_x=0.04, hard_iron_y=-0.03,
                              declination_deg=12.5)
        kw = dict(gear_ratio=5000, supply_v=12.0, r_ohm=8.0, motor_j_kgm2=1.0e-6,
                  load_j_kgm2=0.5, backlash_deg=0.5, sensor=mag)
        return (_dc_axis(az, hard=None, **kw),  # type: ignore[arg-type]
                _dc_axis(el, hard=(-5.0, 185.0), **kw))  # type: ignore[arg-type]
    if name == "bigras":
        # SPID BIG-RAS: 24 V DC motors, reed-pulse sensor on the gear train, limit switches
        # 2 deg outside the soft limits, hard stops 5 deg outside.
        pul = SimSensorParams(on_load=False)
        return (_dc_axis(az, gear_ratio=3750, supply_v=24.0, r_ohm=1.5, motor_j_kgm2=1.2e-5,
                         load_j_kgm2=20.0, backlash_deg=0.2, sensor=pul,
                         hard=(az.min_deg - 5, az.max_deg + 5),
                         switches=(az.min_deg - 2, az.max_deg + 2)),
                _dc_axis(el, gear_ratio=7500, supply_v=24.0, r_ohm=1.5, motor_j_kgm2=1.2e-5,
                         load_j_kgm2=20.0, backlash_deg=0.2, sensor=pul,
                         hard=(el.min_deg - 5, el.max_deg + 5),
                         switches=(el.min_deg - 2, el.max_deg + 2)))
    if name == "berkeley":
        # Fast 12 V hobby gearmotors (N = 600), lots of play, AS5600 on the axis (load).
        mag = SimSensorParams(on_load=True, glitch_prob=0.02)
        kw = dict(gear_ratio=600, supply_v=12.0, r_ohm=3.0, motor_j_kgm2=2.0e-6,
                  load_j_kgm2=0.3, backlash_deg=1.5, sensor=mag)
        return (_dc_axis(az, hard=(-10.0, 370.0), **kw),  # type: ignore[arg-type]
                _dc_axis(el, hard=(-50.0, 230.0), **kw))  # type: ignore[arg-type]  # ~270 deg
    if name == "g4jnt":
        # Relay-switched AC rotator (CDE/Hy-Gain style), loaded pot on the output: the
        # document's own (Table 1), end stops just outside its -10..370 deg travel.
        return (_ac_axis(az, gear_j_kgm2=40.0, load_j_kgm2=15.0, coast_deg=az.overshoot_deg,
                         backlash_deg=0.3, sensor=G4JNT_TABLE_1_POT,
                         hard=(-12.0, 372.0), noload_current_a=0.5, stall_current_a=3.0),
                _ac_axis(el, gear_j_kgm2=40.0, load_j_kgm2=15.0, coast_deg=el.overshoot_deg,
                         backlash_deg=0.3, sensor=_pot(el, "ratiometric", 0.4, True),
                         hard=(-5.0, 95.0), noload_current_a=0.5, stall_current_a=3.0))
    if name == "g5500":
        # Yaesu G-5500: 24 VAC motors on relays, pot geared to the output ring gear.
        return (_ac_axis(az, gear_j_kgm2=60.0, load_j_kgm2=20.0, coast_deg=az.overshoot_deg,
                         backlash_deg=0.5, sensor=_pot(az, "linear", 0.3, False),
                         hard=(-3.0, 453.0), noload_current_a=0.5, stall_current_a=2.5),
                _ac_axis(el, gear_j_kgm2=60.0, load_j_kgm2=20.0, coast_deg=el.overshoot_deg,
                         backlash_deg=0.5, sensor=_pot(el, "linear", 0.3, False),
                         hard=(-2.0, 182.0), noload_current_a=0.5, stall_current_a=2.5))
    if name == "satnogs-v3":
        # NEMA17 steppers at 1/8 microstep through the 54:1 worms (sim/stepper.py), which
        # move the generic DC axis standing in for them (the sim's and the gpio
        # emulation's step/dir stage, sim/stepdrive.py). The homing endstop 2 deg below 0
        # (LimitSwitchHoming's default), only at the low end as on the rotator; hard stops
        # 5 deg outside the range.
        return tuple(dataclasses.replace(_generic_axis(a), switch_max_deg=None,  # type: ignore[return-value]
                                         stepper=satnogs_v3_stepper(8)) for a in (az, el))
    # Generic machine for caps variants nobody described: DC for pwm, AC for relay.
    return tuple(_generic_axis(a) for a in (az, el))  # type: ignore[return-value]


def _generic_axis(ax: AxisCaps) -> SimAxisParams:
    kind = ax.sensor.kind
    if kind == "pot":
        sensor = _pot(ax, "linear", 0.3, True)
    elif kind == "magnetometer":
        sensor = SimSensorParams(on_load=True, declination_deg=0.0)
    else:
        sensor = SimSensorParams(on_load=kind in ("as5600",))
    hard = (ax.min_deg - 5.0, ax.max_deg + 5.0)
    if ax.drive == "relay":
        return _ac_axis(ax, gear_j_kgm2=40.0, load_j_kgm2=15.0,
                        coast_deg=ax.overshoot_deg or 0.3, backlash_deg=0.3, sensor=sensor,
                        hard=hard, noload_current_a=0.8, stall_current_a=2.5)
    return _dc_axis(ax, gear_ratio=3000, supply_v=24.0, r_ohm=2.0, motor_j_kgm2=1.5e-5,
                    load_j_kgm2=20.0, backlash_deg=0.1, sensor=sensor, hard=hard,
                    switches=(ax.min_deg - 2, ax.max_deg + 2) if ax.limit_switches else None)


def params_for_caps(caps: RotatorCaps) -> SimRotatorParams:
    """Physical truth matching these caps (a profile's own numbers when it is one)."""
    az, el = _build(caps)
    return SimRotatorParams(name=caps.name, az=az, el=el)


#: the mechanical truth of each shipped profile.
PHYSICS: dict[str, SimRotatorParams] = {name: params_for_caps(c) for name, c in PROFILES.items()}


def physics_for(profile_name: str) -> SimRotatorParams:
    try:
        return PHYSICS[profile_name]
    except KeyError:
        raise ConfigError(
            f"no simulator physics for profile {profile_name!r}; expected one of "
            f"{', '.join(sorted(PHYSICS))}", key="profile",
            expected=" | ".join(sorted(PHYSICS)), found=profile_name) from None


__all__ = ["SimAxisParams", "SimRotatorParams", "SimSensorParams", "PHYSICS", "physics_for",
           "params_for_caps", "breakaway_duty"]
