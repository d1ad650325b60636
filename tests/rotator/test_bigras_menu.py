"""The BIG-RAS menu settings (seed 002) as urc settings: pulses per degree, minimal
turn, max elevation 90/180, elevation ON/OFF, zero point north/south. Each is kept in
the configuration file (the web settings page saves it), validated, and used."""

from __future__ import annotations

from pathlib import Path

import pytest

from urc.config import Config, load_config
from urc.errors import CommandRejected, ConfigError
from urc.protocols import make_session
from urc.web.settings_store import SettingsStore
from urc.testing.sessions import fed

BIGRAS = Path(__file__).resolve().parents[2] / "examples" / "bigras.toml"


def emulated_bigras(bench, **rotator):
    data = load_config(BIGRAS).to_dict()
    data["rotator"].update(rotator)
    data["hardware"]["gpio"]["emulate"] = True
    return bench("bigras", rotator=data["rotator"], hardware=data["hardware"])


@pytest.mark.parametrize("ppd", [1, 2, 5])
def test_pulses_per_degree_is_what_the_pulse_counter_driver_counts_by(bench, ppd):
    b = emulated_bigras(bench, pulses_per_deg=ppd)
    sensor = b.rot.hw.axis("az").sensor
    assert type(sensor).__name__ == "SpidPulseSensor" and sensor.caps.resolution_deg == pytest.approx(1.0 / ppd)
    b.rot.goto(60.0, 10.0)
    s = b.settle()
    assert not s.faults
    # the driver's own pulse count is ppd pulses per degree turned
    assert sensor.counts() == pytest.approx(60.0 * ppd, abs=2)
    assert b.truth("az") == pytest.approx(60.0, abs=1.0 / ppd + 0.6)


def test_minimal_turn_is_where_motion_starts_and_ends(bench):
    slow = bench("bigras")
    quick = bench("bigras", control={"az": {"min_rate_deg_per_s": 2.0}})
    assert quick.rot.axes["az"].tuning.min_rate_deg_per_s == 2.0
    assert quick.rot.axes["az"].flim.min_rate_deg_per_s == 2.0  # the stall check waits for it too
    for b, floor in ((slow, 0.8), (quick, 2.0)):
        b.rot.goto(40.0, 0.0)
        rates = []
        b.run(1.0, on_tick=lambda s, b=b: rates.append(abs(b.rot.axes["az"].law.ref_rate_deg_per_s)))
        started = [r for r in rates if r > 0]
        # the motion profile starts at the minimal turn speed, not from zero
        assert started and started[0] == pytest.approx(floor, abs=0.05), started[:3]
        s = b.settle()
        assert s.az_deg == pytest.approx(40.0, abs=1.0) and not s.faults


def test_max_elevation_180_flies_over_the_top(bench):
    b = bench("bigras", rotator={"max_el_deg": 180})
    assert b.rot.caps.can_flip and b.rot.settings.el_limits_deg == (0.0, 180.0)
    b.rot.goto(30.0, 120.0)  # the flipped pose: sky az 210, el 60
    s = b.settle(400.0)
    assert not s.faults and s.flipped
    assert b.truth("el") == pytest.approx(120.0, abs=1.0)
    assert s.az_deg == pytest.approx(210.0, abs=1.0) and s.el_deg == pytest.approx(60.0, abs=1.0)
    ninety = bench("bigras", rotator={"max_el_deg": 90})
    with pytest.raises(CommandRejected) as exc:
        ninety.rot.goto(30.0, 120.0)
    assert exc.value.reason == "limit"


def test_south_zero_point(bench):
    b = bench("bigras", rotator={"zero": "south"})
    s = b.rot.status()
    assert s.az.pos_deg == pytest.approx(0.0, abs=0.5) and s.az_deg == pytest.approx(180.0, abs=0.5)
    b.rot.goto(90.0, 10.0)  # compass east: mechanical 270 from the south zero
    s = b.settle(400.0)
    assert b.truth("az") == pytest.approx(270.0, abs=1.0) and s.az_deg == pytest.approx(90.0, abs=1.0)
    rotctld = make_session("rotctld", b.rot)
    az, _ = fed(rotctld, b"p\n")[0].split(b"\n")[:2]
    assert float(az) == pytest.approx(90.0, abs=1.0)  # protocols speak compass azimuth
    state = b"".join(fed(rotctld, b"\\dump_state\n")).decode()
    assert "south_zero=0" in state  # urc maps it itself: a client must not add 180 again


def test_menu_settings_are_validated_with_file_key_expected_found():
    cases = [({"rotator": {"max_el_deg": 120}}, "rotator.max_el_deg", "90 or 180"),
             ({"rotator": {"pulses_per_deg": 0, "profile": "bigras"}}, "rotator.pulses_per_deg", "an integer in 1..100"),
             ({"rotator": {"pulses_per_deg": 2, "profile": "berkeley"}}, "rotator.pulses_per_deg", "no pulse sensor"),
             ({"rotator": {"zero": "east"}}, "rotator.zero", "north"),
             ({"rotator": {"max_el_deg": 180, "elevation": False}}, "rotator.max_el_deg", "azimuth only"),
             ({"rotator": {"profile": "bigras"}, "control": {"az": {"min_rate_deg_per_s": 9.0}}},
              "control.az.min_rate_deg_per_s", "top speed")]
    for data, key, expected in cases:
        with pytest.raises(ConfigError) as exc:
            Config.from_dict(data, source="urc.toml")
        text = str(exc.value)
        assert text.startswith("urc.toml: ") and key in text and expected in text, text


def test_menu_settings_persist_through_the_settings_store(tmp_path):
    path = tmp_path / "urc.toml"
    path.write_text('[rotator]\nprofile = "bigras"\n')
    store = SettingsStore(load_config(path), path, tmp_path)
    doc = store.document()["config"]
    doc["rotator"].update({"pulses_per_deg": 1, "max_el_deg": 180, "zero": "south", "elevation": True})
    doc.setdefault("control", {}).setdefault("az", {})["min_rate_deg_per_s"] = 1.2
    cfg, errors = store.validate(doc)
    assert not errors, errors
    assert "rotator" in store.changed_sections(cfg)
    store.save(cfg)
    again = load_config(path)  # what the next start reads
    assert (again.rotator.pulses_per_deg, again.rotator.max_el_deg, again.rotator.zero) == (1, 180, "south")
    assert again.control.az.min_rate_deg_per_s == 1.2
    bad = dict(doc, rotator={**doc["rotator"], "max_el_deg": 100})
    _, errors = store.validate(bad)
    assert [e["key"] for e in errors] == ["rotator.max_el_deg"]
