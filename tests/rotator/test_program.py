"""Program track (urc.model.program) beside a client tracking the same satellite: a sky
goto that agrees with the program in flight keeps it (issue 33's soak lost a pass to a
Gpredict-style client whose P replaced the program); one that does not replaces it."""

from __future__ import annotations

import tempfile
from pathlib import Path

import pytest

from urc.assembly import build_rotator
from urc.clock import VirtualClock
from urc.config import Config
from urc.rotator.core import PROGRAM_AGREE_DEG
from urc.rotator.loop import run_virtual
from urc.model.program import PassProgram


def rotator():
    clock = VirtualClock(0.0)
    cfg = Config.from_dict({"rotator": {"profile": "tartu-urc"}, "hardware": {"sim": {"wind": False}}})
    return build_rotator(cfg, clock, Path(tempfile.mkdtemp()), fast_virtual=True), clock


def flying(rot, clock):
    """A 60 s program from az 100 to 130 at el 40 (mechanical = sky on tartu-urc), flown
    until 20 s into it."""
    t0 = clock.now_s() + 10.0
    ts = tuple(t0 + k for k in range(61))
    rot.fly_program(PassProgram(7, "TEST", ts, tuple(100.0 + 0.5 * k for k in range(61)), (40.0,) * 61,
                                (False,) * 61, clock.now_s()))
    s = run_virtual(rot, clock, 30.0)
    assert s.program is not None and s.program["state"] == "tracking", s.program
    return t0


def test_a_goto_that_agrees_with_the_program_in_flight_keeps_it():
    rot, clock = rotator()
    t0 = flying(rot, clock)
    az_now = 100.0 + 0.5 * (clock.now_s() - t0)
    route = rot.goto(az_now + 0.5 * PROGRAM_AGREE_DEG, 40.0)     # Gpredict's P, a poll late
    s = run_virtual(rot, clock, 5.0)
    assert s.program is not None and s.program["id"] == 7 and s.program_end is None
    assert route[0][0] == pytest.approx(az_now, abs=0.1)
    assert abs(s.az_deg - (100.0 + 0.5 * (clock.now_s() - t0))) < 0.5   # still following the program


def test_a_goto_elsewhere_replaces_the_program():
    rot, clock = rotator()
    flying(rot, clock)
    rot.goto(200.0, 60.0)
    s = run_virtual(rot, clock, 1.0)
    assert s.program is None and s.program_end["why"] == "replaced by goto"

