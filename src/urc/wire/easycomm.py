"""Easycomm I/II/III wire format: pure parse and format functions, no state.

A message is one line (ended by ``\\n`` or ``\\r``) of space-separated tokens, each a
two-letter command with its value glued on (``AZ100.0``, ``VL4900``). Lines, not tokens,
are the unit because Hamlib 4.5 asks for the position with one line ``AZ EL `` and parses
one combined reply line, and because ``AZ100.0 EL20.0`` must become one goto, not two.

Both sides are here: the device side (what urc serves) and the host side (what Hamlib
sends and how it parses replies) for tests and for bridges that drive a real Easycomm
controller.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

from ..errors import ProtocolError


#: Easycomm II commands (``easycomm.txt``) plus Hamlib's own PARK and RESET.
COMMANDS_II = frozenset({
    "AZ", "EL", "UP", "DN", "UM", "DM", "UR", "DR", "ML", "MR", "MU", "MD", "SA", "SE",
    "AO", "LO", "OP", "IP", "AN", "ST", "VE", "PARK", "RESET",
})
#: Easycomm III adds velocity moves and the config/status/error registers.
COMMANDS_III = COMMANDS_II | {"VL", "VR", "VU", "VD", "CR", "CW", "GS", "GE"}

# value kinds: what may follow the command letters
_NUMBER_OPT = {"AZ", "EL"}                    # bare = query, number = set
_NUMBER_REQ = {"VL", "VR", "VU", "VD", "UR", "DR", "OP", "IP", "AN"}
_FREQ = {"UP", "DN"}                          # Hz; Easycomm I puts a mode word after it
_TEXT = {"UM", "DM", "ST", "CR", "CW"}        # free text (mode, time, register[,value])
_TEXT_REQ = {"CR", "CW"}
_BARE = {"ML", "MR", "MU", "MD", "SA", "SE", "AO", "LO", "VE", "GS", "GE", "PARK", "RESET"}

#: a decimal number as Easycomm writes it; no exponent, nan or inf can get through.
_NUMBER_RE = re.compile(rb"[+-]?(?:[0-9]{1,12}(?:\.[0-9]{0,6})?|\.[0-9]{1,6})")
_TOKEN_RE = re.compile(rb"(PARK|RESET|[A-Z]{2})(.*)", re.S)
_TEXT_RE = re.compile(rb"[\x21-\x7e]{1,32}")
_MODE_RE = re.compile(rb"[A-Z]{1,8}")
#: token separators: space, tab, and the ``;`` Hamlib leaves after its conf commands.
_SEP_RE = re.compile(rb"[ \t;]+")


class EasycommParseError(ProtocolError):
    """A line that is not valid Easycomm."""


@dataclass(frozen=True)
class Command:
    name: str                          # "AZ", "VL", "PARK" ...
    value: float | str | None = None   # number, text, or None for a bare command (query)


def parse_number(text: bytes) -> float:
    if not _NUMBER_RE.fullmatch(text):
        raise EasycommParseError("a decimal number", text)
    value = float(text)
    assert math.isfinite(value)
    return value


def _is_command(token: bytes, commands: frozenset[str]) -> bool:
    m = _TOKEN_RE.fullmatch(token)
    return m is not None and m.group(1).decode() in commands


def parse_line(line: bytes, commands: frozenset[str] = COMMANDS_III) -> list[Command]:
    """One line (without its terminator) -> its commands, in order.

    All or nothing: one bad token rejects the whole line, so nothing half-understood
    reaches the rotator. Letters may be lower case.
    """
    tokens = [t for t in _SEP_RE.split(line.upper()) if t]
    out: list[Command] = []
    i = 0
    while i < len(tokens):
        tok = tokens[i]
        i += 1
        m = _TOKEN_RE.fullmatch(tok)
        if m is None or m.group(1).decode() not in commands:
            raise EasycommParseError("an Easycomm command", tok)
        name, rest = m.group(1).decode(), m.group(2)
        nxt = tokens[i] if i < len(tokens) else None
        if name in _NUMBER_OPT or name in _NUMBER_REQ:
            # the value may also come as the next token: "AZ 100.0", "VL 4900"
            if not rest and nxt is not None and _NUMBER_RE.fullmatch(nxt):
                rest, i = nxt, i + 1
            if not rest:
                if name in _NUMBER_REQ:
                    raise EasycommParseError(f"{name} followed by a number", tok)
                out.append(Command(name))
            else:
                out.append(Command(name, parse_number(rest)))
        elif name in _FREQ:
            out.append(Command(name, parse_number(rest) if rest else None))
            # Easycomm I: "UP000 XXX": the word after a frequency is its mode
            if nxt is not None and _MODE_RE.fullmatch(nxt) and not _is_command(nxt, commands):
                i += 1
        elif name in _TEXT:
            # "CR 1": Hamlib separates the register from the command with a space
            if not rest and name in _TEXT_REQ and nxt is not None and not _is_command(nxt, commands):
                rest, i = nxt, i + 1
            if not rest:
                if name in _TEXT_REQ:
                    raise EasycommParseError(f"{name} followed by a value", tok)
                out.append(Command(name))
            elif not _TEXT_RE.fullmatch(rest):
                raise EasycommParseError(f"{name} followed by printable text", tok)
            else:
                out.append(Command(name, rest.decode("ascii")))
        else:
            assert name in _BARE
            if rest:
                raise EasycommParseError(f"{name} alone", tok)
            out.append(Command(name))
    return out


# ---------------------------------------------------------------- device replies
def _deg(value_deg: float) -> str:
    text = f"{value_deg:.1f}"
    return "0.0" if text == "-0.0" else text


def format_az_el(az_deg: float, el_deg: float) -> bytes:
    """Reply to Hamlib 4.5's combined ``AZ EL `` query (parsed as ``AZ%f EL%f``)."""
    return f"AZ{_deg(az_deg)} EL{_deg(el_deg)}\n".encode()


def format_axis(name: str, value_deg: float) -> bytes:
    """Reply to a bare ``AZ`` or ``EL`` (Hamlib 4.6+ parses ``AZ%f`` / ``EL%f``)."""
    return f"{name}{_deg(value_deg)}\n".encode()


def format_value(name: str, value: str) -> bytes:
    """Echo-plus-value reply (``VEurc-0.1.0``, ``GS1``, ``CR0,6000``). Hamlib keeps what
    follows the first two characters and reads at most 31 characters."""
    return (name + value)[:30].encode("ascii", "replace") + b"\n"


# ---------------------------------------------------------------- host side (Hamlib)
def format_set_position(az_deg: float, el_deg: float) -> bytes:
    """What Hamlib models 202/204 send for set_position."""
    return f"AZ{az_deg:.1f} EL{el_deg:.1f}\n".encode()


_REPLY_AZ_EL_RE = re.compile(rb"AZ\s*([+-]?[0-9.]+)\s*EL\s*([+-]?[0-9.]+)")
_REPLY_AXIS_RE = re.compile(rb"(AZ|EL)\s*([+-]?[0-9.]+)")


def parse_az_el_reply(line: bytes) -> tuple[float, float]:
    """Hamlib 4.5's ``sscanf(reply, "AZ%f EL%f")``: both fields required."""
    m = _REPLY_AZ_EL_RE.match(line)
    if m is None:
        raise EasycommParseError("AZ<az> EL<el>", line)
    return float(m.group(1)), float(m.group(2))


def parse_axis_reply(line: bytes, name: str) -> float:
    """Hamlib 4.6's ``sscanf(reply, "AZ%f")`` (or ``EL%f``)."""
    m = _REPLY_AXIS_RE.match(line)
    if m is None or m.group(1).decode() != name:
        raise EasycommParseError(f"{name}<value>", line)
    return float(m.group(2))


def format_position_query() -> bytes:
    """Hamlib 4.5's combined query, answered with one ``AZx EL y`` line."""
    return b"AZ EL \n"


def format_stop() -> bytes:
    """Stop both axes (SA, SE)."""
    return b"SA SE\n"


_MOVE_NAMES = {("az", -1): "L", ("az", 1): "R", ("el", 1): "U", ("el", -1): "D"}


def format_move(axis: str, direction: int, speed_frac: float | None = None) -> bytes:
    """A jog: Easycomm II ``ML``/``MR``/``MU``/``MD`` (the controller's speed), or with a
    speed Easycomm III ``VL``..``VD`` in Hamlib's scale (speed s% -> (s - 1) x 100)."""
    name = _MOVE_NAMES[(axis, 1 if direction > 0 else -1)]
    if speed_frac is None:
        return b"M%s\n" % name.encode()
    speed_pct = min(max(round(speed_frac * 100.0), 1), 100)
    return b"V%s%04d\n" % (name.encode(), (speed_pct - 1) * 100)


def format_version_query() -> bytes:
    return b"VE\n"


def parse_value_reply(line: bytes, name: str) -> str:
    """An echo-plus-value reply (``VEk3ng 2024``) -> the value."""
    text = line.strip(b"\r\n \t")
    if not text.upper().startswith(name.encode()):
        raise EasycommParseError(f"{name}<value>", line)
    return text[len(name):].decode("ascii", "replace").strip()
