"""Number syntax and angle formats that several protocols share. Pure functions."""

from __future__ import annotations

#: a plain decimal as the console protocols (Tartu, SARCNET, G4JNT, PstRotator) read
#: it: ``123``, ``-5.5``, ``.5``, ``12.``; no exponent, ``nan`` or ``inf``. (Regular
#: expression source, for str patterns; a long run of digits can still overflow a
#: float to inf, so callers check the value is finite.)
DECIMAL = r"[+-]?(?:\d+(?:\.\d*)?|\.\d+)"


def format_deg(v: float) -> str:
    """0.1 deg, three integer digits, zero padded: 123.4, 045.0, 000.0, -005.0 (Tartu
    replies, the G4JNT bearing)."""
    v = round(v, 1)
    if v == 0.0:
        v = 0.0  # no "-000.0"
    return ("-" if v < 0 else "") + f"{abs(v):05.1f}"


def compass_tenths(az_deg: float) -> float:
    """An azimuth rounded to 0.1 deg within 0..360: 359.97 is 0.0, not 360.0."""
    return round(az_deg, 1) % 360.0
