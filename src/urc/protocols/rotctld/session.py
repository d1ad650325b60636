"""One rotctld (Hamlib NET rotctl) client connection, sans-I/O.

Bytes go through :class:`~.lexer.Lexer` into commands; each command runs against the
rotator and yields one complete reply (rotctld flushes once per command, and gpredict
relies on a whole ``p`` reply arriving in one segment).

Frames: positions are reported and accepted in the frame of ``status()``: sky azimuth
0..360, plus, for ``P``, the rotator's extended range ``min_az..max_az`` (its mechanical
limits plus the mount offsets, as ``\\dump_state`` advertises), where values outside
0..360 name a cable-wrap pose. Azimuths -180..0 outside that range (gpredict's
-180..180 mode) are compass azimuths and get +360.
"""

from __future__ import annotations

from typing import Callable

from ...model.messages import ClearFaults, Goto, Move, Park, Stop
from ...model.effects import Effects

from ... import __version__
from ...errors import CommandRejected, ConfigError, HardwareError
from ..base import MAX_PENDING_BYTES, RotatorPort, bad_input_log, internal_error, protocol_logger
from ..poses import readback_pose_deg
from ..single_axis import has_elevation
from ...wire.rotctld import codec
from ...wire.rotctld.commands import (
    CONF_TOKENS, LEVELS, RIG_EINTERNAL, RIG_EINVAL, RIG_EIO, RIG_ELIMIT, RIG_ENAVAIL, RIG_ERJCTED,
    SPEED_MAX, SPEED_MIN, SPEED_NO_CHANGE, CommandSpec,
)
from .flags import status_flags
from .lexer import CLOSE, CMD, OVERFLOW, UNKNOWN, Lexer

log = protocol_logger("rotctld")
#: bad input from clients, logged at a bounded rate (shared by all connections)
bad_input = bad_input_log("rotctld")

HAMLIB_VERSIONS = ("4.5", "4.6")
#: Hamlib's rotctld reports the backend's model; urc has none, so it answers as the
#: dummy (1) does. netrotctl reads and ignores it.
MODEL = 1
#: Hamlib's defaults when a rotator reports no limits
_DEFAULT_LIMITS = {"az": (-180.0, 180.0), "el": (0.0, 90.0)}
_LEVEL_LIST = "".join(name + " " for name in LEVELS) + "\n"
_LEVEL_GRAN = f"SPEED({SPEED_MIN}..{SPEED_MAX}/1) "

Result = tuple[int, str]


class RotctldSession:
    """rotctld protocol for one client.

    Options (keyword-only):

    * ``hamlib_version``: ``"4.5"`` (default) or ``"4.6"``, the rotctld to imitate where
      they differ on the wire: the code for a position out of range (``RPRT -1`` vs
      ``RPRT -21``), the diagonal ``M`` directions (4.6+), and ``C ?`` (4.5: ``RPRT -1``).
    """

    def __init__(self, rotator: RotatorPort, *, hamlib_version: str = "4.5"):
        version = str(hamlib_version)
        if version not in HAMLIB_VERSIONS:
            raise ConfigError(f"rotctld: hamlib_version must be one of {', '.join(HAMLIB_VERSIONS)}, "
                              f"found {hamlib_version!r}", key="options.hamlib_version",
                              expected=" | ".join(HAMLIB_VERSIONS), found=hamlib_version)
        self.rotator = rotator
        self.hamlib_version = version
        self._v46 = version != "4.5"
        self._limit_code = RIG_ELIMIT if self._v46 else RIG_EINVAL
        #: the SPEED level (1..100): the speed of ``M <dir> -1``
        self.speed = SPEED_MAX
        self.closed = False
        self._lexer = Lexer(MAX_PENDING_BYTES)

    # ------------------------------------------------------------------ Session API
    def receive(self, data: bytes) -> Effects[list[bytes]]:
        if self.closed or not data:
            return []
        if type(data) is not bytes:  # bytearray / memoryview from an adapter
            data = bytes(data)
        try:
            items = self._lexer.feed(data)
        except Exception:  # a tokenizer bug must not kill the connection
            internal_error(log, "rotctld", "tokenizer failed; input dropped")
            self._lexer.reset()
            return []
        out = []
        for kind, spec, args, sep in items:
            if kind == CMD and spec is not None:
                out.append((yield from self._run(spec, args, sep)))
            elif kind == CLOSE:
                self.closed = True
                break
            elif kind == UNKNOWN and len(args) == 1:
                bad_input.info("rotctld: long command %r not found, ignored (rotctld sends nothing)",
                               args[0])
            elif kind == UNKNOWN:   # a run of unknown one-character commands
                bad_input.info("rotctld: command %r not found, ignored (rotctld sends nothing)",
                               args[0], count=args[1])
            elif kind == OVERFLOW:
                bad_input.warning("rotctld: more than %d bytes of one unfinished command (%s); dropped",
                                  MAX_PENDING_BYTES, spec.name if spec else "long name")
                if spec is not None:  # its client waits for an answer
                    out.append(codec.frame_reply(spec, (), sep, RIG_EINVAL, ""))
        return out

    def tick(self, now_s: float) -> list[bytes]:
        return []

    # ----------------------------------------------------------------- dispatch
    def _run(self, spec: CommandSpec, args: tuple[str, ...], sep: str | None) -> Effects[bytes]:
        try:
            acts = _ACTS.get(spec.code)
            if acts is not None:  # (a command: its port requests yielded)
                code, data = yield from acts(self, args, sep)
            else:  # (a query: answered from the status)
                code, data = _HANDLERS[spec.code](self, args, sep)
        except CommandRejected as exc:
            code, data = self._rejected_code(exc), ""
            bad_input.info("rotctld: %s %s refused: %s", spec.name, " ".join(args), exc)
        except HardwareError as exc:
            code, data = RIG_EIO, ""
            log.warning("rotctld: %s failed: %s", spec.name, exc)
        except Exception:  # a bug: answered as Hamlib's internal error, logged and counted
            code, data = RIG_EINTERNAL, ""
            internal_error(log, "rotctld", "%s %s failed", spec.name, " ".join(args))
        return codec.frame_reply(spec, args, sep, code, data)

    def _rejected_code(self, exc: CommandRejected) -> int:
        if exc.reason in ("limit", "keepout"):
            return self._limit_code
        if exc.reason in ("fault", "uncertain", "local", "state"):
            return RIG_ERJCTED
        return RIG_EINVAL

    def frame_limits(self) -> tuple[float, float, float, float]:
        """(min_az, max_az, min_el, max_el) in the frame of status() and P."""
        status = self.rotator.status()
        limits = status.limits or _DEFAULT_LIMITS
        az_lo, az_hi = limits.get("az", _DEFAULT_LIMITS["az"])
        el_lo, el_hi = limits.get("el", _DEFAULT_LIMITS["el"])
        az_off, el_off = status.offsets.get("az", 0.0), status.offsets.get("el", 0.0)
        return az_lo + az_off, az_hi + az_off, el_lo + el_off, el_hi + el_off

    def _conf_values(self) -> dict[str, float]:
        min_az, max_az, min_el, max_el = self.frame_limits()
        return {"min_az": min_az, "max_az": max_az, "min_el": min_el, "max_el": max_el,
                "south_zero": 0}

    # ------------------------------------------------------------------ motion
    def _set_pos(self, args: tuple[str, ...], sep: str | None) -> Effects[Result]:
        pos = codec.parse_position(*args) if len(args) == 2 else None
        if pos is None:
            bad_input.info("rotctld: set_pos needs two finite numbers, got %r", args)
            return RIG_EINVAL, ""
        az, el = pos
        min_az, max_az, min_el, max_el = self.frame_limits()
        az_ok = min_az <= az <= max_az  # passed on unchanged: beyond 0..360 names a wrap pose
        if not az_ok:
            if -180.0 <= az < 0.0:
                az += 360.0  # -180..180 clients: west is negative
            # a compass azimuth outside the range (mount offsets): the rotator picks the
            # wrap, or refuses
            az_ok = 0.0 <= az < 360.0
        if not (az_ok and min_el <= el <= max_el):
            bad_input.info("rotctld: set_pos %s %s outside az %g..%g, el %g..%g",
                     args[0], args[1], min_az, max_az, min_el, max_el)
            return self._limit_code, ""
        yield Goto(az, el)
        return 0, ""

    def _get_pos(self, args: tuple[str, ...], sep: str | None) -> Result:
        # flipped: the pose as a client commands it (poses.readback_pose_deg, README)
        return 0, codec.format_position(*readback_pose_deg(self.rotator.status()), sep)

    def _park(self, args: tuple[str, ...], sep: str | None) -> Effects[Result]:
        yield Park()
        return 0, ""

    def _stop(self, args: tuple[str, ...], sep: str | None) -> Effects[Result]:
        yield Stop()
        return 0, ""

    def _reset(self, args: tuple[str, ...], sep: str | None) -> Effects[Result]:
        # any integer, as rotctld passes it on; ROT_RESET_ALL (1) is the one defined
        if codec.parse_int(args[0]) is None:
            return RIG_EINVAL, ""
        yield Stop()
        yield ClearFaults()
        return 0, ""

    def _move(self, args: tuple[str, ...], sep: str | None) -> Effects[Result]:
        moves = codec.parse_direction(args[0], self._v46) if len(args) == 2 else None
        speed = codec.parse_int(args[1]) if len(args) == 2 else None
        if speed == SPEED_NO_CHANGE:
            speed = self.speed
        if moves is None or speed is None or not SPEED_MIN <= speed <= SPEED_MAX:
            bad_input.info("rotctld: move needs a direction and a speed 1..100 or -1, got %r", args)
            return RIG_EINVAL, ""
        started: list[str] = []
        # UP/DOWN on an azimuth-only rotator: refused by the service (reason no_axis) ->
        # RPRT -1 (EINVAL), the same answer as P with an elevation outside min_el..max_el
        # (0..0); nothing moves (urc's choice: Hamlib has no rule for M on such a rotator)
        try:
            for axis, direction in moves:
                yield Move(axis, direction, speed / 100.0)
                started.append(axis)
        except CommandRejected:
            for axis in started:  # a diagonal moves both axes or neither
                yield Stop(axis)
            raise
        return 0, ""

    # ---------------------------------------------------------------- levels etc.
    def _set_level(self, args: tuple[str, ...], sep: str | None) -> Result:
        if args[0] == "?":
            return 0, _LEVEL_LIST
        if args[0] != "SPEED":
            return RIG_ENAVAIL, ""
        value = codec.parse_int(args[1]) if len(args) == 2 else None
        if value is None or not SPEED_MIN <= value <= SPEED_MAX:
            return RIG_EINVAL, ""
        self.speed = value
        return 0, ""

    def _get_level(self, args: tuple[str, ...], sep: str | None) -> Result:
        if args[0] == "?":
            return 0, _LEVEL_LIST
        if args[0] != "SPEED":
            return RIG_EINVAL, ""
        return 0, "%d\n" % self.speed

    def _func_parm_list(self, args: tuple[str, ...], sep: str | None) -> Result:
        """U/u/X/x: this rotator has no functions or parameters; ``?`` lists none."""
        return (0, "\n") if args[0] == "?" else (RIG_EINVAL, "")

    def _set_func(self, args: tuple[str, ...], sep: str | None) -> Result:
        return (0, "\n") if args[0] == "?" else (RIG_ENAVAIL, "")

    def _get_info(self, args: tuple[str, ...], sep: str | None) -> Result:
        info = f"urc {self.rotator.status().profile}"
        return 0, (info + "\n") if sep is None else f"Info: {info}{sep}"

    def _get_status(self, args: tuple[str, ...], sep: str | None) -> Result:
        status = self.rotator.status()
        text = codec.format_flags(status_flags(status, status.offsets.get("az", 0.0)))
        return 0, (text + "\n") if sep is None else f"Status flags: {text}{sep}"

    # ----------------------------------------------------------------- configuration
    def _set_conf(self, args: tuple[str, ...], sep: str | None) -> Result:
        token = args[0]
        if token.startswith("?"):
            # 4.5 reads no value after '?' and fails; 4.6 lists the tokens
            return (0, codec.format_conf_list(self._conf_values())) if self._v46 else (RIG_EINVAL, "")
        if token not in CONF_TOKENS or len(args) < 2:
            return RIG_EINVAL, ""
        value = codec.parse_float(args[1])
        if value is None:
            return RIG_EINVAL, ""
        if abs(value - self._conf_values()[token]) < 5e-7:
            return 0, ""  # already so
        # Limits and the azimuth frame belong to the rotator (its configuration),
        # enforced once for every protocol; a client may not change them.
        bad_input.info("rotctld: set_conf %s %s refused: set in the rotator's configuration", token, args[1])
        return RIG_ENAVAIL, ""

    def _get_conf(self, args: tuple[str, ...], sep: str | None) -> Result:
        token = args[0]
        values = self._conf_values()
        if token.startswith("?"):
            return 0, codec.format_conf_list(values)
        if token not in CONF_TOKENS:
            return RIG_EINVAL, ""
        return 0, f"{token}={codec.format_conf_value(token, values[token])}\n"

    def _dump_conf(self, args: tuple[str, ...], sep: str | None) -> Result:
        return 0, codec.format_conf_list(self._conf_values())

    def _dump_state(self, args: tuple[str, ...], sep: str | None) -> Result:
        # an azimuth-only rotator: min_el = max_el = 0 and rot_type=Az, as Hamlib's own
        # azimuth-only backends (GS-232A azimuth, Rot1Prog) report them
        rot_type = "AzEl" if has_elevation(self.rotator) else "Az"
        return 0, codec.format_dump_state(MODEL, self.frame_limits(), 0, rot_type, sep)

    def _dump_caps(self, args: tuple[str, ...], sep: str | None) -> Result:
        return 0, codec.format_dump_caps(model=MODEL, model_name=f"urc {self.rotator.status().profile}",
                                         version=__version__, limits=self.frame_limits(),
                                         levels=_LEVEL_GRAN)

    def _not_available(self, args: tuple[str, ...], sep: str | None) -> Result:
        """send_cmd, pause and the locator helpers: not offered (their arguments are
        still read, so the stream stays in step)."""
        return RIG_ENAVAIL, ""


_Handler = Callable[[RotctldSession, tuple, "str | None"], Result]
#: command code -> the handler of a command that acts on the rotator (yields requests)
_ACTS: dict[int, Callable[[RotctldSession, tuple, "str | None"], Effects[Result]]] = {
    ord("P"): RotctldSession._set_pos,
    ord("K"): RotctldSession._park,
    ord("S"): RotctldSession._stop,
    ord("R"): RotctldSession._reset,
    ord("M"): RotctldSession._move,
}
#: command code -> handler, built once
_HANDLERS: dict[int, _Handler] = {
    ord("p"): RotctldSession._get_pos,
    ord("V"): RotctldSession._set_level,
    ord("v"): RotctldSession._get_level,
    ord("U"): RotctldSession._set_func,
    ord("u"): RotctldSession._func_parm_list,
    ord("X"): RotctldSession._func_parm_list,
    ord("x"): RotctldSession._func_parm_list,
    ord("C"): RotctldSession._set_conf,
    ord("_"): RotctldSession._get_info,
    ord("s"): RotctldSession._get_status,
    ord("1"): RotctldSession._dump_caps,
    ord("3"): RotctldSession._dump_conf,
    0x8F: RotctldSession._dump_state,
    0xAD: RotctldSession._get_conf,
}
for _spec_code in (ord(c) for c in "wLlDdEeBAa"):
    _HANDLERS[_spec_code] = RotctldSession._not_available
_HANDLERS[0x8C] = RotctldSession._not_available
