"""Property tests: no sequence of commands, from any source, drives an axis past its soft
limits or through a keep-out zone — on every profile, judged by the simulator's truth."""

from __future__ import annotations

import math
import tempfile
from pathlib import Path

import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from conftest import ALL_PROFILES, Bench
from urc.control.geometry import KeepOut
from urc.errors import CommandRejected

MAST = {"name": "mast", "az_min_deg": 80.0, "az_max_deg": 110.0, "el_min_deg": 0.0, "el_max_deg": 25.0}
NORTH_ROOF = {"name": "roof", "az_min_deg": 330.0, "az_max_deg": 20.0, "el_min_deg": 0.0, "el_max_deg": 8.0}

angle = st.one_of(st.floats(-720, 720), st.sampled_from([math.nan, math.inf, -math.inf]))
command = st.one_of(
    st.tuples(st.just("goto"), angle, st.one_of(st.floats(-100, 200), st.just(math.nan))),
    st.tuples(st.just("move"), st.sampled_from(["az", "el"]), st.sampled_from([-1, 1]), st.floats(0.05, 1.0)),
    st.tuples(st.just("stop"), st.sampled_from([None, "az", "el"])),
    st.tuples(st.just("park")),
    st.tuples(st.just("track"), st.floats(0, 360), st.floats(-10, 100), st.floats(-3, 3), st.floats(-2, 2)),
)
step = st.tuples(command, st.floats(0.2, 8.0))


def slack(rot, axis: str) -> float:
    """What sensor quantisation, gear play and coasting may legitimately add."""
    c = rot.caps.axis(axis)
    return c.tolerance_deg + 2 * c.sensor.resolution_deg + 4 * c.sensor.noise_deg + 1.6


@pytest.mark.parametrize("profile", ALL_PROFILES)
@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(steps=st.lists(step, min_size=1, max_size=5))
# found by this property on tartu-urc: stopping the elevation of a track left the azimuth
# following it, and a jog down then ran into the mast under the moving azimuth
@example(steps=[(("goto", 0.0, math.nan), 3.29), (("track", 138.01, 59.87, -0.899, 0.0), 2.59),
                (("stop", "el"), 6.91), (("move", "el", -1, 0.59), 4.55)])
def test_no_command_sequence_leaves_limits_or_enters_a_zone(profile, steps):
    check_sequence(profile, steps)


#: the gpio examples (a bridge example has no drivers of urc's to emulate)
EXAMPLES = {p.stem: p for p in (Path(__file__).resolve().parents[2] / "examples").glob("*.toml")
            if 'backend = "gpio"' in p.read_text()}


@pytest.mark.parametrize("example", sorted(EXAMPLES))
@settings(max_examples=4, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(steps=st.lists(step, min_size=1, max_size=4))
def test_no_command_sequence_leaves_limits_or_enters_a_zone_on_emulated_gpio(example, steps):
    """The same property through the gpio backend's real drivers on emulated parts."""
    check_example_sequence(example, steps)


def test_a_turntable_standing_in_a_zone_is_not_let_deeper_into_it():
    """Found by the property above: the turntable's beam (el 0) stands on the edge of the
    roof's elevation band, where the zone's depth was 0 at any azimuth, so a track that
    turned back inside the roof was never seen going deeper."""
    check_example_sequence("trc-turntable", [(("track", 30.229261152447787, 0.0, -2.0, 0.0), 5.641910441665534)])


def check_example_sequence(example: str, steps) -> None:
    from urc.config import load_config
    cfg = load_config(EXAMPLES[example])
    hardware = cfg.to_dict()["hardware"]
    hardware["gpio"]["emulate"] = True
    check_sequence(cfg.rotator.profile, steps, hardware=hardware, rotator=cfg.to_dict()["rotator"])


def check_sequence(profile, steps, **config):
    with tempfile.TemporaryDirectory() as tmp:
        single = config.get("rotator", {}).get("elevation") is False  # (the TRC turntable)
        b = Bench(profile, Path(tmp), keepout=[MAST, NORTH_ROOF],
                  park={"az_deg": 180.0} if single else {"az_deg": 180.0, "el_deg": 45.0}, **config)
        rot = b.rot
        geometry = rot.geometry
        # zones shrunk by the allowed slack: the truth may graze, never enter
        inner = [KeepOut(z.name, z.az_min_deg + 1.0, z.az_max_deg - 1.0, z.el_min_deg, z.el_max_deg - 1.0)
                 for z in geometry.zones]
        limits = {a: rot.settings.limits(a) for a in rot.caps.axes}
        violations: list[str] = []
        outside = {z.name: False for z in inner}  # starting inside a zone is allowed: leave only

        def check(s):
            truth = s.sim_truth
            for a in rot.caps.axes:
                lo, hi = limits[a]
                t = truth[a]["deg"]
                if not (lo - slack(rot, a) <= t <= hi + slack(rot, a)):
                    violations.append(f"{a} truth {t:.2f} outside {lo}..{hi}")
            # (a single-axis rotator's beam stands at the horizon, el 0)
            az, el = geometry.to_sky(truth["az"]["deg"], truth["el"]["deg"] if rot.caps.has_el else 0.0)
            for z in inner:
                if not z.contains(az, el):
                    outside[z.name] = True
                elif outside[z.name]:
                    violations.append(f"truth az {az:.2f} el {el:.2f} entered {z.name}")

        for (cmd, *args), dwell_s in steps:
            try:
                getattr(rot, cmd)(*args)
            except CommandRejected:
                pass
            b.run(dwell_s, on_tick=check)
            assert not violations, violations[:3]
        # finally let every command run to its end
        b.run(60.0, on_tick=check, until=lambda s: not s.moving)
        assert not violations, violations[:3]


@settings(max_examples=200, deadline=None)
@given(az=angle, el=st.one_of(st.floats(-1000, 1000), st.sampled_from([math.nan, math.inf])))
def test_rejected_commands_never_change_the_target(az, el):
    with tempfile.TemporaryDirectory() as tmp:
        b = Bench("g5500", Path(tmp), keepout=[MAST])
        try:
            b.rot.goto(az, el)
        except CommandRejected:
            b.run(0.1)
            s = b.rot.status()
            assert s.az.target_deg is None and s.el.target_deg is None
            assert not s.moving
            return
        assert math.isfinite(az) and math.isfinite(el)
