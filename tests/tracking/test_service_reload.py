"""The tracking service of a running controller (issue 21): it reads the element catalog
again when `urc tle import/update` changed it (used from the next pass, and said so),
and it searches and plans passes off the event loop."""

from __future__ import annotations

import threading

from sgp4.api import WGS72, Satrec
from sgp4.exporter import export_tle

from conftest import Bench
from urc.config import Config
from urc.tracking import tracker as tracker_module
from urc.tracking.elements import Catalog, import_file, load_elements
from urc.tracking.service import CATALOG_CHECK_S, TrackingService
from urc_process import wait_until

from .conftest import FIXTURES, T0_UNIX_S


def newer_iss_tle(days_later: float) -> str:
    """The fixture's ISS orbit with its epoch ``days_later`` days on (a newer set)."""
    old = next(es for es in load_elements(FIXTURES / "leo.tle") if es.norad_id == 25544).satrec
    sat = Satrec()
    sat.sgp4init(WGS72, "i", 25544, old.jdsatepoch + old.jdsatepochF - 2433281.5 + days_later,
                 old.bstar, old.ndot, old.nddot, old.ecco, old.argpo, old.inclo, old.mo, old.no_kozai, old.nodeo)
    sat.intldesg, sat.classification, sat.elnum, sat.revnum, sat.ephtype = "98067A", "U", 999, 43240, 0
    return "ISS (ZARYA)\n" + "\n".join(export_tle(sat)) + "\n"


def service(tmp_path, background: bool = False, without_iss: bool = False):
    b = Bench("tartu-urc", tmp_path / "state")
    cat_dir = tmp_path / "catalog"
    sets = load_elements(FIXTURES / "leo.tle")
    Catalog(es for es in sets if not (without_iss and es.norad_id == 25544)).save(cat_dir)
    cfg = Config.from_dict({"station": {"lat_deg": 58.378, "lon_deg": 26.729, "alt_m": 70},
                            "tracking": {"catalog_dir": str(cat_dir)}})
    start_s = b.clock.now_s()
    svc = TrackingService(b.rot, cfg, unix_at=lambda now_s: T0_UNIX_S + now_s - start_s, background=background)
    return b, svc, cat_dir


def test_a_satellite_imported_while_running_can_be_tracked(tmp_path):
    """`urc track NEW` after `urc tle import` was refused: 'no satellite ... (3 sets)'."""
    b, svc, cat_dir = service(tmp_path, without_iss=True)
    assert 25544 not in svc.catalog()
    new = tmp_path / "iss.tle"
    new.write_text(newer_iss_tle(0.1))
    import_file(new, cat_dir)  # what `urc tle import` does
    svc.track_sync({"kind": "satellite", "name": "ISS"})
    assert svc.tracker.target.elements.norad_id == 25544
    svc.close()


def test_newer_elements_are_used_from_the_next_pass_and_said_so(tmp_path):
    b, svc, cat_dir = service(tmp_path)
    svc.track_sync({"kind": "satellite", "name": "ISS"})
    old_epoch = svc.tracker.target.elements.epoch
    first_pass = svc.tracker.job.pass_
    new = tmp_path / "iss.tle"
    new.write_text(newer_iss_tle(0.25))
    import_file(new, cat_dir)
    b.run(CATALOG_CHECK_S + 1.0, on_tick=lambda s: svc.step_sync(s.t_s))
    events = " ".join(b.rot.status().events)
    assert "element catalog changed on disk" in events and "from its next pass" in events
    # the pass being flown keeps its plan and elements ...
    assert svc.tracker.job.pass_ is first_pass and svc.tracker.target.elements.epoch == old_epoch
    # ... the next one (planned at LOS) flies the new set
    svc.tracker._plan_next(svc.tracker.target, b.clock.now_s())
    assert svc.tracker.target.elements.epoch > old_epoch
    svc.close()


def test_passes_are_searched_and_planned_off_the_calling_thread(tmp_path, monkeypatch):
    """`urc track` and LOS searched 24 h of passes on the event loop (8 s of silence
    under load stopped the axes): with background=True that runs on a worker."""
    b, svc, _ = service(tmp_path, background=True)
    searched_on: list[str] = []
    real = tracker_module.find_passes

    def recording(*args, **kw):
        searched_on.append(threading.current_thread().name)
        return real(*args, **kw)
    monkeypatch.setattr(tracker_module, "find_passes", recording)
    svc.track_sync({"kind": "satellite", "name": "ISS"})
    wait_until(lambda: (svc.step_sync(b.clock.now_s()), svc.tracker.job is not None)[1], timeout_s=60.0,
               what="the next pass planned")
    assert searched_on and threading.current_thread().name not in searched_on
    assert svc.status()["plan"]["max_el_deg"] > 0
    svc.close()


def test_a_stale_background_search_is_dropped(tmp_path):
    """Asked for the Sun while ISS was still being planned: the ISS plan never lands."""
    b, svc, _ = service(tmp_path, background=True)
    svc.track_sync({"kind": "satellite", "name": "ISS"})
    svc.track_sync({"kind": "sun"})
    wait_until(lambda: (svc.step_sync(b.clock.now_s()), not svc.tracker.planning)[1], timeout_s=60.0,
               what="the search finished")
    assert svc.tracker.job is None and svc.tracker.target.name.lower().startswith("sun")
    svc.close()
