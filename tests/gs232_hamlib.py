"""How Hamlib's GS-232 backends read a reply off the wire: shared by the codec's tests
(tests/wire/test_gs232.py) and the sessions' (tests/protocols/test_gs232.py)."""

from __future__ import annotations

from urc.wire.gs232 import STYLE_A, STYLE_B


def hamlib_read(style: str, out: bytes) -> bytes:
    """The line Hamlib's reader takes from the device's output (protocols.md 3.2-3.4):
    601 reads up to LF; 603 up to the first CR or LF; 602/608 up to CR, at most 11 bytes."""
    if style == STYLE_A:
        return out[:out.index(b"\n") + 1]
    if style == STYLE_B:
        ends = [i for i in (out.find(b"\r"), out.find(b"\n")) if i >= 0]
        return out[:min(ends) + 1]
    return out[:out.index(b"\r") + 1][:11]
