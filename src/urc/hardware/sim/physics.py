"""One axis' mechanics, pure and stepped in fixed substeps.

Two bodies at the axis: the *gear* (motor rotor + gear train, reflected to the axis)
and the *load* (the antenna). Between them is a dead band of width ``backlash_deg``:
``|gear_deg - load_deg| <= backlash/2``. When the gear sits at an edge of the gap and
pushes, both move as one body; otherwise each moves under its own torques (motor and
gear friction on one side, wind and bearing friction on the other). A body that crosses
the edge of the gap hits the other with a perfectly inelastic impact.

Friction is Coulomb with stiction (a body at rest stays at rest while the torque on it
is within its static friction) plus viscous damping; the DC motor's back-EMF damping and
the viscous terms are integrated implicitly so a 1 ms substep is stable for any motor.

The true position (what tests and benchmarks compare against) is ``load_deg``.
"""

from __future__ import annotations

import math
import random

from ..drivers.motors import quantise_relay
from .params import SimAxisParams

DEG2RAD = math.pi / 180.0
RAD2DEG = 180.0 / math.pi
_EPS_DEG = 1e-9


def _stick_slip(v: float, t_drive: float, t_static: float, up: float, down: float, den: float) -> float:
    """New velocity of a body after one substep.

    ``t_drive`` is the velocity-independent torque (N m); ``up``, ``down`` and ``den``
    are the parts that stay the same while the torques do (:func:`_slip_terms`, worked
    out once, not in every substep): kinetic friction can stop a body but never reverse
    it; a body at rest breaks away only above ``t_static``.
    """
    if v == 0.0:
        if -t_static <= t_drive <= t_static:
            return 0.0
        if t_drive > 0.0:
            vn = up / den
            return vn if vn > 0.0 else 0.0
        vn = down / den
        return vn if vn < 0.0 else 0.0
    if v > 0.0:
        vn = (v + up) / den
        return vn if vn > 0.0 else 0.0
    vn = (v + down) / den
    return vn if vn < 0.0 else 0.0


def _slip_terms(t_drive: float, b_damp: float, t_kinetic: float, k_dt: float) -> tuple[float, float, float]:
    """:func:`_stick_slip`'s ``up``, ``down`` and ``den`` for a body under ``t_drive``:
    ``b_damp`` is the damping (N m per deg/s, implicit), ``k_dt`` = dt * RAD2DEG / J.
    The new speed is (v + k_dt * (t_drive -+ t_kinetic)) / (1 + k_dt * b_damp)."""
    return k_dt * (t_drive - t_kinetic), k_dt * (t_drive + t_kinetic), 1.0 + k_dt * b_damp


class AxisPhysics:
    """Mechanics of one axis. Plain float attributes; ``step_n`` keeps them in locals."""

    def __init__(self, p: SimAxisParams, *, start_deg: float, dt_s: float,
                 wind_update_s: float, wind_rng: random.Random, wind_enabled: bool = True,
                 relay_levels: tuple[float, ...] = (), pulse_res_deg: float | None = None):
        self.p = p
        self.dt_s = dt_s
        self.jg_kgm2 = p.gear_j_kgm2
        self.jl_kgm2 = p.load_j_kgm2
        self.half_gap_deg = p.backlash_deg / 2.0
        self.relay = p.drive == "relay"
        self.relay_levels = tuple(sorted(relay_levels)) or (1.0,)
        # DC motor: T = a_per_v * V - b * w (w in deg/s)
        self._dc_nm_per_v = p.efficiency * p.gear_ratio * p.kt_nm_per_a / p.r_ohm
        self._dc_b = (p.efficiency * p.gear_ratio ** 2 * p.kt_nm_per_a ** 2 / p.r_ohm) * DEG2RAD
        self._pulse_period_ticks = max(2, round(p.relay_pulse_period_s / dt_s))
        # --- mechanical state ---
        self.gear_deg = float(start_deg)
        self.load_deg = float(start_deg)
        self.gear_deg_per_s = 0.0
        self.load_deg_per_s = 0.0
        self.tick = 0
        # --- inputs and faults ---
        self.cmd_duty = 0.0          # what the controller asked for
        self.runaway_duty: float | None = None
        self.reversed = False
        self.jammed = False
        self.powered = True          # False: drive electronics off (motor terminals open)
        #: the bridge has every switch off (LMD18200 BRAKE high, PWM low): terminals open
        self.bridge_open = False
        self.brake_engaged = p.has_brake   # a powerless brake holds
        # --- wind (Ornstein-Uhlenbeck gust around a mean) ---
        self._wind_rng = wind_rng
        self._wind_every = max(1, round(wind_update_s / dt_s))
        self._wind_countdown = self._wind_every
        self.wind_enabled = wind_enabled
        self.wind_mean_nm = p.wind_mean_nm
        self.wind_gust_nm = p.wind_gust_nm
        self._gust_nm = 0.0
        self.wind_nm = self.wind_mean_nm if wind_enabled else 0.0
        # --- single-channel pulse counter (direction from the motor command) ---
        self.pulse_res_deg = pulse_res_deg
        self.pulse_count = 0
        #: every pulse edge, unsigned: what the reed contact really gives a counter
        self.pulse_edges = 0
        self.pulse_dir = 1
        self._pulse_k = 0
        self.reset_pulse_counter()
        self._apply_drive()

    # ------------------------------------------------------------------ inputs
    def sensor_side_deg(self) -> float:
        return self.load_deg if self.p.sensor.on_load else self.gear_deg

    def reset_pulse_counter(self) -> None:
        self.pulse_count = 0
        self.pulse_edges = 0
        if self.pulse_res_deg:
            self._pulse_k = math.floor(self.sensor_side_deg() / self.pulse_res_deg)

    def set_command(self, duty: float) -> None:
        duty = max(-1.0, min(1.0, float(duty)))
        self.cmd_duty = duty
        if duty != 0.0:
            self.pulse_dir = 1 if duty > 0 else -1
        self._apply_drive()

    def effective_duty(self) -> float:
        """The duty the motor really gets: after faults (runaway, reversed wiring)."""
        if not self.powered or self.bridge_open:
            return 0.0
        duty = self.cmd_duty if self.runaway_duty is None else self.runaway_duty
        return -duty if self.reversed else duty

    def _apply_drive(self) -> None:
        """Turn the effective duty into the motor law T = clip(ta - tb*v, +-cap)."""
        duty = self.effective_duty()
        old_level = getattr(self, "_level", None)
        p = self.p
        self._pulse_p = 0
        self._pulse_on = 0
        if self.relay:
            level = quantise_relay(duty, self.relay_levels)
            self._level = level
            if level == 0.0:
                self._ta = self._tb = 0.0
            else:
                self._ta = math.copysign(p.ac_slope_nm_per_deg_per_s * p.ac_sync_deg_per_s, level)
                self._tb = p.ac_slope_nm_per_deg_per_s
                if abs(level) < 1.0:   # slow speed: pulse the relay
                    self._pulse_p = self._pulse_period_ticks
                    self._pulse_on = max(1, round(abs(level) * self._pulse_period_ticks))
            self._cap = p.ac_torque_nm
        else:
            self._level = duty
            self._ta = self._dc_nm_per_v * duty * p.supply_v
            # powered H-bridge at duty 0 shorts the winding (dynamic braking); unpowered: open
            self._tb = self._dc_b if self.powered and not self.bridge_open else 0.0
            self._cap = math.inf
        if self._level != old_level:
            self._phase0 = self.tick

    # ------------------------------------------------------------------ queries
    @property
    def held(self) -> bool:
        return self.jammed or self.brake_engaged

    def relay_on(self) -> bool:
        if self._level == 0.0:
            return False
        if not self._pulse_p:
            return True
        return (self.tick - self._phase0) % self._pulse_p < self._pulse_on

    def current_a(self) -> float:
        """Magnitude of the motor current, amperes."""
        if not self.relay:
            return abs(self.dc_current_a())
        if not self.relay_on():
            return 0.0
        p = self.p
        vg = 0.0 if self.held else self.gear_deg_per_s
        tm = p.ac_torque_nm if self.held else min(abs(self._ta - self._tb * vg), self._cap)
        frac = min(1.0, tm / self._cap) if self._cap > 0 else 1.0
        return p.ac_noload_current_a + (p.ac_stall_current_a - p.ac_noload_current_a) * frac

    def dc_current_a(self) -> float:
        """A DC motor's current with its sign, amperes: positive flows the way a positive
        drive pushes it, negative while the motor generates (back-EMF above the applied
        voltage, e.g. decelerating or overhauled). A bridge's high-side sense (BTS7960
        IS) sees only the positive part."""
        if self.relay:
            return self.current_a()          # an AC motor's: no sign to give
        p = self.p
        if not self.powered or self.bridge_open:
            return 0.0
        vg = 0.0 if self.held else self.gear_deg_per_s
        volts = self.effective_duty() * p.supply_v
        w_motor_rad = vg * DEG2RAD * p.gear_ratio
        return (volts - p.kt_nm_per_a * w_motor_rad) / p.r_ohm

    def driven_side_current_a(self) -> float:
        """The current through the bridge's driven high side, positive the way it drives
        (whichever way the motor is wired): negative while the motor generates and
        pushes current back through it; 0 with nothing driven."""
        duty = self.effective_duty()
        return 0.0 if duty == 0.0 else math.copysign(1.0, duty) * self.dc_current_a()

    # ------------------------------------------------------------------ integration
    def step_n(self, n: int) -> None:
        """Advance ``n`` substeps with the current inputs (they are constant meanwhile)."""
        if n <= 0:
            return
        p = self.p
        dt = self.dt_s
        tick = self.tick
        xg, vg = self.gear_deg, self.gear_deg_per_s
        xl, vl = self.load_deg, self.load_deg_per_s
        held = self.held
        if held:
            vg = vl = 0.0
        # motor law
        ta_on, tb_on, cap = self._ta, self._tb, self._cap
        capped = cap != math.inf
        pulse_p, pulse_on, phase0 = self._pulse_p, self._pulse_on, self._phase0
        ta, tb = ta_on, tb_on
        if self.relay and ta_on == 0.0:
            tb = 0.0
        # friction and inertia
        tsg, tkg, bvg = p.gear_static_nm, p.gear_kinetic_nm, p.gear_viscous_nm_per_deg_per_s
        tsl, tkl, bvl = p.load_static_nm, p.load_kinetic_nm, p.load_viscous_nm_per_deg_per_s
        ts_c, tk_c = tsg + tsl, tkg + tkl
        jg, jl = self.jg_kgm2, self.jl_kgm2
        kg = dt * RAD2DEG / jg
        kl = dt * RAD2DEG / jl
        kc = dt * RAD2DEG / (jg + jl)
        wg, wl = jg / (jg + jl), jl / (jg + jl)
        hb = self.half_gap_deg
        hb_in = hb - _EPS_DEG
        hmin = -math.inf if p.hard_min_deg is None else p.hard_min_deg
        hmax = math.inf if p.hard_max_deg is None else p.hard_max_deg
        # wind
        wind_on = self.wind_enabled
        wind = self.wind_nm if wind_on else 0.0
        wc, w_every = self._wind_countdown, self._wind_every
        gust = self._gust_nm
        w_mean = self.wind_mean_nm
        w_alpha = math.exp(-self._wind_every * dt / p.wind_tau_s)
        w_beta = self.wind_gust_nm * math.sqrt(1.0 - w_alpha * w_alpha)
        gauss = self._wind_rng.gauss
        # pulse counter
        pres = self.pulse_res_deg
        on_load = p.sensor.on_load
        if pres:
            pk, pcount, pdir = self._pulse_k, self.pulse_count, self.pulse_dir
            pedges = self.pulse_edges
            e_lo, e_hi = pk * pres, (pk + 1) * pres

        # Nothing can move: skip the loop entirely (no wind, no relay pulsing).
        if (not wind_on and not pulse_p and vg == 0.0 and vl == 0.0
                and (held or (-tsg <= min(ta, cap) and max(ta, -cap) <= tsg))):
            self.tick = tick + n
            self.gear_deg_per_s, self.load_deg_per_s = vg, vl
            return

        # _stick_slip's terms for the torques they were worked out for (NaN: none yet)
        terms_tda = terms_tdb = terms_wind = math.nan
        for _ in range(n):
            tick += 1
            if wind_on:
                wc -= 1
                if wc <= 0:
                    wc = w_every
                    gust = gust * w_alpha + w_beta * gauss(0.0, 1.0)
                    wind = w_mean + gust
            if pulse_p:
                if (tick - phase0) % pulse_p < pulse_on:
                    ta, tb = ta_on, tb_on
                else:
                    ta = tb = 0.0
            if held:
                continue
            if vg == 0.0 and vl == 0.0 and -tsg <= ta <= tsg and -tsl <= wind <= tsl:
                continue          # both at rest and stuck: nothing happens
            # motor torque, linearised in the gear velocity (AC: clipped at its cap)
            tda, tdb = ta, tb
            if capped and tb != 0.0:
                tm = ta - tb * vg
                if tm > cap:
                    tda, tdb = cap, 0.0
                elif tm < -cap:
                    tda, tdb = -cap, 0.0
            if tda != terms_tda or tdb != terms_tdb or wind != terms_wind:
                # the torques changed (a relay pulse, the AC cap, a gust): new terms
                terms_tda, terms_tdb, terms_wind = tda, tdb, wind
                g_up, g_down, g_den = _slip_terms(tda, tdb + bvg, tkg, kg)
                l_up, l_down, l_den = _slip_terms(wind, bvl, tkl, kl)
                tc = tda + wind
                c_up, c_down, c_den = _slip_terms(tc, tdb + bvg + bvl, tk_c, kc)
            # each body on its own ... (a moving body's case of _stick_slip written out:
            # these are the simulator's hottest lines; at rest, breakaway is its own)
            if vg > 0.0:
                vg1 = vn if (vn := (vg + g_up) / g_den) > 0.0 else 0.0
            elif vg < 0.0:
                vg1 = vn if (vn := (vg + g_down) / g_den) < 0.0 else 0.0
            else:
                vg1 = _stick_slip(vg, tda, tsg, g_up, g_down, g_den)
            if vl > 0.0:
                vl1 = vn if (vn := (vl + l_up) / l_den) > 0.0 else 0.0
            elif vl < 0.0:
                vl1 = vn if (vn := (vl + l_down) / l_den) < 0.0 else 0.0
            else:
                vl1 = _stick_slip(vl, wind, tsl, l_up, l_down, l_den)
            # ... or as one, when at an edge of the gap and pressing into it
            d = xg - xl
            if (d >= hb_in and vg1 > vl1) or (d <= -hb_in and vg1 < vl1):
                v0 = vg * wg + vl * wl
                if v0 > 0.0:
                    vg1 = vn if (vn := (v0 + c_up) / c_den) > 0.0 else 0.0
                elif v0 < 0.0:
                    vg1 = vn if (vn := (v0 + c_down) / c_den) < 0.0 else 0.0
                else:
                    vg1 = _stick_slip(v0, tc, ts_c, c_up, c_down, c_den)
                vl1 = vg1
            vg, vl = vg1, vl1
            xg += vg * dt
            xl += vl * dt
            # gap overrun: inelastic impact, centre of mass kept
            d = xg - xl
            if d > hb:
                e = d - hb
                xg -= e * wl
                xl += e * wg
                vg = vl = vg * wg + vl * wl
            elif d < -hb:
                e = -hb - d
                xg += e * wl
                xl -= e * wg
                vg = vl = vg * wg + vl * wl
            # hard end stops act on the load; the gear stops at the load through the gap
            if xl > hmax:
                xl = hmax
                if vl > 0.0:
                    vl = 0.0
                if xg > xl + hb:
                    xg = xl + hb
                    if vg > 0.0:
                        vg = 0.0
            elif xl < hmin:
                xl = hmin
                if vl < 0.0:
                    vl = 0.0
                if xg < xl - hb:
                    xg = xl - hb
                    if vg < 0.0:
                        vg = 0.0
            if pres:
                xs = xl if on_load else xg
                while xs >= e_hi:
                    pk += 1
                    e_lo, e_hi = e_hi, e_hi + pres
                    pcount += pdir
                    pedges += 1
                while xs < e_lo:
                    pk -= 1
                    e_lo, e_hi = e_lo - pres, e_lo
                    pcount += pdir
                    pedges += 1

        self.tick = tick
        self.gear_deg, self.gear_deg_per_s = xg, vg
        self.load_deg, self.load_deg_per_s = xl, vl
        self._wind_countdown = wc
        self._gust_nm = gust
        self.wind_nm = wind
        if pres:
            self._pulse_k, self.pulse_count, self.pulse_edges = pk, pcount, pedges

    # ------------------------------------------------------------------ helpers
    def at_rest(self) -> bool:
        return self.gear_deg_per_s == 0.0 and self.load_deg_per_s == 0.0

    def set_wind(self, enabled: bool, mean_nm: float | None = None,
                 gust_nm: float | None = None) -> None:
        self.wind_enabled = enabled
        if mean_nm is not None:
            self.wind_mean_nm = float(mean_nm)
        if gust_nm is not None:
            self.wind_gust_nm = float(gust_nm)
        self.wind_nm = (self.wind_mean_nm + self._gust_nm) if enabled else 0.0
