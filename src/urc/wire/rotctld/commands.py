"""The rotctld command table, Hamlib's return codes and the wire vocabularies.

Mirrors ``test_list[]`` in Hamlib's ``tests/rotctl_parse.c`` (4.6): which word starts a
command, how many argument words it reads, and whether a successful run prints values
(ARG_OUT: then default mode sends no ``RPRT 0``). Lookup tables are built once, here.
"""

from __future__ import annotations

from dataclasses import dataclass

# ---- Hamlib return codes (rig.h), sent negated after "RPRT " --------------------------
RIG_OK = 0
RIG_EINVAL = -1
RIG_ECONF = -2
RIG_ENIMPL = -4
RIG_ETIMEOUT = -5
RIG_EIO = -6
RIG_EINTERNAL = -7
RIG_EPROTO = -8
RIG_ERJCTED = -9
RIG_ENAVAIL = -11
RIG_ELIMIT = -21  # Hamlib 4.6+: set_pos out of range (4.5 says RIG_EINVAL)


@dataclass(frozen=True, slots=True)
class CommandSpec:
    code: int                 # short command byte, or Hamlib's private code (0x8f ...)
    name: str                 # long name, as echoed in extended mode
    n_args: int               # argument words read after the command
    outputs: bool = False     # ARG_OUT: success prints values and no "RPRT 0" (default mode)
    rest_of_line: bool = False  # `w`: the argument is the rest of the line (fgets)


#: every command rotctld 4.6 knows. Served for both versions: 4.5 lacks `3` and get_conf
#: (it read ``\get_conf min_az`` as junk), which no 4.5 client sends.
COMMANDS: tuple[CommandSpec, ...] = (
    CommandSpec(ord("P"), "set_pos", 2),
    CommandSpec(ord("p"), "get_pos", 0, outputs=True),
    CommandSpec(ord("K"), "park", 0),
    CommandSpec(ord("S"), "stop", 0),
    CommandSpec(ord("R"), "reset", 1),
    CommandSpec(ord("M"), "move", 2),
    CommandSpec(ord("V"), "set_level", 2),
    CommandSpec(ord("v"), "get_level", 1, outputs=True),
    CommandSpec(ord("U"), "set_func", 2),
    CommandSpec(ord("u"), "get_func", 1, outputs=True),
    CommandSpec(ord("X"), "set_parm", 2),
    CommandSpec(ord("x"), "get_parm", 1, outputs=True),
    CommandSpec(ord("C"), "set_conf", 2),
    CommandSpec(ord("_"), "get_info", 0, outputs=True),
    CommandSpec(ord("s"), "get_status", 0, outputs=True),
    CommandSpec(ord("w"), "send_cmd", 1, outputs=True, rest_of_line=True),
    CommandSpec(ord("1"), "dump_caps", 0),
    CommandSpec(ord("3"), "dump_conf", 0),
    CommandSpec(0x8F, "dump_state", 0, outputs=True),
    CommandSpec(ord("L"), "lonlat2loc", 3, outputs=True),
    CommandSpec(ord("l"), "loc2lonlat", 1, outputs=True),
    CommandSpec(ord("D"), "dms2dec", 4, outputs=True),
    CommandSpec(ord("d"), "dec2dms", 1, outputs=True),
    CommandSpec(ord("E"), "dmmm2dec", 3, outputs=True),
    CommandSpec(ord("e"), "dec2dmmm", 1, outputs=True),
    CommandSpec(ord("B"), "qrb", 4, outputs=True),
    CommandSpec(ord("A"), "a_sp2a_lp", 1, outputs=True),
    CommandSpec(ord("a"), "d_sp2d_lp", 1, outputs=True),
    CommandSpec(0x8C, "pause", 1),
    CommandSpec(0xAD, "get_conf", 1, outputs=True),
)

#: byte -> spec for one-character commands. Only printable ASCII: Hamlib would also run
#: raw bytes 0x8c/0x8f/0xad as pause/dump_state/get_conf, which no client relies on.
BY_CHAR: tuple[CommandSpec | None, ...] = tuple(
    next((c for c in COMMANDS if c.code == b and 0x20 < b < 0x7F), None) for b in range(256))
#: long name (after the backslash) -> spec
BY_NAME: dict[str, CommandSpec] = {c.name: c for c in COMMANDS}

# ---- move directions (rotator.h ROT_MOVE_*) -> (axis, sign) pairs ---------------------
_UP, _DOWN, _LEFT, _RIGHT = ("el", 1), ("el", -1), ("az", -1), ("az", 1)
MOVE_BASIC: dict[str, tuple[tuple[str, int], ...]] = {
    "2": (_UP,), "UP": (_UP,),
    "4": (_DOWN,), "DOWN": (_DOWN,),
    "8": (_LEFT,), "LEFT": (_LEFT,), "CCW": (_LEFT,),
    "16": (_RIGHT,), "RIGHT": (_RIGHT,), "CW": (_RIGHT,),
}
#: Hamlib 4.6+ diagonals
MOVE_DIAGONAL: dict[str, tuple[tuple[str, int], ...]] = {
    "32": (_UP, _LEFT), "UP_LEFT": (_UP, _LEFT), "UP_CCW": (_UP, _LEFT),
    "64": (_UP, _RIGHT), "UP_RIGHT": (_UP, _RIGHT), "UP_CW": (_UP, _RIGHT),
    "128": (_DOWN, _LEFT), "DOWN_LEFT": (_DOWN, _LEFT), "DOWN_CCW": (_DOWN, _LEFT),
    "256": (_DOWN, _RIGHT), "DOWN_RIGHT": (_DOWN, _RIGHT), "DOWN_CW": (_DOWN, _RIGHT),
}
MOVE_ALL = {**MOVE_BASIC, **MOVE_DIAGONAL}
#: ROT_SPEED_NOCHANGE: move at the SPEED level already set
SPEED_NO_CHANGE = -1
SPEED_MIN, SPEED_MAX = 1, 100

#: rot_status_t flag names in bit order (rot_sprintf_status prints them in this order).
STATUS_FLAGS = (
    "BUSY", "MOVING", "MOVING_AZ", "MOVING_LEFT", "MOVING_RIGHT", "MOVING_EL", "MOVING_UP",
    "MOVING_DOWN", "LIMIT_UP", "LIMIT_DOWN", "LIMIT_LEFT", "LIMIT_RIGHT", "OVERLAP_UP",
    "OVERLAP_DOWN", "OVERLAP_LEFT", "OVERLAP_RIGHT",
)

# ---- configuration tokens (rot_conf.c frontend params) --------------------------------
#: token -> (label, tooltip, Hamlib default text, numeric range or None for a checkbox)
CONF_TOKENS: dict[str, tuple[str, str, str, tuple[float, float] | None]] = {
    "min_az": ("Minimum azimuth", "Minimum rotator azimuth in degrees", "-180", (-360.0, 360.0)),
    "max_az": ("Maximum azimuth", "Maximum rotator azimuth in degrees", "180", (-360.0, 360.0)),
    "min_el": ("Minimum elevation", "Minimum rotator elevation in degrees", "0", (-90.0, 180.0)),
    "max_el": ("Maximum elevation", "Maximum rotator elevation in degrees", "90", (-90.0, 180.0)),
    "south_zero": ("South is zero deg", "Adjust azimuth 180 degrees for south oriented rotators",
                   "0", None),
}

#: levels this server has (rot_sprintf_level prints each name followed by a space)
LEVELS = ("SPEED",)
