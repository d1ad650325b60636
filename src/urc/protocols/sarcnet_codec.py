"""SARCNET mini rotator serial lines: parse and format (pure functions).

Two kinds of line share the port, as on the Arduino (Rotator7.ino): the console a person
types (single letters, ``az el`` pairs) and the Easycomm II subset Hamlib's rotctld
(model 202) sends. Console replies end CR LF (Arduino ``println``); Easycomm replies end
LF only.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

from ..errors import ProtocolError
from .lines import crlf_line as console
from .numbers import DECIMAL, compass_tenths
from ..angles import wrap180_deg

EASYCOMM_EOL = b"\n"

_PAIR = re.compile(rf"\s*({DECIMAL})(?:\s*,\s*|\s+)({DECIMAL})\s*\Z")
_EASY_TOKEN = re.compile(rf"(AZ|EL|UP|DN|SA|SE)({DECIMAL})?\Z")
_DECL = re.compile(rf"\s*({DECIMAL})\s*\Z")

LETTERS = "rbcdmaesph"


class SarcnetSyntaxError(ProtocolError):
    pass


@dataclass(frozen=True)
class SarcnetCommand:
    kind: str                      # "letter" | "goto" | "ec_query" | "ec_set" | "ec_stop"
    letter: str = ""               # console letter (lower case)
    az_deg: float | None = None
    el_deg: float | None = None
    text: str = ""                 # parameter text (e<decl>)
    axes: tuple[str, ...] = ()     # ec_query: ("az",), ("el",) or both; ec_stop: stopped axes


def _number(text: str) -> float:
    v = float(text)
    if not math.isfinite(v):
        raise SarcnetSyntaxError(f"number {text!r} out of range")
    return v


def _easycomm(tokens: list[str]) -> SarcnetCommand:
    values: dict[str, float | None] = {}
    stops: list[str] = []
    skip_mode = False
    for tok in tokens:
        if skip_mode and tok.isalpha():      # the mode word after UPnnn / DNnnn (Easycomm I)
            skip_mode = False
            continue
        skip_mode = False
        m = _EASY_TOKEN.match(tok)
        if not m:
            raise SarcnetSyntaxError(f"Easycomm: expected AZ[x] EL[y] (UP/DN/SA/SE), got {tok!r}")
        name, num = m.group(1), m.group(2)
        if name in ("SA", "SE"):
            stops.append("az" if name == "SA" else "el")
        elif name in ("AZ", "EL"):
            values[name] = None if num is None else _number(num)
        else:
            skip_mode = True
    if stops:
        return SarcnetCommand("ec_stop", axes=tuple(stops))
    given = {k: v for k, v in values.items() if v is not None}
    if not given:
        axes = tuple(a for a, k in (("az", "AZ"), ("el", "EL")) if k in values)
        if not axes:
            raise SarcnetSyntaxError(f"Easycomm: expected AZ or EL, got {' '.join(tokens)!r}")
        return SarcnetCommand("ec_query", axes=axes)
    return SarcnetCommand("ec_set", az_deg=given.get("AZ"), el_deg=given.get("EL"))


def parse_line(raw: bytes) -> SarcnetCommand | None:
    """One line (terminator removed) -> command; None for an empty line.
    Raises SarcnetSyntaxError with what was expected and what came."""
    # a leading ';' is Hamlib's stray conf-command separator (protocols.md §2.2)
    text = raw.decode("latin-1").strip().lstrip(";").strip()
    if not text:
        return None
    if text[:2] in ("AZ", "EL", "SA", "SE"):
        return _easycomm(text.split())
    m = _PAIR.match(text)
    if m:
        return SarcnetCommand("goto", az_deg=_number(m.group(1)), el_deg=_number(m.group(2)))
    letter = text[0].lower()
    if letter == "e":
        rest = text[1:]
        if not rest.strip():
            return SarcnetCommand("letter", letter="e")
        if _DECL.match(rest):
            return SarcnetCommand("letter", letter="e", text=rest.strip())
    elif letter in LETTERS and len(text) == 1:
        return SarcnetCommand("letter", letter=letter)
    # brief (one short line per bad line, issue 13.1): h lists the commands
    raise SarcnetSyntaxError(f"unknown command {text[:20]!r}: expected 'az el' or a letter (h: help)")


# ------------------------------------------------------------------- formatting
def easycomm_position(axes: tuple[str, ...], az_deg: float, el_deg: float) -> bytes:
    """``AZ123.4\\n``, ``EL45.6\\n`` or (Hamlib 4.5's ``AZ EL``) ``AZ123.4 EL45.6\\n``."""
    az_deg = compass_tenths(az_deg)            # 359.97 is AZ0.0, not AZ360.0
    parts = [f"AZ{az_deg:.1f}" if a == "az" else f"EL{el_deg:.1f}" for a in axes]
    return " ".join(parts).encode("ascii") + EASYCOMM_EOL


def _i(v: float) -> str:
    """Arduino ``print(v, 0)``: rounded, no decimals."""
    s = f"{v:.0f}"
    return "0" if s == "-0" else s


def monitor_line(az: float, el: float, az_set: float, el_set: float, az_windup: float,
                 windup: bool, az_error: float, el_error: float) -> bytes:
    """Monitor mode row: az,el,azSet,elSet,azWindup,windup,azError,elError."""
    return console(",".join((_i(az), _i(el), _i(az_set), _i(el_set), _i(az_windup),
                             "1" if windup else "0", _i(az_error), _i(el_error))))


def demo_line(az_set: float, el_set: float) -> bytes:
    return console(f"{_i(az_set)},{_i(el_set)}")


def signed180(az_deg: float) -> float:
    """0..360 -> -180..180, the SARCNET controller's azimuth format."""
    return wrap180_deg(az_deg)


#: what ``c`` prints first. The document gives no prompt text (its screenshot is lost):
#: it says to disconnect the motor supply, to point each of the board's six faces along
#: the magnetic field and along gravity (12 directions), to move gently, and that the
#: screen tells when each point is done; urc asks for them in a fixed order but takes
#: them in any order.
CALIBRATION_INTRO = (
    "Calibration in progress: Press 'a' to abort",
    "Motor supply off; take the sensor off the boom and hold it gently",
    "Point each face (+X -X +Y -Y +Z -Z) down (gravity) and along the magnetic field",
    "(north, dipping into the ground), 12 directions; hold each still until done",
)


def direction_text(face: str, along: str) -> str:
    """``+X face down`` / ``+X face along the magnetic field``."""
    return f"{face} face " + ("down" if along == "gravity" else "along the magnetic field")


def _triple(v) -> str:
    return ",".join(f"{c:.3f}" for c in v)


def calibration_rows(mag, acc) -> list[str]:
    """The calibration data the console shows as it changes (the document's "3D
    magnetometer (M) and accelerometer (G) errors and scaling factors"): offsets and
    half ranges per axis, and how far from a sphere the magnetometer's ellipsoid is."""
    return [f"M offset {_triple(mag.centre)} scale {_triple(mag.half_extent)} "
            f"soft iron {mag.axis_ratio:.3f}",
            f"G offset {_triple(acc.centre)} scale {_triple(acc.half_extent)}"]


HELP = ("Commands:", "az el -(0..360 or -180..180, 0..180)", "r -Reset", "eNN.N -MagDecl",
        "c -Calibrate", "s -Save", "a -Abort", "d -Demo", "b -Debug", "m -Monitor", "p -Pause",
        "h -Help")
