"""Nothing of the tracking's heavy work runs on the event loop's thread (issue 33: the
catalog read again after `urc tle import` of 100 000 sets, and a pass planned from the
web page, held urc run's loop until the control process stopped the axes for its
silence). A real TrackingService inside a running asyncio loop, driven as urc run drives
it (its commands and steps awaited on the loop); every catalog read, pass search and plan is
recorded with the thread that ran it. Judged by threads, not by durations."""

from __future__ import annotations

import asyncio
import sys
import threading

import pytest

from conftest import Bench
from urc.config import Config
from urc.tracking import passes as passes_module
from urc.tracking import service as service_module
from urc.tracking import tracker as tracker_module
from urc.tracking.elements import Catalog, import_file, load_elements
from urc.tracking.passes import find_passes
from urc.tracking.service import CATALOG_CHECK_S, TrackingService

from .conftest import FIXTURES, T0_UNIX_S, TARTU
from .test_service_reload import newer_iss_tle

#: a bound on any wait here (only a broken service waits that long)
WAIT_S = 60.0


@pytest.fixture
def recorded(monkeypatch) -> dict[str, list[int]]:
    """The heavy functions, each recording the thread that ran it."""
    ran: dict[str, list[int]] = {"catalog read": [], "pass search": [], "pass plan": [], "ground track": []}

    def recording(what, fn):
        def wrapper(*args, **kw):
            ran[what].append(threading.get_ident())
            return fn(*args, **kw)
        return wrapper
    load = Catalog.load
    monkeypatch.setattr(Catalog, "load", staticmethod(recording("catalog read", load)))
    for module in (service_module, tracker_module):
        monkeypatch.setattr(module, "find_passes", recording("pass search", passes_module.find_passes))
    monkeypatch.setattr(tracker_module.Tracker, "_plan", recording("pass plan", tracker_module.Tracker._plan))
    # (the status a tracking command answers with: tens of ms of skyfield)
    monkeypatch.setattr(tracker_module, "_ground_track", recording("ground track", tracker_module._ground_track))
    return ran


def make_service(tmp_path):
    b = Bench("tartu-urc", tmp_path / "state")
    cat_dir = tmp_path / "catalog"
    Catalog(load_elements(FIXTURES / "leo.tle")).save(cat_dir)
    cfg = Config.from_dict({"station": {"lat_deg": TARTU.lat_deg, "lon_deg": TARTU.lon_deg, "alt_m": TARTU.alt_m},
                            "tracking": {"catalog_dir": str(cat_dir), "schedule": [{"sat": "ISS"}]}})
    start_s = b.clock.now_s()
    svc = TrackingService(b.rot, cfg, unix_at=lambda now_s: T0_UNIX_S + now_s - start_s, background=True)
    return b, svc, cat_dir


async def stepping_until(step, pred, what: str) -> None:
    """Step the service on the loop (as urc run does) until ``pred()``."""
    for _ in range(int(WAIT_S / 0.01)):
        await step()
        if pred():
            return
        await asyncio.sleep(0.01)
    raise AssertionError(f"not within {WAIT_S} s: {what}")


def test_catalog_reads_and_pass_plans_never_run_on_the_loop_thread(tmp_path, recorded):
    b, svc, cat_dir = make_service(tmp_path)
    now = [b.clock.now_s()]

    async def step() -> None:  # as urc run steps the tracker
        await svc.step(now[0])

    def replace_catalog(days_later: float) -> None:  # what `urc tle import` does
        (tmp_path / "iss.tle").write_text(newer_iss_tle(days_later))
        import_file(tmp_path / "iss.tle", cat_dir)

    async def main() -> int:
        loop_thread = threading.get_ident()
        # the start: the schedule planned on a thread, its first pass started by a step
        await asyncio.to_thread(svc.run_schedule)
        await stepping_until(step, lambda: svc.tracker.job is not None, "the scheduled pass planned")
        # `urc track ISS` just after an import: read again, looked up, its next pass planned
        replace_catalog(0.1)
        await svc.track({"kind": "satellite", "name": "iss"})
        await stepping_until(step, lambda: svc.tracker.job is not None, "the next pass of ISS planned")
        # the web page's "track this pass" just after another import
        replace_catalog(0.2)
        iss_pass = find_passes(load_elements(tmp_path / "iss.tle"), TARTU, T0_UNIX_S, duration_s=86400.0,
                               min_el_deg=0.0)[0]
        await svc.track_pass(25544, iss_pass.aos_unix_s)
        # an import while the tracker runs: the step notices it, the worker reads it
        replace_catalog(0.3)
        reads = len(recorded["catalog read"])
        now[0] += CATALOG_CHECK_S + 1.0
        await stepping_until(step, lambda: len(recorded["catalog read"]) > reads and svc._reloading is None,
                             "the changed catalog read and installed")
        return loop_thread

    loop_thread = asyncio.run(main())
    svc.close()
    assert len(recorded["catalog read"]) >= 4, recorded   # the start, and after each import
    for what, threads in recorded.items():
        assert threads, f"no {what} seen"
        assert loop_thread not in threads, f"a {what} ran on the event loop's thread"


def test_the_first_requests_imports_are_warmed_up_on_a_thread_of_their_own(tmp_path, monkeypatch):
    from urc.tracking import warm_up as warm_up_module

    ran_on: list[str] = []
    monkeypatch.setattr(warm_up_module, "warm_up", lambda: ran_on.append(threading.current_thread().name))
    b, svc, _ = make_service(tmp_path)
    for _ in range(int(WAIT_S / 0.01)):
        if ran_on:
            break
        threading.Event().wait(0.01)
    svc.close()
    assert ran_on == ["urc-warm-up"]


def test_warm_up_loads_what_a_first_status_and_plan_need():
    from urc.tracking import sky
    from urc.tracking.warm_up import MODULES, warm_up

    warm_up()
    assert all(m in sys.modules for m in MODULES)
    assert sky.timescale.cache_info().currsize == 1 and sky.ephemeris.cache_info().currsize == 1
