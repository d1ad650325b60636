"""Re-referencing (Commands.set_position) with a pointing model in force (issue 38)."""

from __future__ import annotations

import tempfile
from pathlib import Path

import pytest

from urc.assembly import build_rotator
from urc.clock import VirtualClock
from urc.config import Config
from urc.rotator.loop import run_virtual


def rotator():
    clock = VirtualClock(0.0)
    cfg = Config.from_dict({"rotator": {"profile": "tartu-urc"}, "hardware": {"sim": {"wind": False}}})
    return build_rotator(cfg, clock, Path(tempfile.mkdtemp()), fast_virtual=True), clock


def test_a_declared_position_is_where_the_beam_points_with_a_pointing_model():
    """Issue 38: with a pointing model in force every reported position is the beam's; a
    set position (re-reference) declares the beam's direction too, so the status then
    reports what was declared (it reported it IA = 1.5 deg off before)."""
    import dataclasses

    from urc.control.geometry import POINTING_TERMS

    rot, clock = rotator()
    terms = {"ia": 1.5, "ie": -0.7}
    rot.reconfigure(dataclasses.replace(rot.settings, pointing_deg=tuple(terms.get(n, 0.0) for n in POINTING_TERMS)))
    run_virtual(rot, clock, 0.5)
    rot.set_position(az_deg=100.0, el_deg=30.0)
    s = run_virtual(rot, clock, 0.5)
    assert s.az_deg == pytest.approx(100.0, abs=0.05) and s.el_deg == pytest.approx(30.0, abs=0.05), \
        (s.az_deg, s.el_deg)
    rot.set_position(az_deg=120.0)           # one axis: the other keeps the beam's
    s = run_virtual(rot, clock, 0.5)
    assert s.az_deg == pytest.approx(120.0, abs=0.05) and s.el_deg == pytest.approx(30.0, abs=0.05)
