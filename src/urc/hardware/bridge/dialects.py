"""What the bridge says to each kind of controller, built on the wire codecs.

One codec serves both ends (as pymodbus does with its framers): urc's protocol servers
use the device side of :mod:`urc.wire.gs232`, ``.easycomm``, ``.spid`` and
``.rotctld``; a dialect here uses their host side to drive a real controller. A dialect
only builds :class:`Exchange` values (bytes to send, how the answer is framed, how it is
parsed); the client engine (:mod:`.client`) decides when.

Timing follows Hamlib's backends for the same controllers (protocols.md section 6).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable

from ...wire import easycomm as ec
from ...wire import gs232 as gs
from ...wire import satnogs as sn
from ...wire import spid
from ...wire.rotctld import codec as rc

#: the protocols a bridge can drive (``[hardware.bridge] protocol``)
BRIDGE_PROTOCOLS = ("gs232a", "gs232b", "easycomm2", "easycomm3", "rot2prog", "rot1prog", "md01", "rotctld",
                    "satnogs")


class ReplyError(ValueError):
    """A reply that is not what the protocol answers: never acted on."""


@dataclass(frozen=True)
class Reply:
    """How an answer is framed: ``length`` bytes, or ``lines`` lines ending in
    ``terminator``. ``stop_line`` (rotctld): a line starting with it ends the reply early
    (``RPRT -n`` instead of values)."""

    length: int = 0
    terminator: bytes = b"\n"
    lines: int = 1
    stop_line: bytes | None = None

    def complete(self, buf: bytes) -> int | None:
        """How many bytes of ``buf`` make the whole reply, or None while incomplete."""
        if self.length:
            return self.length if len(buf) >= self.length else None
        end = 0
        for _ in range(self.lines):
            i = buf.find(self.terminator, end)
            if i < 0:
                return None
            line = buf[end:i]
            end = i + len(self.terminator)
            if self.stop_line is not None and line.startswith(self.stop_line):
                return end
        return end


@dataclass(frozen=True)
class Exchange:
    kind: str                                   # poll | set | stop | move | identify | status | error | home
    request: bytes
    reply: Reply | None = None                  # None: the controller answers nothing
    parse: Callable[[bytes], Any] | None = None
    #: quiet time after the write before the next one (the controller's post-write delay)
    settle_s: float = 0.0
    #: discard unread input first (a late echo or ack must not be read as this answer)
    flush_before: bool = True
    #: the pose a set asks for (az, el)
    pose: tuple[float, float] | None = None


class Dialect:
    name = ""
    default_baud = 9600
    #: Hamlib's read timeout for this controller
    timeout_s = 0.4
    #: the controller reports azimuth modulo 360 (sky az): continuity picks the wrap turn
    az_modulo_deg: float | None = None
    #: it has an elevation axis
    has_el = True
    #: its own move must start from rest (a stop first), and a move it runs is ended by
    #: a stop before urc's goto takes over (SPID MD-01/02)
    stop_around_move = False

    def __init__(self) -> None:
        #: the smallest step a set can express, per axis
        self.resolution_deg = (1.0, 1.0)
        #: the step of a position report
        self.report_resolution_deg = 1.0

    def poll(self) -> Exchange:
        raise NotImplementedError

    def goto(self, az_deg: float, el_deg: float) -> Exchange:
        raise NotImplementedError

    def stop(self) -> Exchange:
        raise NotImplementedError

    def identify(self) -> Exchange | None:
        return None

    #: how often the controller's own status is read (0: the protocol reports none)
    status_interval_s = 0.0
    #: how long the controller may say nothing while it homes (0: it answers throughout)
    homing_s = 0.0

    def status(self) -> Exchange | None:
        """Read the controller's status (parsed to :class:`ControllerStatus`)."""
        return None

    def error_query(self) -> Exchange | None:
        """Read the controller's error once its status says it has one (parsed to
        :class:`ControllerError`)."""
        return None

    def home(self, in_error: bool) -> Exchange | None:
        """Home the controller on its endstops (``in_error``: it reports an error that
        only a restart clears), or None where the protocol has no such command."""
        return None

    def move(self, axis: str, direction: int, speed_frac: float) -> Exchange | None:
        """The controller's own jog of one axis (runs until a stop or a new target), or
        None where the protocol has none: a jog is then a goto to where it must end."""
        return None

    def quantise(self, value_deg: float, axis: int) -> float:
        """The value the controller will act on (its set resolution)."""
        step = self.resolution_deg[axis]
        return round(value_deg / step) * step


@dataclass(frozen=True)
class ControllerStatus:
    """The controller's own status: ``error`` when it reports one."""
    code: int
    text: str
    error: bool


@dataclass(frozen=True)
class ControllerError:
    code: int
    text: str


def _finite(az: float, el: float | None) -> tuple[float, float | None]:
    if not math.isfinite(az) or (el is not None and not math.isfinite(el)):
        raise ReplyError(f"non-finite position {az!r}, {el!r}")
    return az, el


# ---------------------------------------------------------------------- GS-232A / B
class Gs232(Dialect):
    """Yaesu GS-232A/B: ``C2`` polls, ``Waaa eee`` sets, ``S`` stops; whole degrees.

    The controller answers C2 only between commands: each set is followed by Hamlib's
    50 ms post-write delay and the next poll flushes whatever the set left behind
    (the A's CR acknowledgement)."""

    style = gs.STYLE_A
    timeout_s = 0.4

    def poll(self) -> Exchange:
        def parse(data: bytes) -> tuple[float, float]:
            try:
                return _finite(*gs.parse_position_reply(self.style, data.lstrip(b"\r\n")))
            except gs.Gs232ParseError as exc:
                raise ReplyError(str(exc)) from None
        # A ends with CRLF; B with CR (then LF, flushed before the next command)
        term = b"\n" if self.style == gs.STYLE_A else b"\r"
        return Exchange("poll", gs.format_query(), Reply(terminator=term), parse)

    def goto(self, az_deg: float, el_deg: float) -> Exchange:
        return Exchange("set", gs.format_goto(az_deg, el_deg), settle_s=0.05, pose=(az_deg, el_deg))

    def stop(self) -> Exchange:
        return Exchange("stop", gs.format_stop(), settle_s=0.05)

    def move(self, axis: str, direction: int, speed_frac: float) -> Exchange:
        return Exchange("move", gs.format_move(axis, direction, speed_frac), settle_s=0.05)


class Gs232a(Gs232):
    name = "gs232a"
    style = gs.STYLE_A


class Gs232b(Gs232):
    name = "gs232b"
    style = gs.STYLE_B


# ---------------------------------------------------------------------- Easycomm II / III
class Easycomm(Dialect):
    """Easycomm II/III: ``AZ EL`` polls, ``AZaaa.a ELeee.e`` sets (never answered),
    ``SA SE`` stops; tenths of a degree."""

    default_baud = 9600
    timeout_s = 0.5
    #: Easycomm reports compass azimuth (0..360, as Hamlib reads it): keep the turn by continuity
    az_modulo_deg = 360.0

    def __init__(self) -> None:
        super().__init__()
        self.resolution_deg = (0.1, 0.1)
        self.report_resolution_deg = 0.1

    def poll(self) -> Exchange:
        def parse(data: bytes) -> tuple[float, float]:
            try:
                return _finite(*ec.parse_az_el_reply(data.strip(b"\r\n \t")))
            except ec.EasycommParseError as exc:
                raise ReplyError(str(exc)) from None
        return Exchange("poll", ec.format_position_query(), Reply(terminator=b"\n"), parse)

    def goto(self, az_deg: float, el_deg: float) -> Exchange:
        return Exchange("set", ec.format_set_position(az_deg, el_deg), pose=(az_deg, el_deg))

    def stop(self) -> Exchange:
        return Exchange("stop", ec.format_stop())

    def identify(self) -> Exchange:
        return Exchange("identify", ec.format_version_query(), Reply(terminator=b"\n"),
                        lambda data: ec.parse_value_reply(data, "VE"))


class Easycomm2(Easycomm):
    name = "easycomm2"

    def move(self, axis: str, direction: int, speed_frac: float) -> Exchange:
        return Exchange("move", ec.format_move(axis, direction))   # ML..MD: its own speed


class Easycomm3(Easycomm):
    name = "easycomm3"

    def move(self, axis: str, direction: int, speed_frac: float) -> Exchange:
        return Exchange("move", ec.format_move(axis, direction, speed_frac))   # VL..VD


# ---------------------------------------------------------------------- SPID
class Spid(Dialect):
    """SPID Rot2Prog / MD-01/02 / Rot1Prog: 13-byte frames. Status (0x1F) polls and
    tells the controller's resolution (PH/PV pulses per degree), which every set then
    uses; stop (0x0F) answers with the position. Hamlib waits 300 ms after each frame."""

    variant = "rot2"
    default_baud = 600
    timeout_s = 0.4
    settle_s = 0.3

    def __init__(self) -> None:
        super().__init__()
        self.pulses = (0, 0)       # unknown until the first status reply
        self.resolution_deg = (1.0, 1.0)
        self.report_resolution_deg = 0.1 if self.variant != "rot1" else 1.0

    def _parse_position(self, data: bytes) -> tuple[float, float | None]:
        try:
            if self.variant == "rot1":
                return _finite(spid.decode_rot1_position(data), None)
            az, el, ph, pv = spid.decode_rot2_position(data)
        except spid.SpidFrameError as exc:
            raise ReplyError(str(exc)) from None
        if not (1 <= ph <= 10 and 1 <= pv <= 10) or any(b > 9 for b in data[1:5] + data[6:10]):
            raise ReplyError(f"expected digits 0..9 and PH/PV 1..10, got {data.hex(' ')}")
        self.pulses = (ph, pv)
        self.resolution_deg = (1.0 / ph, 1.0 / pv)
        return _finite(az, el)

    def _position_reply(self) -> Reply:
        return Reply(length=spid.ROT1_REPLY_LEN if self.variant == "rot1" else spid.ROT2_REPLY_LEN)

    def poll(self) -> Exchange:
        return Exchange("poll", spid.encode_query(spid.K_STATUS), self._position_reply(),
                        self._parse_position, settle_s=self.settle_s)

    def goto(self, az_deg: float, el_deg: float) -> Exchange:
        if self.variant == "rot1":
            return Exchange("set", spid.encode_rot1_set(az_deg), settle_s=self.settle_s, pose=(az_deg, el_deg))
        ph, pv = self.pulses if all(self.pulses) else (1, 1)
        # the frame truncates H = PH x (360 + az): aim half a step up so it rounds
        frame = spid.encode_rot2_set(az_deg + 0.5 / ph, el_deg + 0.5 / pv, ph, pv)
        answered = self.variant == "md01"
        return Exchange("set", frame, self._position_reply() if answered else None,
                        self._parse_position if answered else None, settle_s=self.settle_s, pose=(az_deg, el_deg))

    def stop(self) -> Exchange:
        return Exchange("stop", spid.encode_query(spid.K_STOP), self._position_reply(),
                        self._parse_position, settle_s=self.settle_s)


class Rot2Prog(Spid):
    name = "rot2prog"
    variant = "rot2"


class Md01(Spid):
    """MD-01/02 in ROT2 mode: Rot2Prog's frames, a position answer to a set, and a move
    of its own (K 0x14, Hamlib's model 903, the only SPID backend that has one): the
    direction bits in byte 1, no speed (it turns at the speed set on the controller),
    no answer. Hamlib always sends a stop before it ("the rotator must be stopped before
    changing directions"); urc also stops it before the goto that ends it, since nothing
    upstream says a set is taken while it moves on its own."""

    name = "md01"
    variant = "md01"
    default_baud = 115200
    stop_around_move = True
    _DIRECTIONS = {("az", -1): spid.DIR_LEFT, ("az", 1): spid.DIR_RIGHT,
                   ("el", 1): spid.DIR_UP, ("el", -1): spid.DIR_DOWN}

    def move(self, axis: str, direction: int, speed_frac: float) -> Exchange:
        # bytes 5 and 10 are uninitialised in Hamlib's frame (the controller ignores
        # them): urc fills in the PH/PV it reported, as in a set
        ph, pv = self.pulses if all(self.pulses) else (1, 1)
        frame = spid.encode_move(self._DIRECTIONS[axis, 1 if direction > 0 else -1], (ph, pv))
        return Exchange("move", frame, settle_s=self.settle_s)


class Rot1Prog(Spid):
    name = "rot1prog"
    variant = "rot1"
    default_baud = 1200
    has_el = False


# ---------------------------------------------------------------------- rotctld
class Rotctld(Dialect):
    """Hamlib's NET rotctl protocol to a ``rotctld`` (anything Hamlib drives): ``p``,
    ``P az el`` (answered ``RPRT n``), ``S``, ``_`` for identification."""

    name = "rotctld"
    timeout_s = 2.0
    az_modulo_deg = 360.0

    def __init__(self) -> None:
        super().__init__()
        # P takes hundredths, but no controller behind Hamlib turns to them (GS-232 and
        # Rot2Prog take whole or half degrees, an MD-01 a tenth at best): targets are
        # sent in tenths, so a track does not make the controller re-plan for nothing
        # five times a second (low pass through rotctld 0.77 -> 0.60 deg RMS, 978 -> 720
        # targets, bench/bridge_bench.py)
        self.resolution_deg = (0.1, 0.1)
        self.report_resolution_deg = 0.01

    @staticmethod
    def _check_rprt(data: bytes) -> int:
        code = rc.parse_rprt(data.strip(b"\r\n"))
        if code is None:
            raise ReplyError(f"expected RPRT n, found {data!r}")
        return code

    def poll(self) -> Exchange:
        def parse(data: bytes) -> tuple[float, float]:
            lines = data.splitlines()
            if lines and rc.parse_rprt(lines[0]) is not None:
                raise ReplyError(f"get_pos failed: {lines[0].decode(errors='replace')}")
            try:
                return _finite(*rc.parse_get_pos_reply(lines))
            except ValueError as exc:
                raise ReplyError(str(exc)) from None
        return Exchange("poll", b"p\n", Reply(terminator=b"\n", lines=2, stop_line=b"RPRT"), parse)

    def goto(self, az_deg: float, el_deg: float) -> Exchange:
        return Exchange("set", rc.format_set_pos_request(az_deg, el_deg), Reply(terminator=b"\n"),
                        self._check_rprt, pose=(az_deg, el_deg))

    def stop(self) -> Exchange:
        return Exchange("stop", b"S\n", Reply(terminator=b"\n"), self._check_rprt)

    def move(self, axis: str, direction: int, speed_frac: float) -> Exchange:
        return Exchange("move", rc.format_move_request(axis, direction, speed_frac), Reply(terminator=b"\n"),
                        self._check_rprt)

    def identify(self) -> Exchange:
        return Exchange("identify", b"_\n", Reply(terminator=b"\n"),
                        lambda data: data.strip().decode("ascii", "replace"))


# ---------------------------------------------------------------------- SatNOGS
class Satnogs(Dialect):
    """The SatNOGS rotator firmware (stepper_motor_controller): Easycomm II as it speaks
    it (:mod:`urc.wire.satnogs` says where each form comes from) plus its
    status (GS), error (GE) and homing (RESET, RB) commands.

    * A stop is answered with the position line (not silent as Easycomm's).
    * No move of its own: it has no ML..MD, and its VL..VD only set a speed mode the
      stepper loop never reads (stepper_motor_controller.ino:117-119): jogs are gotos.
    * It homes at every power-up and on RESET inside a loop that reads no serial input
      (stepper_motor_controller.ino:100-115, 154-200): silent until both endstops are
      found, then HOME_DELAY (12 s) more; ``homing_s`` bounds that silence.
    * A homing or watchdog error stays until a restart (RESET is ignored in the error
      state, ino:100 and 129-139): homing it then is RB, a reboot through the watchdog.
    """

    name = "satnogs"
    #: it reports its step count in degrees (step2deg, ino:224-226), not compass
    #: azimuth: 0..360 from the endstop, never folded
    az_modulo_deg = None
    #: easycomm.h:22 (BAUDRATE 19200)
    default_baud = 19200
    timeout_s = 0.5
    status_interval_s = 0.5
    #: seek of up to 360 deg az at 3200 steps/s of 240 steps/deg (13.3 deg/s, ino:26-31,
    #: 105-106) with its 1600 steps/s^2 ramps, then HOME_DELAY 12 s (ino:37), and the 2 s
    #: watchdog reboot before it (RB): 45 s, and a margin
    homing_s = 50.0

    def __init__(self) -> None:
        super().__init__()
        self.resolution_deg = (0.1, 0.1)     # AZ%.1f EL%.1f
        self.report_resolution_deg = 0.1     # String(x, 1)

    def poll(self) -> Exchange:
        return Exchange("poll", sn.format_position_query(), Reply(terminator=b"\n"), self._position)

    @staticmethod
    def _position(data: bytes) -> tuple[float, float]:
        try:
            az, el = sn.parse_position_reply(data)
        except sn.SatnogsParseError as exc:
            raise ReplyError(str(exc)) from None
        _finite(az, el)
        return az, el

    def identify(self) -> Exchange:
        return Exchange("identify", ec.format_version_query(), Reply(terminator=b"\n"),
                        lambda data: ec.parse_value_reply(data, "VE"))

    def goto(self, az_deg: float, el_deg: float) -> Exchange:
        return Exchange("set", sn.format_set_position(az_deg, el_deg), pose=(az_deg, el_deg))

    def stop(self) -> Exchange:
        return Exchange("stop", sn.format_stop(), Reply(terminator=b"\n"), self._position)

    def move(self, axis: str, direction: int, speed_frac: float) -> None:
        return None

    def status(self) -> Exchange:
        def parse(data: bytes) -> ControllerStatus:
            try:
                code = sn.parse_status_reply(data)
            except sn.SatnogsParseError as exc:
                raise ReplyError(str(exc)) from None
            return ControllerStatus(code, sn.describe_status(code), code == sn.STATUS_ERROR)
        return Exchange("status", sn.format_status_query(), Reply(terminator=b"\n"), parse)

    def error_query(self) -> Exchange:
        def parse(data: bytes) -> ControllerError:
            try:
                code = sn.parse_error_reply(data)
            except sn.SatnogsParseError as exc:
                raise ReplyError(str(exc)) from None
            return ControllerError(code, sn.describe_error(code))
        return Exchange("error", sn.format_error_query(), Reply(terminator=b"\n"), parse)

    def home(self, in_error: bool) -> Exchange:
        if in_error:
            return Exchange("home", sn.format_reboot())
        return Exchange("home", sn.format_reset(), Reply(terminator=b"\n"), self._position)


DIALECTS: dict[str, type[Dialect]] = {
    "gs232a": Gs232a, "gs232b": Gs232b, "easycomm2": Easycomm2, "easycomm3": Easycomm3,
    "rot2prog": Rot2Prog, "rot1prog": Rot1Prog, "md01": Md01, "rotctld": Rotctld, "satnogs": Satnogs,
}
assert tuple(DIALECTS) == BRIDGE_PROTOCOLS


def make_dialect(name: str) -> Dialect:
    return DIALECTS[name]()
