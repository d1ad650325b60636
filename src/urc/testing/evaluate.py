"""Pointing error, as DESIGN.md defines it, for a pass flown on the simulator.

The great-circle angle between where the simulated antenna truly points (simulator
truth, after the flip mapping) and where the target truly is, sampled every control tick
while the target is above the horizon mask.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable, NamedTuple

import numpy as np

from ..angles import great_circle_deg, wrap180_deg
from ..clock import VirtualClock
from ..rotator.loop import run_virtual


@dataclass(frozen=True)
class PointingStats:
    rms_deg: float
    p95_deg: float
    max_deg: float
    within_0_1_pct: float
    within_0_5_pct: float
    aos_error_deg: float     # error at the first sample of the pass
    samples: int

    @classmethod
    def of(cls, err_deg: np.ndarray) -> "PointingStats":
        e = np.asarray(err_deg, dtype=float)
        return cls(float(math.sqrt(np.mean(e ** 2))), float(np.percentile(e, 95)), float(e.max()),
                   float(100 * np.mean(e <= 0.1)), float(100 * np.mean(e <= 0.5)), float(e[0]), len(e))

    def as_dict(self) -> dict:
        return {k: round(v, 4) if isinstance(v, float) else v for k, v in self.__dict__.items()}


def fly(rot, clock: VirtualClock, step: Callable[[float], None], unix_at: Callable[[float], float],
        until_unix_s: float, reported: list | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Run the loop (calling ``step(now_s)`` after each tick, like ``urc run``) until
    ``until_unix_s``; return UTC times and the true sky pointing at every tick.
    ``reported`` (a list) also collects (utc_s, az_deg, el_deg) as the controller reports it."""
    t, az, el = [], [], []
    geometry = rot.geometry

    def on_tick(s) -> None:
        step(s.t_s)
        truth = s.sim_truth
        a, e = geometry.to_sky(truth["az"]["deg"], truth["el"]["deg"])
        t.append(unix_at(s.t_s))
        az.append(a)
        el.append(e)
        if reported is not None:
            reported.append((t[-1], s.az_deg, s.el_deg))
    run_virtual(rot, clock, max(0.0, until_unix_s - unix_at(clock.now_s())), on_tick=on_tick)
    return np.array(t), np.array(az), np.array(el)


#: Gpredict's way of driving a rotator (protocols.md 1.7): a command every ~0.8 s, only
#: when the target has moved more than the threshold from the last command.
GPREDICT_PERIOD_S = 0.8
GPREDICT_THRESHOLD_DEG = 5.0


def gpredict_flips(sky_az_deg: np.ndarray, el_max_deg: float) -> bool:
    """Gpredict's own flip rule (``is_flipped_pass`` in gtk-rot-ctrl.c, 0..360 azimuth
    type): on a rotator configured with a 180 deg elevation range, a pass whose azimuth
    track jumps across the stop at north is flown flipped all the way (az + 180,
    180 - el); any other pass is flown unflipped."""
    az = np.asarray(sky_az_deg, dtype=float) % 360.0
    return bool(el_max_deg >= 180.0 and np.any(np.abs(np.diff(az)) > 180.0))


def gpredict_flips_pass(elements, station, p, geometry) -> bool:
    """``gpredict_flips`` for pass ``p`` on a rotator of ``geometry`` (its user sets the
    elevation range Gpredict is told to the rotator's own)."""
    from ..tracking.propagate import look_angles

    track = look_angles(elements, station, np.arange(p.aos_unix_s, p.los_unix_s, 1.0))
    return gpredict_flips(track.az_deg, geometry.el_max_deg + geometry.el_offset_deg)


class GpredictDriver:
    """Drives the rotator like Gpredict does through rotctld: threshold jumps, no plan;
    ``flipped``: the whole pass in the flipped frame, as Gpredict decides it
    (``gpredict_flips``)."""

    def __init__(self, rotator, target, unix_at: Callable[[float], float], aos_unix_s: float,
                 los_unix_s: float, threshold_deg: float = GPREDICT_THRESHOLD_DEG, flipped: bool = False):
        self.rot, self.target, self.unix_at = rotator, target, unix_at
        self.aos, self.los, self.threshold = aos_unix_s, los_unix_s, threshold_deg
        self.flipped = flipped
        self.next_s = -math.inf
        self.last: tuple[float, float] | None = None

    def step(self, now_s: float) -> None:
        if now_s < self.next_s:
            return
        self.next_s = now_s + GPREDICT_PERIOD_S
        u = self.unix_at(now_s)
        if not self.aos - 60.0 <= u <= self.los:
            return
        az, el = self.target.position(u)
        el = max(el, 0.0)
        if self.flipped:
            az, el = (az + 180.0) % 360.0, 180.0 - el
        if self.last is None or max(abs(wrap180_deg(az - self.last[0])), abs(el - self.last[1])) > self.threshold:
            try:
                self.rot.goto(az, el)
                self.last = (az, el)
            except Exception:  # refused (limits): Gpredict would just try again later
                pass


class FlownPass(NamedTuple):
    rotator: object
    plan: object | None             # the pass plan (None for the Gpredict-style driver)
    stats: PointingStats            # the antenna's true pointing error
    #: the pointing error of the plan itself at the same instants: what a perfect
    #: rotator flying the plan would achieve (the geometry's share of the error: a pass
    #: wider than the azimuth range, a keyhole on a rotator that cannot flip)
    plan_stats: PointingStats | None
    #: (utc_s, az_deg, el_deg): where the antenna truly pointed at every tick, from the
    #: start (pre-positioning included) to LOS
    flight: tuple[np.ndarray, np.ndarray, np.ndarray]
    #: the pointing error at every tick between AOS and LOS
    error_deg: np.ndarray
    #: (utc_s, az_deg, el_deg): where the controller said it pointed at every tick
    #: (its sensors' view, blind to gear play)
    reported: tuple[np.ndarray, np.ndarray, np.ndarray]
    #: the pass was flown flipped (over the top): the plan's choice, or Gpredict's
    flipped: bool = False


#: how long before AOS a Gpredict-style run starts (it commands from AOS - 60 s), and a
#: urc run given no ``lead_s`` plans its pass from
DEFAULT_LEAD_S = 240.0
#: a urc run given no ``lead_s`` starts this long before its plan leaves for the AOS pose
AT_REST_BEFORE_PREPOSITION_S = 5.0


def start_before_preposition(plan, start_u: float) -> float:
    """When a run that planned ``plan`` at UTC ``start_u`` (no tick yet) may as well
    start: AT_REST_BEFORE_PREPOSITION_S before the plan leaves for the AOS pose."""
    return max(start_u, plan.preposition_start_s - AT_REST_BEFORE_PREPOSITION_S)


def fly_pass_on_sim(profile: str, elements, station, p, state_dir, *, flip: bool | str = "auto",
                    driver: str = "urc", lead_s: float | None = None, config: dict | None = None) -> FlownPass:
    """Fly pass ``p`` on a fresh simulated rotator (``flip`` as ``[rotator] flip``).

    ``lead_s``: the run starts this long before AOS. Without it, urc's tracker plans the
    pass DEFAULT_LEAD_S before AOS and the run starts just before the plan leaves for the
    AOS pose: the antenna would only stand at rest until then (each simulated second
    costs a 50 Hz loop's CPU, and the pass tests are the suite's longest)."""
    from ..assembly import build_rotator
    from ..config import Config
    from ..tracking.planner import pointing_error_deg
    from ..tracking.propagate import look_angles
    from ..tracking.targets import SatelliteTarget
    from ..tracking.tracker import Tracker

    cfg: dict[str, Any] = {"rotator": {"profile": profile, "flip": flip}, "hardware": {"sim": {"wind": False}}}
    for k, v in (config or {}).items():  # sections merge; lists (keepout) replace
        cfg[k] = {**cfg.get(k, {}), **v} if isinstance(v, dict) else v
    clock = VirtualClock(0.0)
    rot = build_rotator(Config.from_dict(cfg), clock, state_dir, fast_virtual=True)
    start_u = p.aos_unix_s - (DEFAULT_LEAD_S if lead_s is None else lead_s)

    def unix_at(now_s: float) -> float:
        return start_u + now_s
    plan = None
    if driver == "urc":
        tracker = Tracker(rot, station, unix_at, park_after_pass=False)
        plan = tracker.track_pass(elements, p, clock.now_s())
        if lead_s is None:  # no tick has run: the clock's origin moves, the plan's UTC stays
            start_u = start_before_preposition(plan, start_u)
        step = tracker.step
    else:
        # Gpredict flips by its own rule where the rotator can (its user configures the
        # 180 deg elevation range), whatever ``flip`` says: like with like against urc's
        # planner, which flips per pass under flip = "auto"
        gpredict = GpredictDriver(rot, SatelliteTarget(elements, station), unix_at, p.aos_unix_s, p.los_unix_s,
                                  flipped=flip is not False and gpredict_flips_pass(elements, station, p,
                                                                                    rot.geometry))
        step = gpredict.step
    reported: list[tuple[float, float, float]] = []
    t, az, el = fly(rot, clock, step, unix_at, p.los_unix_s, reported)
    up = (t >= p.aos_unix_s) & (t <= p.los_unix_s)
    la = look_angles(elements, station, t[up])
    err = great_circle_deg(az[up], el[up], la.az_deg, la.el_deg)
    stats = PointingStats.of(err)
    plan_stats = None
    if plan is not None:
        plan_az = np.interp(t[up], plan.t_s, plan.az_deg)
        plan_el = np.interp(t[up], plan.t_s, plan.el_deg)
        plan_stats = PointingStats.of(pointing_error_deg(plan_az, plan_el, la.az_deg, la.el_deg, rot.geometry))
    rep_t, rep_az, rep_el = (np.array(c) for c in zip(*reported))
    flipped = bool(plan.flip) if plan is not None else gpredict.flipped
    return FlownPass(rot, plan, stats, plan_stats, (t, az, el), err, (rep_t, rep_az, rep_el), flipped)
