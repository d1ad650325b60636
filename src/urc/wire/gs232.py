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

from ..errors import ProtocolError


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
# BIG-RAS extensions (seed 002): AZ=aaa, EL=eee, AZ=aaa EL=eee, Keee, ML/MR/MU/MD, H
_AZEL_RE = re.compile(rb"(?:AZ *= *" + _ANGLE + rb")? *(?:EL *= *" + _ANGLE + rb")?")
_K_RE = re.compile(rb"K *" + _ANGLE)
_M_MOVES = {b"ML": b"L", b"MR": b"R", b"MU": b"U", b"MD": b"D"}
_TIMED_RE = re.compile(rb"[MW] *[0-9]{1,3}( +[0-9]{1,3}){2,}")


class Gs232ParseError(ProtocolError):
    """A line that is not valid GS-232."""


@dataclass(frozen=True)
class Command:
    op: str                        # read | goto | goto_az | goto_el | stop | move | speed | help | nmea
    what: str | None = None        # read: az | el | azel; stop/move: axis (None = both)
    az_deg: float | None = None
    el_deg: float | None = None
    direction: int = 0
    level: int = 0
    text: bytes = b""              # nmea: the sentence


def parse_command(line: bytes) -> Command:
    """One line (terminator removed) -> its command. Surrounding spaces are ignored.
    Besides GS-232A/B: the BIG-RAS controller's extensions (``AZ=aaa``, ``EL=eee``,
    ``AZ=aaa EL=eee``, ``Keee``, ``ML`` ``MR`` ``MU`` ``MD``, ``H`` help) and NMEA
    sentences (``$GPGGA,...``: a point to turn to)."""
    raw = line.strip(b" \t")
    if raw.startswith(b"$"):
        return Command("nmea", text=raw)
    cmd = raw.upper()
    if cmd in _READS:
        return Command("read", _READS[cmd])
    if cmd in _STOPS:
        return Command("stop", _STOPS[cmd])
    if cmd in _MOVES or cmd in _M_MOVES:
        axis, direction = _MOVES[_M_MOVES.get(cmd, cmd)]
        return Command("move", axis, direction=direction)
    if cmd == b"H":
        return Command("help")
    if cmd.startswith((b"AZ", b"EL")) and (m := _AZEL_RE.fullmatch(cmd)) and (m.group(1) or m.group(2)):
        az = None if m.group(1) is None else float(m.group(1))
        el = None if m.group(2) is None else float(m.group(2))
        return Command("goto" if az is not None and el is not None else "goto_az" if el is None else "goto_el",
                       az_deg=az, el_deg=el)
    if m := _K_RE.fullmatch(cmd):
        return Command("goto_el", el_deg=float(m.group(1)))
    if m := _W_RE.fullmatch(cmd):
        return Command("goto", az_deg=float(m.group(1)), el_deg=float(m.group(2)))
    if m := _M_RE.fullmatch(cmd):
        return Command("goto_az", az_deg=float(m.group(1)))
    if m := _X_RE.fullmatch(cmd):
        return Command("speed", level=int(m.group(1)))
    if _TIMED_RE.fullmatch(cmd):
        raise Gs232ParseError("W/M with one position (timed lists with T are not supported)", line)
    raise Gs232ParseError("a GS-232 command (H lists them)", line[:20])


#: the H reply: the command set, one line each (BIG-RAS's own list, in this order)
HELP_LINES = (
    "Waaa eee - turn to azimuth aaa, elevation eee", "A - stop azimuth turning",
    "AZ=aaa - turn to azimuth aaa", "AZ=aaa EL=eee - turn to azimuth aaa, elevation eee",
    "E - stop elevation turning", "EL=eee - turn to elevation eee", "S - stop all turning",
    "Maaa - turn to azimuth aaa", "Keee - turn to elevation eee",
    "ML - turn counterclockwise", "MR - turn clockwise", "MU - turn up", "MD - turn down",
    "L - turn counterclockwise", "R - turn clockwise", "U - turn up", "D - turn down",
    "C - azimuth", "C2 - azimuth and elevation", "B - elevation", "X1..X4 - speed",
    "$GPGGA,... - turn to the reported point (station coordinates needed)", "H - this list",
)


def format_help() -> bytes:
    return "".join(f"{row}\r\n" for row in HELP_LINES).encode()


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


def format_move(axis: str, direction: int, speed_frac: float) -> bytes:
    """A jog at the nearest speed level at or above ``speed_frac`` (X1..X4), then R/L
    (azimuth) or U/D (elevation); it runs until a stop or a new target."""
    level = next(n for n, frac in sorted(SPEED_LEVELS.items()) if frac >= min(speed_frac, 1.0) - 1e-9)
    letter = next(k for k, v in _MOVES.items() if v == (axis, 1 if direction > 0 else -1))
    return b"X%d\r%s\r" % (level, letter)
