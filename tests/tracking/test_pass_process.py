"""Pass searches in the worker process give exactly the in-process answer, for element
sets read from TLE and from OMM text, and really run in another interpreter."""

from __future__ import annotations

from pathlib import Path

import pytest

from urc.tracking import pass_process
from urc.tracking.elements import load_elements
from urc.tracking.passes import find_passes
from urc.tracking.station import Station

FIXTURES = Path(__file__).parent / "fixtures"
TARTU = Station(58.3780, 26.7290, 70.0, "Tartu")
T0_UNIX_S = 1704110400.0


@pytest.fixture(scope="module", autouse=True)
def _stop_worker():
    yield
    pass_process.shutdown()


@pytest.mark.parametrize("fixture", ["leo.tle", "omm.json"])
def test_isolated_search_equals_the_in_process_one(fixture):
    sats = load_elements(FIXTURES / fixture)
    here = find_passes(sats, TARTU, T0_UNIX_S, duration_s=6 * 3600.0, min_el_deg=5.0)
    there = pass_process.find_passes_isolated(sats, TARTU, T0_UNIX_S, duration_s=6 * 3600.0, min_el_deg=5.0)
    assert here and there == here


def test_the_search_runs_in_another_interpreter(monkeypatch):
    sats = load_elements(FIXTURES / "leo.tle")

    def not_here(*_a, **_k):
        raise AssertionError("the pass search ran in the controller's own process")
    monkeypatch.setattr(pass_process, "find_passes", not_here)
    assert pass_process.find_passes_isolated(sats, TARTU, T0_UNIX_S, duration_s=3 * 3600.0, min_el_deg=0.0)


def test_a_dead_worker_is_replaced():
    sats = load_elements(FIXTURES / "leo.tle")[:2]
    pass_process.find_passes_isolated(sats, TARTU, T0_UNIX_S, duration_s=3600.0, min_el_deg=0.0)
    for proc in list(pass_process._executor()._processes.values()):
        proc.kill()
        proc.join()
    assert pass_process.find_passes_isolated(sats, TARTU, T0_UNIX_S, duration_s=86400.0, min_el_deg=0.0)
