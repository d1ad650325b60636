"""Pure rotctld value codecs: argument words -> values, values -> reply text.

Both ends use it: urc's rotctld server (:mod:`urc.protocols.rotctld`) and the bridge's
NET rotctl client (:mod:`urc.hardware.bridge.dialects`). Which status flags a snapshot
shows is the server's (:mod:`urc.protocols.rotctld.flags`); their wire text is here.

Numbers are read strictly: rotctld's ``sscanf("%f")`` would take ``10abc`` as 10 and
``nan``/``inf`` as numbers; here a word is a number only if all of it is one, and
positions must be finite, so nothing half-understood reaches the rotator.
"""

from __future__ import annotations

import math
import re
from typing import Iterable

from .commands import CONF_TOKENS, MOVE_ALL, MOVE_BASIC, STATUS_FLAGS, CommandSpec

_FLOAT = re.compile(r"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")
_INT = re.compile(r"[+-]?[0-9]{1,10}")
_INT_MAX = 2**31 - 1


# ---------------------------------------------------------------- arguments -> values
def parse_float(word: str) -> float | None:
    """A finite decimal number (``+10``, ``10.``, ``.5``, ``1e1``), else None."""
    if _FLOAT.fullmatch(word) is None:
        return None
    value = float(word)
    return value if math.isfinite(value) else None


def parse_int(word: str) -> int | None:
    """A C ``int`` written in decimal, else None."""
    if _INT.fullmatch(word) is None:
        return None
    value = int(word)
    return value if -_INT_MAX - 1 <= value <= _INT_MAX else None


def decimal_comma(word: str) -> str:
    """rotctld's set_pos fix for comma locales: the first ``,`` becomes ``.``."""
    return word.replace(",", ".", 1)


def parse_position(az_word: str, el_word: str) -> tuple[float, float] | None:
    """``P`` arguments (decimal comma allowed) -> (az_deg, el_deg), or None."""
    az = parse_float(decimal_comma(az_word))
    el = parse_float(decimal_comma(el_word))
    if az is None or el is None:
        return None
    return az, el


def parse_direction(word: str, diagonals: bool) -> tuple[tuple[str, int], ...] | None:
    """``M`` direction (number or name) -> ((axis, ±1), ...), or None."""
    table = MOVE_ALL if diagonals else MOVE_BASIC
    moves = table.get(word)
    if moves is None and _INT.fullmatch(word):  # "+2", "002"
        moves = table.get(str(int(word)))
    return moves


# ------------------------------------------------------------------ values -> text
def format_position(az_deg: float, el_deg: float, sep: str | None) -> str:
    """``p``: ``%.2f`` each, labelled in extended mode."""
    if sep is None:
        return "%.2f\n%.2f\n" % (az_deg, el_deg)
    return "Azimuth: %.2f%sElevation: %.2f%s" % (az_deg, sep, el_deg, sep)


def format_flags(flags: Iterable[str]) -> str:
    """rot_sprintf_status: names in bit order, each followed by a space."""
    present = set(flags)
    return "".join(name + " " for name in STATUS_FLAGS if name in present)


def format_dump_state(model: int, limits: tuple[float, float, float, float], south_zero: int,
                      rot_type: str, sep: str | None) -> str:
    """``\\dump_state``, protocol version 1 (what rotctld 4.5 .. master send)."""
    min_az, max_az, min_el, max_el = limits
    if sep is None:
        return (f"1\n{model}\nmin_az={min_az:f}\nmax_az={max_az:f}\nmin_el={min_el:f}\n"
                f"max_el={max_el:f}\nsouth_zero={south_zero:d}\nrot_type={rot_type}\ndone\n")
    s = sep
    return (f"rotctld Protocol Ver: 1{s}Rotor Model: {model}{s}Minimum Azimuth: {min_az:f}{s}"
            f"Maximum Azimuth: {max_az:f}{s}Minimum Elevation: {min_el:f}{s}"
            f"Maximum Elevation: {max_el:f}{s}South Zero: {south_zero:d}{s}"
            f"rot_type={rot_type}{s}done{s}")


def format_conf_value(token: str, value: float) -> str:
    """rot_get_conf: limits as ``%f``, south_zero as ``%d``."""
    return "%d" % value if CONF_TOKENS[token][3] is None else "%f" % value


def format_conf_list(values: dict[str, float]) -> str:
    """print_conf_list for the tokens this server knows (``C ?``, ``3``)."""
    out = []
    for token, (_label, tip, default, rng) in CONF_TOKENS.items():
        out.append(f'{token}: "{tip}"\n\tDefault: {default}, Value: '
                   f"{format_conf_value(token, values[token])}\n")
        if rng is None:
            out.append("\tCheckbox: 0,1\n")
        else:
            out.append(f"\tRange: {rng[0]:.1f}..{rng[1]:.1f}, step 0.0\n")
    return "".join(out)


def format_dump_caps(*, model: int, model_name: str, version: str,
                     limits: tuple[float, float, float, float], levels: str) -> str:
    """``1``: dumpcaps_rot()'s human-readable layout. No client parses it."""
    min_az, max_az, min_el, max_el = limits
    flags = format_flags(f for f in STATUS_FLAGS if f not in ("OVERLAP_UP", "OVERLAP_DOWN"))
    return (
        f"Caps dump for model:\t{model}\nModel name:\t\t{model_name}\nMfg name:\t\turc\n"
        f"Backend version:\t{version}\nBackend copyright:\tMIT\nBackend status:\t\tStable\n"
        "Rot type:\t\tAz-El\nPort type:\t\tNone\n"
        "Write delay:\t\t0ms, timeout 0ms, 0 retries\nPost write delay:\t0ms\n"
        f"Status flags: {flags}\nGet functions: \nSet functions: \nExtra functions:\n"
        f"Get level: {levels}\nSet level: {levels}\nExtra levels:\n"
        "Get parameters: \nSet parameters: \nExtra parameters:\n"
        f"Min Azimuth:\t\t{min_az:.2f}\nMax Azimuth:\t\t{max_az:.2f}\n"
        f"Min Elevation:\t\t{min_el:.2f}\nMax Elevation:\t\t{max_el:.2f}\n"
        "Has priv data:\t\tN\nHas Init:\t\tY\nHas Cleanup:\t\tY\nHas Open:\t\tY\n"
        f"Has Close:\t\tY\nCan set Conf:\t\tY\nCan get Conf:\t\tY\n"
        "Can set Position:\tY\nCan get Position:\tY\nCan Stop:\t\tY\nCan Park:\t\tY\n"
        "Can Reset:\t\tY\nCan Move:\t\tY\nCan get Info:\t\tY\nCan get Status:\t\tY\n"
        "Can set Func:\tN\nCan get Func:\tN\nCan set Level:\tY\nCan get Level:\tY\n"
        "Can set Param:\tN\nCan get Param:\tN\n\nOverall backend warnings: 0\n")


def frame_reply(spec: CommandSpec, args: tuple[str, ...], sep: str | None, code: int,
                data: str) -> bytes:
    """The whole reply to one command, as rotctld prints it (section 1.3 rules).

    Default mode: an error is ``RPRT n``; success is the values for commands with
    outputs, else whatever they printed followed by ``RPRT 0``. Extended mode: the
    ``name: args`` header, the values on success, and ``RPRT n`` always.
    """
    if sep is None:
        if code:
            return b"RPRT %d\n" % code
        if spec.outputs:
            return data.encode("latin-1", "replace")
        return (data + "RPRT 0\n").encode("latin-1", "replace") if data else b"RPRT 0\n"
    header = spec.name + ":" + "".join(" " + a for a in args) + sep
    body = data if code == 0 else ""
    return (header + body + "RPRT %d\n" % code).encode("latin-1", "replace")


# ------------------------------------------------- host side (what a client sends)
def format_set_pos_request(az_deg: float, el_deg: float) -> bytes:
    """``P``, as Hamlib's NET rotctl backend (model 2) writes it."""
    return b"P %.2f %.2f\n" % (az_deg, el_deg)


def format_move_request(axis: str, direction: int, speed_frac: float) -> bytes:
    """``M <direction> <speed>`` with Hamlib's numeric direction (``M %d %d``)."""
    code = next(int(k) for k, v in MOVE_BASIC.items() if k.isdigit() and v == ((axis, 1 if direction > 0 else -1),))
    return b"M %d %d\n" % (code, min(max(round(speed_frac * 100.0), 1), 100))


def parse_rprt(line: bytes) -> int | None:
    """``RPRT n`` -> n; None for any other line."""
    m = re.fullmatch(rb"RPRT (-?[0-9]{1,4})\s*", line)
    return None if m is None else int(m.group(1))


def parse_get_pos_reply(lines: list[bytes]) -> tuple[float, float]:
    """The two value lines ``p`` answers with -> (az_deg, el_deg); ValueError if they
    are not two finite numbers (an ``RPRT -n`` line is an error the caller reports)."""
    if len(lines) != 2:
        raise ValueError(f"expected two lines az, el; got {lines!r}")
    az, el = (parse_float(line.strip().decode("ascii", "replace")) for line in lines)
    if az is None or el is None:
        raise ValueError(f"expected two numbers az, el; got {lines!r}")
    return az, el
