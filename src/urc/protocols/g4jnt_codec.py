"""G4JNT PIC rotator controller: the pot model, stream lines and commands (pure).

The controller reads the potentiometer through a 10-bit ADC with the pot loaded by a
resistor equal to its track, so the count is N = 2048 x / (1 + x) for wiper fraction x.
It linearises P = 4096 N / (2048 - N) (= 4096 x) and computes the bearing
M x P + C + Z: slope M and intercept C from a two-point calibration, zero offset Z.
This is the same model as ``urc.hardware.sim.sensors.PotSensor`` (ratiometric).

Stream line, every interval: ``b059.3,p1415`` CR LF (bearing in 0.1 deg with three
integer digits, P as a whole number, at least four digits).

Commands (lines ending CR or LF, letters in either case):

``Z12.5`` ``C-3.0`` ``K5`` ``M0.0879``   set a constant; answered with its stored value,
                                          e.g. ``Z12.5``
``Z`` ``C`` ``K`` ``M``                   report one constant
``?``                                     report all: ``Z0.0 C-50.4 K5.0 M0.1125``
``G123.4`` / ``G123.4,45.0``              go to bearing (and elevation) -> ``G123.4``
``S``                                     stop -> ``S``
Errors are one line ``? <what was expected>, got '<what came>'``.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

from .lines import crlf_line as line
from .numbers import DECIMAL, format_deg

ADC_MAX = 1023
CONSTANTS = "ZCKM"

_SET = re.compile(rf"\s*([ZCKMzckm])\s*({DECIMAL})?\s*\Z")
_GOTO = re.compile(rf"\s*[Gg]\s*({DECIMAL})(?:\s*,\s*({DECIMAL}))?\s*\Z")


class G4jntSyntaxError(ValueError):
    pass


@dataclass(frozen=True)
class G4jntCommand:
    kind: str                        # "const" | "all" | "goto" | "stop"
    name: str = ""                   # constant letter (upper case)
    value: float | None = None       # const: None = report
    az_deg: float | None = None
    el_deg: float | None = None


def _finite(text: str) -> float:
    v = float(text)
    if not math.isfinite(v):
        raise G4jntSyntaxError(f"number {text[:20]!r} out of range")
    return v


def parse_line(raw: bytes) -> G4jntCommand | None:
    text = raw.decode("latin-1").strip()
    if not text:
        return None
    m = _SET.match(text)
    if m:
        name = m.group(1).upper()
        value = None if m.group(2) is None else _finite(m.group(2))
        if name == "M" and value is not None and value <= 0:
            raise G4jntSyntaxError(f"M (degrees per P unit) must be > 0, got {m.group(2)!r}")
        if name == "K" and value is not None and value < 0:
            raise G4jntSyntaxError(f"K (slow/fast threshold, degrees) must be >= 0, got {m.group(2)!r}")
        return G4jntCommand("const", name=name, value=value)
    m = _GOTO.match(text)
    if m:
        return G4jntCommand("goto", az_deg=_finite(m.group(1)),
                            el_deg=None if m.group(2) is None else _finite(m.group(2)))
    if text in ("S", "s"):
        return G4jntCommand("stop")
    if text == "?":
        return G4jntCommand("all")
    raise G4jntSyntaxError(f"expected Z|C|K|M[value], G<bearing>[,<elevation>], S or ?, got {text[:40]!r}")


# ---------------------------------------------------------------------- pot model
def adc_counts(p_ideal: float) -> int:
    """The 10-bit count the loaded pot gives at P = 4096 x (x clamped to 0..1)."""
    x = min(max(p_ideal / 4096.0, 0.0), 1.0)
    return min(max(round(2048.0 * x / (1.0 + x)), 0), ADC_MAX)


def linearise(n: int) -> float:
    """P = 4096 N / (2048 - N)."""
    return 4096.0 * n / (2048.0 - n)


def p_for_bearing(bearing_deg: float, m: float, c: float, z: float) -> int:
    """The P the controller would compute with its pot at ``bearing_deg``: the inverse
    calibration, then the ADC's quantisation."""
    return round(linearise(adc_counts((bearing_deg - c - z) / m)))


def bearing_for_p(p: float, m: float, c: float, z: float) -> float:
    return m * p + c + z


# ---------------------------------------------------------------------- formatting
def stream_line(bearing_deg: float, p: int) -> bytes:
    return line(f"b{format_deg(bearing_deg)},p{p:04d}")


def format_constant(name: str, value: float) -> str:
    """``M0.0879``, ``C-3.0``, ``K5.0``: up to 6 significant digits, always a point."""
    text = f"{value:.6g}"
    if not any(ch in text for ch in ".en"):
        text += ".0"
    return f"{name}{text}"


def parse_stream_line(raw: bytes) -> tuple[float, int]:
    """``b059.3,p1415`` -> (59.3, 1415), for tests and clients."""
    m = re.fullmatch(rb"b(-?\d+\.\d),p(\d+)\r?\n?", raw)
    if not m:
        raise ValueError(f"expected b###.#,p####, got {raw!r}")
    return float(m.group(1)), int(m.group(2))
