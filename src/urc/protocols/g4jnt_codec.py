"""G4JNT PIC rotator controller (seed 003): the pot arithmetic, the stored constants,
the serial stream and the command syntax, in the controller's own integer units (pure).

The pot is read through a 10-bit ADC as a divider fed from K x Vref (K = 2), so the
count is N = 1024 K x / (1 + x) for wiper fraction x, and the PIC linearises
P = 4096 N / (1024 K - N) (about 0..4096, linear in rotation). The stored constant
``K`` is that 1024 K: 2048 for the document's gain of 2.

Angles are integers in 0.1 deg. theta = C + M x P / 16384 (truncated toward zero)
is the angle from the end-stop reference; the bearing is theta + Z brought into
000.0..359.9 by whole turns (so the stream never prints ``b-000.1``).

Units of M: the document gives M = -15897 and C = 3758 with its P/bearing pairs but
not the scale of M. One scale and rounding rule reproduce all ten stream lines of its
Table 1 exactly: M in 1/16384 of 0.1 deg per P unit, the product truncated toward zero
(what sign-magnitude integer arithmetic on a PIC gives). That is what this module uses.

Wire format (lines end CR LF):

* power-on banner and stored-constants listing (Table 1), see :func:`banner`;
* stream, one line per interval: ``b059.3,p1415``;
* commands (lines ending CR or LF, letters in either case):

  ``#Z1807`` ``#M-15897`` ``#C3758`` ``#K2048``  set a constant: ``#`` + letter +
                             signed integer (``(-)nnnn(n)``) in the units above
                             (Z a bearing, 0..3599); answered with its listing
                             line, e.g. ``Z 1807``
  ``L`` / ``R``             go-left / go-right: pulse the rotator one step
  ``G123.4`` / ``G123.4,45`` go to a bearing (and elevation)    -> ``G123.4``  (urc's)
  ``S``                     stop                                -> ``S``       (urc's)
  ``?``                     the stored-constants listing again             (urc's)

The document names go-left/go-right commands without their bytes; ``L`` and ``R``
were chosen after its left/right buttons. ``G``, ``S`` and ``?`` are urc's additions
(the document leaves the rest of the command set to its online notes). Errors are one
line ``? <what was expected>, got '<what came>'``.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, replace

from ..errors import ProtocolError
from .lines import crlf_line as line
from .numbers import DECIMAL

ADC_MAX = 1023
#: M is in 1/M_SCALE of 0.1 deg per P unit (see the module notes)
M_SCALE = 16384
TENTHS_PER_TURN = 3600
CONSTANT_ORDER = "ZMCK"               # the order of Table 1's listing
#: the constant may be written with up to 6 digits: (-)nnnn(n), plus room for M's range
_SET = re.compile(rb"\s*#\s*([ZCKMzckm])\s*([+-]?\d{1,6})\s*\Z")
_GOTO = re.compile(rf"\s*[Gg]\s*({DECIMAL})(?:\s*,\s*({DECIMAL}))?\s*\Z")


class G4jntSyntaxError(ProtocolError):
    pass


@dataclass(frozen=True)
class Constants:
    """The controller's stored constants, in its own integer units."""

    z: int = 0          # bearing of the end-stop reference, 0.1 deg
    m: int = 18432      # slope, 1/16384 of 0.1 deg per P unit
    c: int = 0          # intercept, 0.1 deg
    k: int = 2048       # 1024 x the divider's drive gain K

    def get(self, name: str) -> int:
        return getattr(self, name.lower())

    def with_value(self, name: str, value: int) -> "Constants":
        return replace(self, **{name.lower(): value})


#: Table 1 of the document
TABLE_1 = Constants(z=1807, m=-15897, c=3758, k=2048)


@dataclass(frozen=True)
class G4jntCommand:
    kind: str                        # "const" | "all" | "goto" | "stop" | "pulse"
    name: str = ""                   # constant letter (upper case)
    value: int | None = None         # const: the new value
    az_deg: float | None = None
    el_deg: float | None = None
    direction: int = 0               # pulse: -1 left, +1 right


def check_constant(name: str, value: int) -> None:
    # Z is the bearing entered for the end-stop reference, kept "within the range 000 to
    # 359.9" (the document): #Z3700 or #Z-5 is a mistake, not a bearing to wrap
    if name == "Z" and not 0 <= value < TENTHS_PER_TURN:
        raise G4jntSyntaxError(f"#Z: expected a bearing 0..{TENTHS_PER_TURN - 1} (000.0..359.9 deg in "
                               f"0.1 deg), got {value}")
    if name == "M" and value == 0:
        raise G4jntSyntaxError("#M: expected a non-zero slope, got 0")
    if name == "K" and not ADC_MAX < value <= 4 * ADC_MAX:
        raise G4jntSyntaxError(f"#K: expected 1024 x the divider gain (1024..4096), got {value}")


def parse_line(raw: bytes) -> G4jntCommand | None:
    text = raw.strip()
    if not text:
        return None
    m = _SET.match(text)
    if m:
        name, value = m.group(1).decode().upper(), int(m.group(2))
        check_constant(name, value)
        return G4jntCommand("const", name=name, value=value)
    upper = text.upper()
    if upper in (b"L", b"R"):
        return G4jntCommand("pulse", direction=-1 if upper == b"L" else 1)
    if upper == b"S":
        return G4jntCommand("stop")
    if text == b"?":
        return G4jntCommand("all")
    g = _GOTO.match(text.decode("latin-1"))
    if g:
        return G4jntCommand("goto", az_deg=_finite(g.group(1)),
                            el_deg=None if g.group(2) is None else _finite(g.group(2)))
    raise G4jntSyntaxError(f"expected #Z/C/K/M(-)nnnn, L, R, G<bearing>, S or ?, got {text[:20]!r}")


def _finite(text: str) -> float:
    if len(text) > 12:
        raise G4jntSyntaxError(f"number {text[:20]!r} out of range")
    return float(text)


# ---------------------------------------------------------------------- arithmetic
def adc_counts(x: float, k: int = 2048) -> int:
    """The count the loaded pot gives at wiper fraction x (clamped to 0..1)."""
    x = min(max(x, 0.0), 1.0)
    return min(max(round(k * x / (1.0 + x)), 0), ADC_MAX)


def linearise(n: int, k: int = 2048) -> int:
    """P = 4096 N / (K - N), as the PIC computes it (integer)."""
    return 4096 * n // (k - n) if n < k else 4096 * ADC_MAX


def bearing_tenths(p: int, k: Constants) -> int:
    """The bearing (0.1 deg, 0..3599) the controller computes from P."""
    product = k.m * p
    theta = k.c + (abs(product) // M_SCALE) * (1 if product >= 0 else -1)   # toward zero
    return (theta + k.z) % TENTHS_PER_TURN


def p_for_bearing(bearing_deg: float, k: Constants) -> int:
    """Without a pot (a g4jnt session on another rotator): the P that would give
    ``bearing_deg`` at the reference turn, for a stream that still reads like one."""
    want = round(bearing_deg * 10) % TENTHS_PER_TURN
    theta = (want - k.z - k.c) % TENTHS_PER_TURN
    guess = round(theta * M_SCALE / k.m) % 4096
    # the truncating arithmetic may land a tenth off: take the nearest P that does not
    return min(range(guess - 2, guess + 3),
               key=lambda p: abs((bearing_tenths(p, k) - want + 1800) % TENTHS_PER_TURN - 1800))


# ----------------------------------------------------------- sensor calibration units
def to_sensor(k: Constants) -> dict[str, float]:
    """The pot driver's constants (degrees: theta = M P + C, bearing = theta + Z; and K)."""
    return {"M": k.m / M_SCALE / 10.0, "C": k.c / 10.0, "Z": k.z / 10.0, "K": float(k.k)}


def sensor_values(changes: dict[str, int]) -> dict[str, float]:
    """Only the named constants (Z, M, C, K in the controller's units) in the pot driver's
    units, as :func:`to_sensor` converts them."""
    every = to_sensor(Constants(**{n.lower(): v for n, v in changes.items()}))
    return {n: every[n] for n in changes}


def from_sensor(cal: dict) -> Constants:
    return Constants(z=round(float(cal.get("Z", 0.0)) * 10), m=round(float(cal["M"]) * 10 * M_SCALE),
                     c=round(float(cal.get("C", 0.0)) * 10), k=round(float(cal.get("K", 2048))))


# ---------------------------------------------------------------------- formatting
def stream_line(bearing_tenths_: int, p: int) -> bytes:
    t = bearing_tenths_ % TENTHS_PER_TURN
    return line(f"b{t // 10:03d}.{t % 10},p{max(p, 0):04d}")


def constant_line(name: str, k: Constants) -> bytes:
    return line(f"{name} {k.get(name)}")


def banner(k: Constants) -> bytes:
    """What the controller prints when turned on (Table 1): its name, the stored
    constants and the command summary. The table was typeset in a narrow column; its
    wrapped lines ("G4JNT Rotator / Controller", "Commands # + / Z/C/K/M + ...") are
    joined here, one printed line each, and the blank line before the summary kept."""
    return (line("G4JNT Rotator Controller") + line("Stored Constants -")
            + b"".join(constant_line(n, k) for n in CONSTANT_ORDER)
            + line("") + line("Commands # + Z/C/K/M + (-)nnnn(n)"))


def parse_stream_line(raw: bytes) -> tuple[float, int]:
    """``b059.3,p1415`` -> (59.3, 1415), for tests and clients."""
    m = re.fullmatch(rb"b(\d{3}\.\d),p(\d{4,})\r?\n?", raw)
    if not m:
        raise ValueError(f"expected b###.#,p####, got {raw!r}")
    return float(m.group(1)), int(m.group(2))
