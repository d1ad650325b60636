"""urc.angles: the one azimuth fold, for floats and arrays alike."""

import numpy as np

from urc.angles import wrap180_deg


def test_wrap180_folds_floats_and_arrays_into_minus_180_to_180():
    assert wrap180_deg(190.0) == -170.0
    assert wrap180_deg(-190.0) == 170.0
    assert wrap180_deg(180.0) == -180.0
    assert wrap180_deg(359.5) == -0.5
    np.testing.assert_allclose(wrap180_deg(np.array([0.0, 270.0, -450.0, 720.25])), [0.0, -90.0, -90.0, 0.25])
