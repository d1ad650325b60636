"""A pass flown on the simulator with elements that are off (issue 38 part 5): the
tracker plans it from ``flown`` elements, the simulated power comes from the ``true``
satellite through the Gaussian beam, and step-track (when on) corrects the program.
The antenna's true beam is judged against the true satellite at every tick."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from ..angles import great_circle_deg
from ..clock import VirtualClock
from .evaluate import fly


def shifted_elements(es: Any, dt_s: float, node_deg: float = 0.0) -> Any:
    """``es`` with its epoch ``dt_s`` later and its elements unchanged: the same orbit,
    the satellite predicted ``dt_s`` behind where it is on it (along-track error: in
    space, prediction(t) = truth(t - dt_s), a time offset of -dt_s in step-track's
    terms; seen from the ground the Earth has turned in between, which step-track's
    Prediction.seen accounts for). ``node_deg`` turns the orbit's ascending node too:
    a cross-track error as well."""
    from sgp4.api import WGS72, Satrec
    from sgp4.exporter import export_tle

    from ..tracking.elements import parse_tle

    s = es.satrec
    sat = Satrec()
    epoch_days = s.jdsatepoch - 2433281.5 + s.jdsatepochF + dt_s / 86400.0
    sat.sgp4init(WGS72, "i", s.satnum, epoch_days, s.bstar, s.ndot, s.nddot, s.ecco, s.argpo, s.inclo, s.mo,
                 s.no_kozai, s.nodeo + math.radians(node_deg))
    sat.intldesg, sat.classification, sat.elnum, sat.revnum, sat.ephtype = "98067A", "U", 999, 1, 0
    l1, l2 = export_tle(sat)
    return parse_tle(f"{es.name}\n{l1}\n{l2}\n")[0]


class StatusSource:
    """The simulated power read at the tracker's status (synchronous: a virtual clock)."""

    def __init__(self, sim: Any):
        self.sim, self.name = sim, sim.name

    def read_at(self, status: Any, unix_s: float) -> Any:
        return self.sim.read()


class SteptrackFlight(NamedTuple):
    rotator: Any
    tracker_status: dict | None     # the tracker's status near LOS
    t_unix_s: np.ndarray            # every tick between AOS and LOS of the true pass
    error_deg: np.ndarray           # the true beam's angle from the true satellite then
    time_offset_s: float | None     # step-track's estimate at the end (None: off)
    time_offset_err_s: float | None
    events: list[str]
    programs: int                   # programs uploaded
    flipped: bool                   # the pass was planned over the top (el 90..180, az + 180)


def fly_steptrack_pass(true_es: Any, flown_es: Any, station: Any, p: Any, state_dir: Path, *, fwhm_deg: float,
                       snr_db: float, step_track: bool = True, seed: int = 1, lead_s: float = 150.0,
                       ceiling_db: float | None = None, noise_only: bool = False,
                       profile: str = "tartu-urc") -> SteptrackFlight:
    """Fly pass ``p`` (of ``flown_es``: the pass the tracker predicts) on a fresh
    simulated rotator, from ``lead_s`` before its AOS to its LOS plus a minute."""
    from ..assembly import build_rotator
    from ..config import Config
    from ..peaking.simsource import SimulatedPower, SkySource, world_beam
    from ..peaking.steptrack import factory
    from ..tracking.propagate import look_angles
    from ..tracking.tracker import Tracker

    cfg = Config.from_dict({"rotator": {"profile": profile}, "hardware": {"sim": {"wind": False}}})
    clock = VirtualClock(0.0)
    rot = build_rotator(cfg, clock, state_dir, fast_virtual=True)
    start_u = p.aos_unix_s - lead_s

    def unix_at(now_s: float) -> float:
        return start_u + now_s
    sim = SimulatedPower(SkySource.satellite(true_es, station), fwhm_deg=fwhm_deg,
                         snr_db=-60.0 if noise_only else snr_db, beam_at=world_beam(rot.hw.world, unix_at),
                         seed=seed, horizon_deg=0.0, ceiling_db=ceiling_db)
    tracker = Tracker(rot, station, unix_at, park_after_pass=False)
    if step_track:
        tracker.step_track = factory(fwhm_deg, lambda job: StatusSource(sim), ceiling_db=ceiling_db)
    tracker.track_pass(flown_es, p, clock.now_s())
    events: list[str] = []
    uploads = [0]
    fly_program = rot.fly_program

    def counting(program: Any) -> None:
        uploads[0] += 1
        fly_program(program)
    rot.fly_program = counting  # type: ignore[method-assign]
    announce = rot.announce

    def said(text: str) -> None:
        events.append(text)
        announce(text)
    rot.announce = said  # type: ignore[method-assign]
    last: dict[str, Any] = {"next_s": 0.0}

    def step(now_s: float) -> None:
        tracker.step(now_s)
        if tracker.job is not None:
            last["flip"] = bool(tracker.job.plan.flip)
        # (the status costs milliseconds of skyfield: every few seconds, as a client asks)
        if now_s >= last["next_s"] and tracker.job is not None and tracker.job.steptrack is not None:
            last["st"], last["next_s"] = tracker.status(now_s), now_s + 5.0
    t, az, el = fly(rot, clock, step, unix_at, p.los_unix_s + 60.0)
    # the true pass: where the true satellite is above the horizon
    la = look_angles(true_es, station, t)
    up = (la.el_deg > 0.0) & (t >= p.aos_unix_s - 60.0)
    err = great_circle_deg(az[up], el[up], la.az_deg[up], la.el_deg[up])
    st = last.get("st")
    track = (st or {}).get("step_track") or {}
    return SteptrackFlight(rot, st, t[up], np.asarray(err), track.get("time_offset_s"),
                           track.get("time_offset_err_s"), events, uploads[0], bool(last.get("flip")))


def within(err_deg: np.ndarray, limit_deg: float) -> float:
    """The share of samples within ``limit_deg``."""
    return float(np.mean(np.asarray(err_deg) <= limit_deg)) if len(err_deg) else math.nan
