"""Easycomm I/II/III device emulation: what Hamlib models 201, 202 and 204 talk to.

One line is one message (see :mod:`urc.wire.easycomm`). Set, move, stop, park and reset
commands get no reply at all: Hamlib reads none, and with no post-write delay a late
reply would be taken as the answer to its next query (protocols.md 2.3). Easycomm has
no error reply either, so bad lines and refused commands are logged and answered with
silence; Hamlib then reports a timeout for a query it sent.

Positions are reported as the sky direction (compass 0..360, elevation 0..90), which is
what Hamlib's Easycomm limits (az 0..360) and gpredict expect; values sent outside that
range (e.g. ``AZ400.0`` on a rotator with wrap) are passed to the rotator unchanged and
name a wrap or flip pose.
"""

from __future__ import annotations

from .. import __version__
from ..errors import CommandRejected, UrcError
from ..model.messages import ClearFaults, Goto, Move, Park, Request, Stop
from ..model.effects import Effects, as_effects
from ..model.snapshot import Status
from .base import RotatorPort, bad_input_log, internal_error, protocol_logger
from ..wire.easycomm import (COMMANDS_II, COMMANDS_III, Command, EasycommParseError, format_axis,
                             format_az_el, format_value, parse_line)
from .lines import LineSplitter
from .poses import require_known
from .single_axis import has_elevation, wire_el_axis, wire_el_deg

_JOG = {"ML": ("az", -1), "MR": ("az", 1), "MU": ("el", 1), "MD": ("el", -1),
        "VL": ("az", -1), "VR": ("az", 1), "VU": ("el", 1), "VD": ("el", -1)}
#: Easycomm III velocity: Hamlib sends (speed% - 1) * 100, i.e. 0..9900 for 1..100 %
#: (the standard says mdeg/s, but Hamlib, the client that matters, uses this scale).
VELOCITY_FULL_SCALE = 10000.0
#: the largest velocity on that scale (Hamlib writes %04d and clamps its stored speed to
#: 0..9999): more is not a speed urc understands, refused rather than run at full speed
VELOCITY_MAX = 9999.0
#: commands with no bearing on a rotator (radio frequencies, modes, AOS/LOS, time):
#: accepted so a full Easycomm line is not rejected for them, otherwise ignored.
_IGNORED = {"UP", "DN", "UM", "DM", "UR", "DR", "AO", "LO", "ST", "OP"}
# GS status register bits and GE error register bits (easycomm.txt, Easycomm III)
GS_IDLE, GS_MOVING, GS_POINTING, GS_ERROR = 1, 2, 4, 8
GE_SENSOR, GE_JAM, GE_HOMING = 1, 2, 4
_GE_BITS = {"sensor_stuck": GE_SENSOR, "sensor_jump": GE_SENSOR, "sensor_range": GE_SENSOR,
            "sensor_dead": GE_SENSOR, "stall": GE_JAM, "runaway": GE_JAM, "overcurrent": GE_JAM,
            "driver": GE_JAM,
            "limit_switch": GE_HOMING, "state": GE_HOMING}


def _silent(fn, *args):
    """An action that sends nothing back (sets, moves, stops: Hamlib reads no reply)."""
    def run() -> list[bytes]:
        fn(*args)
        return []
    return run


def _request(request: Request):
    """A rotator command that sends nothing back (Hamlib reads no reply)."""
    def run() -> Effects[list[bytes]]:
        yield request
        return []
    return run


class _EasycommSession:
    protocol = "easycomm"
    commands: frozenset[str] = COMMANDS_II
    #: Easycomm I has no feedback: nothing is ever sent back.
    replies = True

    def __init__(self, rotator: RotatorPort) -> None:
        self.rotator = rotator
        self.closed = False
        self._log = protocol_logger(self.protocol)
        self._bad = bad_input_log(self.protocol)
        self._lines = LineSplitter(log=self._bad)   # an overlong line: logged, no reply

    # ------------------------------------------------------------------ Session API
    def receive(self, data: bytes) -> Effects[list[bytes]]:
        out: list[bytes] = []
        for item in self._lines.feed(data):
            if item.overflowed:
                continue
            try:
                out += yield from self._line(item.text)
            except UrcError as exc:  # a hardware failure: Easycomm has no error reply
                self._log.warning("line %r failed: %s", item.text[:80], exc)
            except Exception:  # a bug: the connection survives, the bug is counted
                internal_error(self._log, self.protocol, "on line %r", item.text[:80])
        return out if self.replies else []

    def tick(self, now_s: float) -> list[bytes]:
        return []

    # ------------------------------------------------------------------ one line
    def _line(self, line: bytes) -> Effects[list[bytes]]:
        if not line.strip(b" \t;"):
            return []
        try:
            steps = self._plan(parse_line(line, self.commands))
        except EasycommParseError as exc:
            self._bad.warning("line %r ignored: %s", line[:80], exc)
            return []
        out: list[bytes] = []
        for step in steps:
            try:
                out += yield from as_effects(step())
            except CommandRejected as exc:
                self._bad.warning("line %r: refused (%s): %s", line[:80], exc.reason, exc)
        return out

    def _plan(self, cmds: list[Command]) -> list:
        """Turn a line's commands into actions, in order, after validating all of them.

        ``AZx ELy`` becomes one goto; a bare ``AZ`` and a bare ``EL`` on one line become
        one combined reply (Hamlib 4.5's ``AZ EL ``); ``SA SE`` one stop; each query is
        answered once per line.
        """
        steps: list = []
        target: dict[str, float] = {}
        queries: list[str] = []
        stops: set[str] = set()
        reads: set[tuple[str, object]] = set()
        for c in cmds:
            if c.name in ("AZ", "EL"):
                axis = c.name.lower()
                if c.value is None:
                    if not queries:
                        steps.append(lambda: self._position(queries))
                    if axis not in queries:
                        queries.append(axis)
                else:
                    if not target:
                        steps.append(lambda: self._goto(target))
                    target[axis] = float(c.value)
            elif c.name in ("SA", "SE"):
                if not stops:
                    steps.append(lambda: self._stop(stops))
                stops.add("az" if c.name == "SA" else "el")
            elif c.name in _JOG:
                axis, direction = _JOG[c.name]
                frac = 1.0
                if isinstance(c.value, float):  # VL/VR/VU/VD (parsed as a number)
                    if not 0 <= c.value <= VELOCITY_MAX:  # a value off Hamlib's scale: not understood
                        raise EasycommParseError(f"{c.name} with a velocity 0..{VELOCITY_MAX:.0f}",
                                                 str(c.value).encode())
                    frac = min(1.0, (c.value + 100.0) / VELOCITY_FULL_SCALE)
                steps.append(_request(Move(axis, direction, frac)))
            elif c.name == "PARK":
                steps.append(_request(Park()))
            elif c.name == "RESET":  # Hamlib's own: stop, then clear latched faults
                steps.append(_request(Stop()))
                steps.append(_request(ClearFaults()))
            elif c.name in ("VE", "GS", "GE", "CR", "IP", "AN"):
                if (c.name, c.value) not in reads:
                    reads.add((c.name, c.value))
                    steps.append(lambda c=c: self._read(c))
            elif c.name == "CW":
                steps.append(_silent(self._log.warning, "CW%s ignored: urc's settings are "
                                     "not writable over Easycomm", c.value))
            else:
                assert c.name in _IGNORED, c
                self._log.debug("%s ignored (no radio or I/O here)", c.name)
        return steps

    # ------------------------------------------------------------------ actions
    def _goto(self, target: dict[str, float]) -> Effects[list[bytes]]:
        if "az" not in target and not has_elevation(self.rotator):
            # ``EL45`` alone on a single-axis rotator: Easycomm answers no set, so there is
            # no error form to give; it is ignored and nothing moves. ``AZ100 EL45`` turns
            # the azimuth, the elevation left aside; ``EL`` reads 0.0 (wire_status).
            self._bad.info("EL set %s ignored: azimuth-only rotator", target.get("el"))
            return []
        s = self.rotator.status()
        az = target.get("az", self._hold("az", s))
        el = target.get("el", self._hold("el", s))
        yield Goto(az, el)
        return []

    @staticmethod
    def _hold(axis: str, s: Status) -> float:
        """Where the axis not named in a one-axis set should go: on to its target while
        moving, else stay. (Clamped: a noisy elevation reading of -0.05 at the bottom
        stop must not make ``AZ100`` illegal.)"""
        target = s.target_az_deg if axis == "az" else s.target_el_deg
        if s.moving and target is not None:
            return target
        if axis == "az":
            return s.az_deg
        if s.flipped:
            return wire_el_deg(s)
        el = wire_el_deg(s)
        off = el - wire_el_axis(s).pos_deg
        lo, hi = s.limits.get("el", (0.0, 90.0))
        return min(max(el, lo + off), min(hi + off, 90.0))

    def _stop(self, stops: set[str]) -> Effects[list[bytes]]:
        yield Stop(None if len(stops) == 2 else next(iter(stops)))
        return []

    def _position(self, queries: list[str]) -> list[bytes]:
        s = require_known(self.rotator.status())  # never cached: a query while moving says where it is now
        if len(queries) == 2:
            return [format_az_el(s.az_deg, wire_el_deg(s))]
        return [format_axis("AZ", s.az_deg) if queries[0] == "az" else format_axis("EL", wire_el_deg(s))]

    def _read(self, c: Command) -> list[bytes]:
        s = self.rotator.status()
        if c.name == "VE":
            return [format_value("VE", f"urc-{__version__}")]
        if c.name == "GS":
            bits = GS_ERROR if s.faults else 0
            if s.moving:
                bits |= GS_MOVING
            else:
                bits |= GS_IDLE
                if s.target_az_deg is not None and s.az.mode == wire_el_axis(s).mode == "holding":
                    bits |= GS_POINTING
            return [format_value("GS", str(bits))]
        if c.name == "GE":
            bits = 0 if s.position_known else GE_HOMING
            for f in s.faults:
                bits |= _GE_BITS.get(f.kind, 0)
            return [format_value("GE", str(bits))]
        if c.name == "CR" and c.value == "0":
            # register 0 = MaxSpeed, in mdeg/s; caps is not part of RotatorPort, so
            # only a rotator that has one answers
            caps = getattr(self.rotator, "caps", None)
            if caps is not None:
                rate = min(caps.az.max_rate_deg_per_s, caps.el.max_rate_deg_per_s)
                return [format_value("CR", f"0,{round(rate * 1000)}")]
        self._bad.warning("%s%s not supported here; no reply", c.name,
                          "" if c.value is None else f" {c.value}")
        return []


class Easycomm1Session(_EasycommSession):
    """Easycomm I (Hamlib 201): ``AZaaa.a ELeee.e UP... DN...`` lines, no replies ever."""

    protocol = "easycomm1"
    replies = False


class Easycomm2Session(_EasycommSession):
    """Easycomm II (Hamlib 202): two-letter commands; AZ/EL queries, VE; no GS/GE/CR."""

    protocol = "easycomm2"


class Easycomm3Session(_EasycommSession):
    """Easycomm III (Hamlib 204): II plus velocity moves and the GS/GE/CR/CW registers."""

    protocol = "easycomm3"
    commands = COMMANDS_III
