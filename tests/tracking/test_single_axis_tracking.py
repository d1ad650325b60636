"""A pass flown by a single-axis rotator ([rotator] elevation = false): the azimuth
follows the whole pass above min_el, with no flip and no elevation targets."""

from __future__ import annotations

import numpy as np
import pytest

from urc.testing.evaluate import fly_pass_on_sim
from urc.tracking.passes import find_passes
from urc.tracking.propagate import look_angles

from .conftest import T0_UNIX_S


def test_the_azimuth_follows_the_whole_pass(tmp_path, leo_sets, station):
    es = next(s for s in leo_sets if s.norad_id == 25544)
    p = max(find_passes(es, station, T0_UNIX_S, duration_s=86400, min_el_deg=10), key=lambda p: p.max_el_deg)
    flown = fly_pass_on_sim("tartu-urc", es, station, p, tmp_path, config={"rotator": {"elevation": False}})
    rot, plan = flown.rotator, flown.plan
    s = rot.status()
    assert not s.faults and s.el is None
    assert not plan.flip and np.all(plan.el_deg == 0.0)  # no elevation targets at all
    assert plan.sky_el_deg.max() == pytest.approx(p.max_el_deg, abs=0.5)  # the display keeps the sky
    t, az, _ = flown.flight
    up = (t >= p.aos_unix_s) & (t <= p.los_unix_s)
    la = look_angles(es, station, t[up])
    az_err = np.abs((az[up] - la.az_deg + 180.0) % 360.0 - 180.0)
    # pre-positioned and following from AOS to LOS (0.1 deg encoder, 0.2 restart band)
    assert az_err[0] < 0.5 and np.sqrt(np.mean(az_err ** 2)) < 0.2 and az_err.max() < 0.6, az_err.max()
    truth_el = s.sim_truth["el"]
    assert truth_el["rate_deg_per_s"] == 0.0  # nothing ever drove the elevation joint
