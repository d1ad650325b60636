"""A stepper axis as the simulator's truth: steps move it exactly while the torque they
demand stays under the motor's pull-out torque at that speed; beyond it the rotor slips
and the steps of that stretch are lost (the axis stays where it was).

The pull-out curve is the usual hybrid-stepper shape (a datasheet's "pull-out torque vs
speed" graph, e.g. a NEMA17 17HS4401): flat at ``pullout_max_nm`` up to the corner speed,
where the winding's L/R time starts to limit the current, then falling as 1/speed
(constant power). Demanded torque at the motor shaft: inertia (rotor plus the load
reflected through the gear) times the acceleration of the step train, Coulomb friction,
viscous drag, and the load torque (wind) reflected through the worm gear.

Numbers for the SatNOGS v3 axis (:func:`satnogs_v3_stepper`): a 0.40 N m NEMA17
(17HS4401 class: 0.40 N m holding, rotor 54 g cm^2), pull-out 0.30 N m to 300 full
steps/s then falling, 54:1 worm at 40 % efficiency, an antenna of 0.1 kg m^2 with 2 N m
of wind at the axis. These are a builder's typical parts, not measured ones.
"""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class StepperParams:
    #: microsteps per full step and full steps per motor turn
    microsteps: int
    full_steps_per_turn: int
    gear_ratio: float
    gear_efficiency: float
    pullout_max_nm: float
    #: full steps/s where the pull-out torque starts to fall as 1/speed
    corner_full_steps_per_s: float
    rotor_j_kgm2: float
    load_j_kgm2: float
    #: at the motor shaft
    friction_nm: float
    viscous_nm_per_rad_per_s: float
    #: at the axis (the antenna side of the worm)
    load_torque_nm: float

    @property
    def steps_per_deg(self) -> float:
        return self.microsteps * self.full_steps_per_turn * self.gear_ratio / 360.0

    def pullout_nm(self, full_steps_per_s: float) -> float:
        f = abs(full_steps_per_s)
        return self.pullout_max_nm if f <= self.corner_full_steps_per_s else \
            self.pullout_max_nm * self.corner_full_steps_per_s / f

    def demanded_nm(self, steps_per_s: float, steps_per_s2: float) -> float:
        """Torque at the motor shaft to follow a step train at this rate and acceleration."""
        rad_per_step = 2.0 * math.pi / (self.full_steps_per_turn * self.microsteps)
        w = steps_per_s * rad_per_step
        a = steps_per_s2 * rad_per_step
        j = self.rotor_j_kgm2 + self.load_j_kgm2 / self.gear_ratio ** 2
        load = self.load_torque_nm / (self.gear_ratio * self.gear_efficiency)
        moving = self.friction_nm if w != 0.0 else 0.0
        return abs(j * a) + moving + abs(self.viscous_nm_per_rad_per_s * w) + load

    def margin(self, steps_per_s: float, steps_per_s2: float) -> float:
        """Pull-out torque over demanded torque: the steps are kept while it is > 1."""
        fs = steps_per_s / self.microsteps
        return self.pullout_nm(fs) / self.demanded_nm(steps_per_s, steps_per_s2)


def satnogs_v3_stepper(microsteps: int = 8) -> StepperParams:
    """The SatNOGS v3 axis (see the module's text): 1/8 microstep as its firmware has it."""
    return StepperParams(microsteps=microsteps, full_steps_per_turn=200, gear_ratio=54.0, gear_efficiency=0.4,
                         pullout_max_nm=0.30, corner_full_steps_per_s=300.0, rotor_j_kgm2=5.4e-6,
                         load_j_kgm2=0.1, friction_nm=0.02, viscous_nm_per_rad_per_s=2e-4,
                         load_torque_nm=2.0)


#: how fast the rotor follows a change of step rate, s
ROTOR_RESPONSE_S = 0.01


class StepperAxis:
    """The axis' true angle, moved by the steps a driver receives.

    :meth:`steps` takes a stretch of ``n`` steps in one direction over ``duration_s``
    (what the pulse train put out between two looks): its rate is n / duration, its
    acceleration the change from the previous stretch's rate. While the driver is
    disabled or unpowered no step moves the rotor (and the rotor holds nothing: with
    the worm self-locking, the axis stays). Nor while the axis is ``jammed``, nor past
    its hard stops ``stops_deg`` (either None: none that side): a stalled rotor slips."""

    def __init__(self, p: StepperParams, start_deg: float,
                 stops_deg: tuple[float | None, float | None] = (None, None)):
        self.p = p
        self.angle_deg = float(start_deg)
        self.stops_deg = stops_deg
        self.jammed = False
        self.steps_taken = 0      # signed: steps that moved the rotor
        self.steps_lost = 0       # unsigned: steps received that did not
        self._rate = 0.0          # steps/s of the previous stretch, signed
        self._force_lose = 0
        self._t_s = -math.inf
        self.worst_margin = math.inf
        #: the translator's microstep state within one electrical turn (4 full steps),
        #: from its home state (0): the rotor sits where the translator's state puts it
        #: (after a slip, a whole number of electrical turns off)
        self.translator_index = 0
        #: microsteps the rotor moved when a reset translator pulled it to its home state
        self.snapped_steps = 0

    @property
    def electrical_turn(self) -> int:
        return 4 * self.p.microsteps

    def reset_translator(self) -> int:
        """The translator back at its home state (the motor supply lost on a chip whose
        logic it feeds, a RESET): with the outputs on again, the rotor is pulled to the
        nearest position in that state, within half an electrical turn (2 full steps).
        Returns the microsteps it moved."""
        turn = self.electrical_turn
        delta = (-self.translator_index + turn // 2) % turn - turn // 2
        self.translator_index = 0
        self.snapped_steps += delta
        self.angle_deg += delta / self.p.steps_per_deg
        return delta

    def lose_next_steps(self, n: int) -> None:
        """Fault injection: the next ``n`` steps received slip (a jam, ice, a gust)."""
        self._force_lose += int(n)

    def steps(self, n: int, direction: int, period_s: float, t_s: float, enabled: bool = True) -> None:
        """``n`` steps at ``period_s`` apart, the last at ``t_s``."""
        if n <= 0:
            return
        if not enabled:
            self.steps_lost += n
            self._rate = 0.0
            return
        self.translator_index = (self.translator_index + direction * n) % self.electrical_turn
        rate = direction / period_s
        gap_s = t_s - self._t_s
        prev = self._rate if gap_s < 2 * period_s + (n - 1) * period_s + 1e-9 else 0.0   # a pause: from rest
        # the rotor answers a change of rate over its own response time (a loaded NEMA17
        # rings at ~100 Hz): a rate stepped between two pulses is an acceleration over that
        accel = (rate - prev) / max(gap_s, ROTOR_RESPONSE_S)
        margin = self.p.margin(rate, accel)
        self.worst_margin = min(self.worst_margin, margin)
        self._rate, self._t_s = rate, t_s
        kept = n if margin > 1.0 and not self.jammed else 0
        stop = self.stops_deg[1 if direction > 0 else 0]
        if stop is not None and kept:
            room_deg = max(0.0, (stop - self.angle_deg) * direction)
            kept = min(kept, math.floor(room_deg * self.p.steps_per_deg + 1e-9))
        if self._force_lose and kept:
            lost = min(self._force_lose, kept)
            self._force_lose -= lost
            kept -= lost
        self.steps_lost += n - kept
        if kept == 0:
            self._rate = 0.0          # a slipping rotor has lost its speed
        self.steps_taken += direction * kept
        self.angle_deg += direction * kept / self.p.steps_per_deg
