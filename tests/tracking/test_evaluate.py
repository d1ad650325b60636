"""The benchmark's reference driver: Gpredict's own whole-pass flip rule."""

from __future__ import annotations

import numpy as np

from urc.testing.evaluate import gpredict_flips


def test_gpredict_flips_a_pass_across_north_only_on_a_180_deg_elevation_rotator():
    across_north = np.array([300.0, 330.0, 355.0, 10.0, 40.0])
    east_to_south = np.array([80.0, 120.0, 170.0, 200.0])
    assert gpredict_flips(across_north, 180.0)
    assert not gpredict_flips(across_north, 90.0)   # cannot flip: flown as it comes
    assert not gpredict_flips(east_to_south, 180.0)  # nothing to flip for
