"""Yaesu GS-232A/B wire format: pure parse and format functions, no state.

A command is one line of ASCII (ended by ``\\r``; ``\\n`` and ``\\r\\n`` accepted), one
letter plus digits, upper or lower case (the GS-232A manual allows both). Angles are
whole degrees, three digits, zero-padded; azimuth 0..450 on a 450 deg rotator.

Both sides are here: the device side (what urc serves) and the host side (what Hamlib
models 601/602/603/608 send and how they parse replies) for tests and for bridges that
drive a real GS-232 controller.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from .base import ProtocolError


#: reply styles: GS-232A, GS-232B, and the generic GS-232 / FoxDelta ST2 family.
STYLE_A, STYLE_B, STYLE_GENERIC = "a", "b", "generic"
#: X1 (slowest) .. X4 (fastest) as a fraction of the axis' top speed.
SPEED_LEVELS = {1: 0.25, 2: 0.5, 3: 0.75, 4: 1.0}
_MOVES = {b"L": ("az", -1), b"R": ("az", 1), b"D": ("el", -1), b"U": ("el", 1)}
_STOPS = {b"S": None, b"A": "az", b"E": "el"}
_READS = {b"C": "az", b"B": "el", b"C2": "azel"}
_ANGLE = rb"([0-9]{1,3})"
_W_RE = re.compile(rb"W *" + _ANGLE + rb" +" + _ANGLE)
_M_RE = re.compile(rb"M *" + _ANGLE)
_X_RE = re.compile(rb"X *([1-4])")
_TIMED_RE = re.compile(rb"[MW] *[0-9]{1,3}( +[0-9]{1,3}){2,}")


class Gs232ParseError(ProtocolError):
    """A line that is not valid GS-232."""


@dataclass(frozen=True)
class Command:
    op: str                        # read | goto | goto_az | stop | move | speed
    what: str | None = None        # read: az | el | azel; stop/move: axis (None = both)
    az_deg: float | None = None
    el_deg: float | None = None
    direction: int = 0
    level: int = 0


def parse_command(line: bytes) -> Command:
    """One line (terminator removed) -> its command. Surrounding spaces are ignored."""
    cmd = line.strip(b" \t").upper()
    if cmd in _READS:
        return Command("read", _READS[cmd])
    if cmd in _STOPS:
        return Command("stop", _STOPS[cmd])
    if cmd in _MOVES:
        axis, direction = _MOVES[cmd]
        return Command("move", axis, direction=direction)
    if m := _W_RE.fullmatch(cmd):
        return Command("goto", az_deg=float(m.group(1)), el_deg=float(m.group(2)))
    if m := _M_RE.fullmatch(cmd):
        return Command("goto_az", az_deg=float(m.group(1)))
    if m := _X_RE.fullmatch(cmd):
        return Command("speed", level=int(m.group(1)))
    if _TIMED_RE.fullmatch(cmd):
        raise Gs232ParseError("W/M with one position (timed lists with T are not supported)", line)
    raise Gs232ParseError("one of C C2 B W<aaa> <eee> M<aaa> S A E L R U D X1..X4", line)


# ---------------------------------------------------------------- device replies
def _three(value_deg: float) -> int:
    """Whole degrees, as the controller shows them (round half to even, like Hamlib's rint)."""
    return min(max(round(value_deg), 0), 999)


def format_position(style: str, az_deg: float | None, el_deg: float | None) -> bytes:
    """Reply to C (az only), B (el only) or C2 (both), terminator included.

    A: ``+0aaa+0eee\\r\\n`` (Hamlib 601 reads to LF); B: ``AZ=aaa  EL=eee\\r\\n`` (603 reads
    to CR, ARTSAT to CRLF); generic: ``+0aaa+0eee\\r`` (602/608 read to CR, at most 11).
    """
    if style == STYLE_B:
        parts = ([f"AZ={_three(az_deg):03d}"] if az_deg is not None else []) + \
                ([f"EL={_three(el_deg):03d}"] if el_deg is not None else [])
        return ("  ".join(parts) + "\r\n").encode()
    text = "".join(f"+0{_three(v):03d}" for v in (az_deg, el_deg) if v is not None)
    return (text + ("\r" if style == STYLE_GENERIC else "\r\n")).encode()


def format_error(style: str) -> bytes:
    """``?>``: the GS-232A returns it plus CR; B-style clients read lines to CRLF."""
    return b"?>\r\n" if style == STYLE_B else b"?>\r"


# ---------------------------------------------------------------- host side (Hamlib)
def format_goto(az_deg: float, el_deg: float) -> bytes:
    """What Hamlib sends for set_position: rint, negative azimuth + 360."""
    az = round(az_deg)
    az = az + 360 if az < 0 else az
    return f"W{az:03d} {round(el_deg):03d}\r".encode()


_A_RE = re.compile(rb"\+0\s*([+-]?[0-9]+)\+0\s*([+-]?[0-9]+)")
_B_RE = re.compile(rb"AZ=\s*([+-]?[0-9]+)(?:\s*EL=\s*([+-]?[0-9]+))?")
_F_RE = re.compile(rb"\s*[+-]?[0-9]*\.?[0-9]+")


def parse_position_reply(style: str, reply: bytes) -> tuple[float, float]:
    """A C2 reply parsed as Hamlib does: 601 ``sscanf("+0%d+0%d")``; 603
    ``sscanf("AZ=%d EL=%d")`` (at least az, 10 characters or more); 602/608 ``%f`` at
    byte offsets 2 and 7."""
    if style == STYLE_A:
        m = _A_RE.match(reply)
        if m is None:
            raise Gs232ParseError("+0aaa+0eee", reply)
        return float(m.group(1)), float(m.group(2))
    if style == STYLE_B:
        m = _B_RE.match(reply)
        if len(reply.rstrip(b"\r\n")) < 10 or m is None:
            raise Gs232ParseError("AZ=aaa  EL=eee", reply)
        return float(m.group(1)), float(m.group(2) or 0)
    az, el = _F_RE.match(reply, 2), _F_RE.match(reply, 7)
    if len(reply) < 10 or az is None or el is None:
        raise Gs232ParseError("+0aaa+0eee", reply)
    return float(az.group()), float(el.group())


def format_query() -> bytes:
    """C2: both positions (what a host polls with)."""
    return b"C2\r"


def format_stop() -> bytes:
    """S: stop both axes."""
    return b"S\r"
