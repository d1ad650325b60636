"""The rotctld wire codec's value round trips: argument words to values and back, read
strictly (nothing half-understood reaches the rotator)."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from urc.wire.rotctld import codec


@given(st.floats(min_value=-1e6, max_value=1e6, allow_nan=False))
def test_float_round_trip(x):
    for text in (f"{x:f}", f"{x:.2f}", repr(x), f"{x:e}"):
        assert codec.parse_float(text) == pytest.approx(float(text))
    assert codec.parse_position(f"{x:.2f}".replace(".", ","), "0") == (float(f"{x:.2f}"), 0.0)


@given(st.floats(min_value=0, max_value=360, allow_nan=False), st.floats(min_value=-90, max_value=180))
def test_position_format_round_trip(az, el):
    text = codec.format_position(az, el, None)
    a, e, rest = text.split("\n")
    assert rest == "" and abs(float(a) - az) <= 0.005 + 1e-9 and abs(float(e) - el) <= 0.005 + 1e-9
    assert codec.format_position(az, el, ";") == f"Azimuth: {a};Elevation: {e};"


@given(st.integers(min_value=-2**31, max_value=2**31 - 1))
def test_int_round_trip(n):
    assert codec.parse_int(str(n)) == n
    assert codec.parse_int("%+d" % n) == n


def test_parse_rejects():
    for w in ("nan", "inf", "1e999", "", "1 ", " 1", "0x1", "1e", "--1", "1.2.3"):
        assert codec.parse_float(w) is None, w
    for w in ("2147483648", "1.0", "", "x", "1e3"):
        assert codec.parse_int(w) is None, w
    assert codec.parse_direction("+16", False) == (("az", 1),)
    assert codec.parse_direction("64", False) is None and codec.parse_direction("64", True) == (("el", 1), ("az", 1))
