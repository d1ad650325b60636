"""Tartu URC four-letter command set: parse a line, format replies (pure functions).

Line syntax: a four-letter command (case-insensitive), then its comma-separated
parameters after spaces or after a comma, e.g. ``GOAE 123.4,45.0`` or the document's own
form, command and parameters all separated by commas: ``GOAE,123.4,45.0``. Numbers are plain decimals
(``123``, ``-5.5``, ``.5``); no exponents, ``nan`` or ``inf``.

Replies are lines ending CR LF. Angles print as ``xxx.x`` (0.1 deg, three integer digits,
zero padded: ``045.0``; negative ``-005.0``). Errors print as ``ERR <code> <text>``, the
text saying what was expected and what was received.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Callable

from ..errors import ProtocolError
from .lines import crlf_line as line
from .numbers import DECIMAL, format_deg
from .poses import extended_targets_deg, shown_pose_deg
from .single_axis import wire_status

# error codes (ERR <code> <text>)
E_UNKNOWN = 1        # no such command
E_SYNTAX = 2         # missing, extra or malformed parameter
E_LIMIT = 3          # outside the rotator's limits
E_KEEPOUT = 4        # target or path in a keep-out zone
E_FAULT = 5          # a latched fault blocks motion
E_UNCERTAIN = 6      # position not known: re-reference first (WRAZ/WREL)
E_UNSUPPORTED = 7    # recognised but not possible on this rotator
E_OVERFLOW = 8       # line too long, dropped
E_REJECTED = 9       # refused by the rotator for another reason

#: CommandRejected.reason -> error code
REASON_CODES = {"limit": E_LIMIT, "keepout": E_KEEPOUT, "fault": E_FAULT, "state": E_FAULT,
                "uncertain": E_UNCERTAIN, "invalid": E_REJECTED, "no_axis": E_UNSUPPORTED}

BAUD_RATES = (1200, 2400, 4800, 9600, 19200, 38400, 57600, 115200, 230400, 460800)

_NUMBER = re.compile(rf"{DECIMAL}\Z")
_LINE = re.compile(r"\s*([A-Za-z]{4})(.*)\Z", re.S)


class TartuSyntaxError(ProtocolError):
    def __init__(self, code: int, text: str):
        self.code = code
        super().__init__(text)


@dataclass(frozen=True)
class Command:
    name: str                       # upper case, e.g. "GOAE"
    args: tuple                     # parsed values (floats, an int for BAUD, bool for ECHO)


def parse_number(text: str, what: str) -> float:
    t = text.strip()
    if not _NUMBER.match(t):
        raise TartuSyntaxError(E_SYNTAX, f"{what}: expected a number like 123.4, got {t!r}")
    v = float(t)
    if not math.isfinite(v):
        raise TartuSyntaxError(E_SYNTAX, f"{what}: number {t!r} out of range")
    return v


def _baud(text: str, what: str) -> int:
    t = text.strip()
    if not t.isdigit() or int(t) not in BAUD_RATES:
        raise TartuSyntaxError(E_SYNTAX, f"{what}: expected one of {', '.join(map(str, BAUD_RATES))}, got {t!r}")
    return int(t)


#: LCD contrast range: the URC's display (MIDAS MCCOG22005A6W, 20x2 COG on I2C) has a
#: 6-bit contrast setting in its controller, so LCDC takes 0..63 (the document gives no
#: range); 32 at power-on, mid-scale.
LCD_CONTRAST_MAX = 63
LCD_CONTRAST_DEFAULT = 32


def _contrast(text: str, what: str) -> int:
    t = text.strip()
    if not t.isdigit() or int(t) > LCD_CONTRAST_MAX:
        raise TartuSyntaxError(E_SYNTAX, f"{what}: expected a contrast 0..{LCD_CONTRAST_MAX}, got {t[:20]!r}")
    return int(t)


def _onoff(text: str, what: str) -> bool:
    t = text.strip().upper()
    if t in ("1", "ON"):
        return True
    if t in ("0", "OFF"):
        return False
    raise TartuSyntaxError(E_SYNTAX, f"{what}: expected ON, OFF, 1 or 0, got {text.strip()!r}")


_Conv = Callable[[str, str], object]

#: name -> (parameter converters, how many may be left out from the end, "usage: help")
COMMANDS: dict[str, tuple[tuple[_Conv, ...], int, str]] = {
    "VERS": ((), 0, "VERS: firmware version"),
    "HELP": ((), 0, "HELP: this list"),
    "BAUD": ((_baud,), 1, "BAUD [rate]: serial speed (changes after the reply; none on pty/TCP)"),
    "ECHO": ((_onoff,), 1, "ECHO [ON|OFF]: character echo for this connection"),
    "GOAZ": ((parse_number,), 0, "GOAZ az: go to azimuth"),
    "GOEL": ((parse_number,), 0, "GOEL el: go to elevation"),
    "GOAE": ((parse_number, parse_number), 0, "GOAE az,el: go to azimuth and elevation"),
    "RDAZ": ((), 0, "RDAZ: read azimuth"),
    "RDEL": ((), 0, "RDEL: read elevation"),
    "WRAZ": ((parse_number,), 0, "WRAZ az: set the present azimuth (re-reference, no motion)"),
    "WREL": ((parse_number,), 0, "WREL el: set the present elevation (re-reference, no motion)"),
    "RDAP": ((), 0, "RDAP: read the azimuth position pulse counter"),
    "RDEP": ((), 0, "RDEP: read the elevation position pulse counter"),
    "OVRA": ((parse_number,), 1, "OVRA [deg]: azimuth overshoot compensation (read or set)"),
    "OVRE": ((parse_number,), 1, "OVRE [deg]: elevation overshoot compensation (read or set)"),
    "HALT": ((), 0, "HALT: stop both axes"),
    "HLTA": ((), 0, "HLTA: stop azimuth"),
    "HLTE": ((), 0, "HLTE: stop elevation"),
    "LCDC": ((_contrast,), 1, "LCDC [0..63]: LCD contrast (read or set)"),
}

#: the turntable controller (TRC, the document's Figure 1): one axis, this subset
TRC_COMMANDS = ("VERS", "HELP", "BAUD", "ECHO", "GOAZ", "RDAZ", "WRAZ", "RDAP", "HALT", "OVRA")


def _unknown(shown: str) -> TartuSyntaxError:
    # brief: a flood of bad lines must not be answered with the command list each
    # (issue 13.1: 64 KiB of junk drew 3.4 MB of replies); HELP lists the commands
    return TartuSyntaxError(E_UNKNOWN, f"unknown command {shown[:20]!r}: expected a command (HELP lists them)")


def parse_line(raw: bytes, commands: tuple[str, ...] | None = None) -> Command:
    """One line (terminator removed) -> Command; raises TartuSyntaxError.
    ``commands``: the names this controller knows (default all; TRC_COMMANDS)."""
    text = raw.decode("latin-1")
    m = _LINE.match(text)
    shown = text.strip()[:40]
    if not m or m.group(1).upper() not in (COMMANDS if commands is None else commands):
        raise _unknown(shown)
    name = m.group(1).upper()
    convs, optional, _ = COMMANDS[name]
    rest = m.group(2)
    if rest and not rest[0].isspace() and not convs:
        raise _unknown(shown)
    rest = rest.strip()
    if rest.startswith(","):   # the document's form: the command, a comma, the parameters
        rest = rest[1:].strip()
    parts = [p for p in rest.split(",")] if rest else []
    if len(parts) > len(convs) or len(parts) < len(convs) - optional:
        want = f"{len(convs) - optional}" if optional == 0 else f"{len(convs) - optional}..{len(convs)}"
        raise TartuSyntaxError(E_SYNTAX, f"{name}: expected {want} parameter(s), got {len(parts)} ({rest!r})")
    args = tuple(conv(p, name) for conv, p in zip(convs, parts))
    return Command(name, args)


# ------------------------------------------------------------------- formatting
def format_opt_deg(v: float | None) -> str:
    return "---.-" if v is None else format_deg(v)


def ok() -> bytes:
    return line("OK")


def error(code: int, text: str) -> bytes:
    # one line whatever the text holds
    return line(f"ERR {code} " + text.replace("\r", " ").replace("\n", " "))


#: the turntable controller (TRC) has one motor: its own words where they differ
TRC_HELP = {"HALT": "HALT: emergency stop of the motor"}


def help_text(commands: tuple[str, ...] | None = None) -> bytes:
    rows = []
    for name, (_, _, h) in COMMANDS.items():
        if commands is None or name in commands:
            if commands == TRC_COMMANDS:
                h = TRC_HELP.get(name, h)
            usage, _, desc = h.partition(": ")
            rows.append(line(f"{usage:<14}{desc}"))
    return b"".join(rows)


LCD_WIDTH = 20


_MODE_STATE = {"driving": "RUN", "releasing": "REL", "holding": "HLD", "idle": "IDL"}


def axis_state(st, axis: str) -> str:
    """The state word an LCD row shows for one axis of a Status: FLT a fault latched,
    UNK position not known, else RUN/REL/HLD/IDL from the axis mode."""
    if any(f.axis in (None, axis) for f in st.faults):
        return "FLT"
    ax = st.az if axis == "az" else st.el
    if ax.uncertainty_deg > 0:
        return "UNK"
    return _MODE_STATE.get(ax.mode, ax.mode[:3].upper())


def lcd_line(axis_label: str, pos_deg: float | None, target_deg: float | None, state: str) -> str:
    """One 20-character LCD row: 'AZ 123.4>130.0  RUN'; 'AZ ---.-          UNK' while a
    procedure runs (None: the position is unknown)."""
    tgt = ">" + format_deg(target_deg) if target_deg is not None else ""
    body = f"{axis_label} {'---.-' if pos_deg is None else format_deg(pos_deg)}{tgt}"
    return body[:LCD_WIDTH - 4].ljust(LCD_WIDTH - 4) + " " + state[:3].rjust(3)


def lcd_rows(st) -> list[str]:
    """The controller's two LCD rows for a Status (LCDC, and the front panel's LCD):
    azimuth and elevation in the extended frame, each axis' setpoint and state."""
    single = st.el is None  # the TRC turntable: the azimuth row only, the other left blank
    st = wire_status(st)
    pos, tgt = shown_pose_deg(st), extended_targets_deg(st)
    # an axis in a procedure (homing) counts in a frame of its own: no number for it
    rows = [lcd_line(label, None, None, axis_state(st, axis)) if st.position_unknown(axis) else
            lcd_line(label, pos[i], tgt[i], axis_state(st, axis))
            for i, (label, axis) in enumerate((("AZ", "az"), ("EL", "el")))]
    return rows[:1] + [""] if single else rows
