"""A full ISS pass on every shipped example through the emulated gpio backend: the real
drivers on emulated pins and chips point within 1.2x the sim backend's RMS on the
same pass."""

from __future__ import annotations

from pathlib import Path

import pytest

from urc.config import load_config
from urc.tracking.elements import load_elements
from urc.testing.evaluate import fly_pass_on_sim
from urc.tracking.passes import find_passes
from urc.tracking.station import Station

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = sorted(p for p in (ROOT / "examples").glob("*.toml") if 'backend = "gpio"' in p.read_text())
T0_UNIX_S = 1704110400.0
TARTU = Station(58.3780, 26.7290, 70.0, "Tartu")


@pytest.fixture(scope="module")
def iss_pass():
    es = next(s for s in load_elements(ROOT / "tests" / "tracking" / "fixtures" / "leo.tle")
              if s.norad_id == 25544)
    p = max(find_passes(es, TARTU, T0_UNIX_S, duration_s=86400, min_el_deg=10), key=lambda p: p.max_el_deg)
    return es, p


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.stem)
def test_iss_pass_through_emulated_gpio_within_1_2x_sim(path, tmp_path, iss_pass):
    es, p = iss_pass
    cfg = load_config(path)
    doc = cfg.to_dict()
    gpio = doc["hardware"]["gpio"]
    gpio["emulate"] = True
    profile = cfg.rotator.profile
    # the example's own rotator and limits on both sides (a single-axis example, its range)
    own = {"rotator": doc["rotator"], "limits": doc["limits"]}
    sim = fly_pass_on_sim(profile, es, TARTU, p, tmp_path / "sim", config=own)
    emu = fly_pass_on_sim(profile, es, TARTU, p, tmp_path / "gpio",
                          config={**own, "hardware": {"backend": "gpio", "gpio": gpio, "sim": {"wind": False}}})
    rot, stats = emu[0], emu[2]
    assert rot.hw.backend == "gpio" and not rot.status().faults
    assert stats.rms_deg <= 1.2 * sim[2].rms_deg, (stats.rms_deg, sim[2].rms_deg)
