"""What flies on without the I/O process (issue 33): an accepted command counts from its
acceptance, not from the tick that applies it, since the I/O process may die between
the two. A goto accepted a moment before is in flight; a jog accepted a moment before
is stopped with the other open-ended motions and never starts."""

from __future__ import annotations

import tempfile
from pathlib import Path

from urc.assembly import build_rotator
from urc.clock import VirtualClock
from urc.config import Config
from urc.rotator.loop import run_virtual
from urc.model.program import PassProgram


def rotator():
    clock = VirtualClock(0.0)
    cfg = Config.from_dict({"rotator": {"profile": "tartu-urc"}, "hardware": {"sim": {"wind": False}}})
    rot = build_rotator(cfg, clock, Path(tempfile.mkdtemp()), fast_virtual=True)
    run_virtual(rot, clock, 0.5)
    return rot, clock


def test_a_goto_accepted_before_its_tick_is_in_flight():
    rot, _ = rotator()
    assert rot.bounded_in_flight() == ""
    rot.goto(120.0, 30.0)
    assert rot.bounded_in_flight() == "goto"


def test_a_park_and_a_program_accepted_before_their_tick_are_in_flight():
    rot, clock = rotator()
    rot.park()
    assert rot.bounded_in_flight() == "park"
    rot2, clock2 = rotator()
    t0 = clock2.now_s() + 30.0
    rot2.fly_program(PassProgram(3, "TEST", (t0, t0 + 10.0), (100.0, 101.0), (40.0, 40.0), (False, False),
                                 clock2.now_s()))
    assert rot2.bounded_in_flight() == "pass program"


def test_a_stop_queued_after_a_goto_ends_it():
    rot, _ = rotator()
    rot.goto(120.0, 30.0)
    rot.stop()
    assert rot.bounded_in_flight() == ""


def test_a_jog_accepted_before_its_tick_never_starts_once_the_io_process_is_silent():
    rot, clock = rotator()
    az0 = rot.status().az_deg
    rot.move("az", 1)
    assert rot.bounded_in_flight() == ""
    assert rot.stop_open_ended("the I/O process was silent for 1.0 s") is True
    s = run_virtual(rot, clock, 3.0)
    assert not s.moving and abs(s.az_deg - az0) < 0.05, (s.az_deg, az0)
    assert s.last_stop is not None and s.last_stop["command"] == "move", s.last_stop
