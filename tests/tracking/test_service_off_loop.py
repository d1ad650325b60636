"""The tracking service's planning stays off the event loop (issue 21: under load the
I/O process went silent for 8 s, right after `urc track` and at LOS, and the control
process stopped the axes mid-pre-positioning). Flying one given pass (the web page's
"track this pass") and starting a scheduled pass plan on the worker; the loop serves
other requests meanwhile. Judged by order and state, not by durations."""

from __future__ import annotations

import asyncio
import threading

from conftest import Bench
from urc.config import Config
from urc.tracking import service as service_module
from urc.tracking import tracker as tracker_module
from urc.tracking.elements import Catalog, load_elements
from urc.tracking.passes import find_passes
from urc.tracking.service import TrackingService
from urc_process import wait_until

from .conftest import FIXTURES, T0_UNIX_S, TARTU

#: how long a gated planner waits for the loop to serve another request before it gives
#: up (only a planner blocking the loop waits that long: the test then fails)
GATE_S = 20.0


def service(tmp_path, schedule: tuple = ()) -> tuple[Bench, TrackingService]:
    b = Bench("tartu-urc", tmp_path / "state")
    cat_dir = tmp_path / "catalog"
    Catalog(load_elements(FIXTURES / "leo.tle")).save(cat_dir)
    cfg = Config.from_dict({"station": {"lat_deg": TARTU.lat_deg, "lon_deg": TARTU.lon_deg, "alt_m": TARTU.alt_m},
                            "tracking": {"catalog_dir": str(cat_dir), "schedule": list(schedule)}})
    start_s = b.clock.now_s()
    svc = TrackingService(b.rot, cfg, unix_at=lambda now_s: T0_UNIX_S + now_s - start_s, background=True)
    return b, svc


def first_iss_pass():
    iss = next(es for es in load_elements(FIXTURES / "leo.tle") if es.norad_id == 25544)
    return find_passes(iss, TARTU, T0_UNIX_S, duration_s=86400.0, min_el_deg=0.0)[0]


def test_track_pass_plans_on_the_worker_while_the_loop_serves(tmp_path, monkeypatch):
    b, svc = service(tmp_path)
    p = first_iss_pass()
    served = threading.Event()   # set by another request the loop serves
    planned_on: list[str] = []
    real = service_module.find_passes

    def slow_search(*args, **kw):
        planned_on.append(threading.current_thread().name)
        # on the event loop this waits for a request that cannot be served: fails
        assert served.wait(GATE_S), "the event loop served nothing while the pass was planned"
        return real(*args, **kw)
    monkeypatch.setattr(service_module, "find_passes", slow_search)

    async def main() -> list[str]:
        order: list[str] = []
        flying = asyncio.create_task(svc.track_pass(25544, p.aos_unix_s))
        await asyncio.sleep(0)  # the route's call has started and is planning
        st = svc.status()  # another client's request
        order.append("other request served" if st is None else "tracking already")
        served.set()
        await flying
        order.append("pass planned")
        return order

    order = asyncio.run(main())
    assert order == ["other request served", "pass planned"]
    assert planned_on and planned_on[0].startswith("urc-tracking"), planned_on
    assert svc.tracker.job is not None and svc.tracker.job.pass_.norad_id == 25544
    svc.close()


def test_a_stop_while_a_pass_is_planned_wins(tmp_path, monkeypatch):
    b, svc = service(tmp_path)
    p = first_iss_pass()
    stopped = threading.Event()
    real = service_module.find_passes

    def slow_search(*args, **kw):
        assert stopped.wait(GATE_S)
        return real(*args, **kw)
    monkeypatch.setattr(service_module, "find_passes", slow_search)

    async def main() -> str:
        flying = asyncio.create_task(svc.track_pass(25544, p.aos_unix_s))
        await asyncio.sleep(0)
        await svc.stop()
        stopped.set()
        try:
            await flying
        except service_module.TrackingError as exc:
            return str(exc)
        return "flown"

    assert "another tracking command" in asyncio.run(main())
    assert svc.tracker.target is None and svc.tracker.job is None
    svc.close()


def test_a_scheduled_pass_is_planned_on_the_worker(tmp_path, monkeypatch):
    b, svc = service(tmp_path, schedule=({"sat": "ISS"},))
    assert svc.run_schedule()
    planned_on: list[str] = []
    real = tracker_module.Tracker._plan

    def recording(self, *args, **kw):
        planned_on.append(threading.current_thread().name)
        return real(self, *args, **kw)
    monkeypatch.setattr(tracker_module.Tracker, "_plan", recording)
    svc.step_sync(b.clock.now_s())  # the first scheduled pass starts: its plan is asked for
    assert svc.tracker.target is not None and svc.tracker.target.elements.norad_id == 25544
    wait_until(lambda: (svc.step_sync(b.clock.now_s()), svc.tracker.job is not None)[1], timeout_s=60.0,
               what="the scheduled pass planned")
    assert planned_on and threading.current_thread().name not in planned_on, planned_on
    assert svc.status()["plan"]["max_el_deg"] > 0
    svc.close()
