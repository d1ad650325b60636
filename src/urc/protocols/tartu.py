"""The Tartu universal rotator controller's four-letter ASCII command set.

Lines end CR, LF or CRLF; parameters are comma separated, after a space or a comma
(``GOAE 123.4,45.0``, or the document's ``GOAE,123.4,45.0``); replies
are lines ending CR LF. Angles are in the controller's own (extended) frame: azimuth
with its cable wrap (0..400 on the Tartu rotator; 380.0 is the overlap), elevation 0..180
(past 90 = flipped over the top). Angles print as ``xxx.x``.

=========  ====================================================================
VERS       ``URC urc-0.1.0 (Tartu URC command set)``
HELP       one line per command
BAUD [r]   ``BAUD 115200`` (the document's serial default, 8N1): reports the rate;
           ``BAUD 9600`` answers ``OK`` at the old rate, then a serial port really
           changes to the new one (a pty or TCP has no rate)
ECHO [on]  ``ECHO ON|OFF`` reports; ``ECHO ON``/``OFF``/``1``/``0`` sets character echo
           for this connection (typed characters, backspace, CR LF at the end)
GOAZ a     go to azimuth a, elevation keeps its target → ``OK``
GOEL e     go to elevation e, azimuth keeps its target → ``OK``
GOAE a,e   go to both → ``OK``
RDAZ       present azimuth → ``123.4``
RDEL       present elevation → ``045.0``
WRAZ a     declare the present azimuth is a (re-reference, no motion) → ``OK``
WREL e     the same for elevation → ``OK``
RDAP       the azimuth position pulse counter (the document: "amount of impulses"),
           a signed integer: the encoder's count from the axis' reference (0 deg), 10
           per degree on the Tartu rotator (az 12.3 -> 123, el 45 -> 450, whatever pose
           the controller was powered up in); on a sensor without a counter, the
           position in sensor steps
RDEP       the same for elevation
OVRA [x]   azimuth overshoot compensation (the on/off drive stops this far before the
           target) → ``000.3``; ``OVRA x`` sets it (0..20 deg; the rotator keeps learning
           from there; read back after its next control tick) → ``OK``
OVRE [x]   the same for elevation
HALT       stop both axes (the TRC: its one motor) → ``OK``;  HLTA azimuth only;
           HLTE elevation only
LCDC [c]   LCD contrast: ``LCDC`` → ``LCDC 32``; ``LCDC 40`` sets it (0..63) → ``OK``;
           the controller's state, shared by every connection to this rotator
=========  ====================================================================

Errors: ``ERR <code> <text>`` with code 1 unknown command, 2 bad parameter, 3 outside
the limits, 4 keep-out zone, 5 fault, 6 position unknown (re-reference with WRAZ/WREL),
7 not supported, 8 line too long, 9 refused otherwise. Nothing moves on an error.
System errors are reported on the serial port as they happen, as the document asks
(its LED and serial error reporting): a fault that latches prints one unsolicited line
``ERR 5 <axis> fault: <reason>`` (the error codes' form; the document gives none).

Variant ``trc`` (option ``variant = "trc"``): the single-axis turntable controller of
the document's Figure 1, which knows only VERS HELP BAUD ECHO GOAZ RDAZ WRAZ RDAP HALT
OVRA (anything else is ``ERR 1``, and HELP lists those). It is the default on a
single-axis rotator (``[rotator] elevation = false``); ``variant = "urc"`` there keeps
the full set, whose elevation commands then answer ``ERR 7`` (not supported) and move
nothing, while RDEL/RDEP read 0 as an azimuth-only unit would.
"""

from __future__ import annotations

import weakref

from .. import __version__
from ..errors import CommandRejected, UrcError
from ..model.messages import OvershootQuery, SensorCount, SetOvershoot, SetPosition
from ..model.effects import Effects, as_effects
from .base import MAX_PENDING_BYTES, RotatorPort, bad_input_log, internal_error, protocol_logger
from . import tartu_codec as codec
from .lines import LineSplitter, TerminalEcho
from .poses import ExtendedTarget, extended_pose_deg
from .single_axis import has_elevation
from .tartu_codec import Command, TartuSyntaxError

log = protocol_logger("tartu")
bad_input = bad_input_log("tartu")

VARIANTS = ("urc", "trc")
#: the controller's own state that outlives a connection (the LCD contrast), per rotator
_PANEL: "weakref.WeakKeyDictionary[object, dict]" = weakref.WeakKeyDictionary()
#: the document's RS-232 setting: 115200 bit/s, 8N1
DEFAULT_BAUD = 115200


def lcd_contrast(rotator) -> int | None:
    """The LCD contrast (0..LCD_CONTRAST_MAX) LCDC last set on this rotator, None if
    never (the front panel applies it to a display that has a contrast control)."""
    return _PANEL.get(rotator, {}).get("lcd_contrast")


class TartuSession:
    """One connection speaking the Tartu URC command set.

    Options: ``echo`` (bool, default False): start with character echo on;
    ``variant``: ``"urc"`` (both axes) or ``"trc"`` (the turntable's subset); default:
    ``"trc"`` on a single-axis rotator, else ``"urc"``.
    """

    wants_tick = True       # reports faults as they latch (see the module notes)
    default_baud = DEFAULT_BAUD

    def __init__(self, rotator: RotatorPort, *, echo: bool = False, variant: str | None = None):
        if variant is None:
            variant = "urc" if has_elevation(rotator) else "trc"
        if variant not in VARIANTS:
            raise ValueError(f"variant must be one of {', '.join(VARIANTS)}, got {variant!r}")
        self.rotator = rotator
        self.closed = False
        self.echo = bool(echo)
        self.variant = variant
        self._commands = codec.TRC_COMMANDS if variant == "trc" else None
        self.baud = DEFAULT_BAUD
        #: a new line rate for the serial adapter to apply after the reply (BAUD)
        self.baud_request: int | None = None
        self._lines = LineSplitter(MAX_PENDING_BYTES, backspace=True, log=bad_input)
        self._echo = TerminalEcho()
        self._targets = ExtendedTarget(rotator, named=True)  # its own azimuth: a set names the pose
        self._faults_seen: set | None = None

    # ------------------------------------------------------------------ Session
    def receive(self, data: bytes) -> Effects[list[bytes]]:
        out: list[bytes] = []
        for item in self._lines.feed(data):
            if item.overflowed:
                out.append(codec.error(codec.E_OVERFLOW, f"line too long: expected at most "
                                                         f"{MAX_PENDING_BYTES} characters before CR/LF"))
                continue
            if self.echo:
                out.append(self._echo.end_line(item.text))
            if not item.text.strip():
                continue
            try:
                reply = yield from self._execute(codec.parse_line(item.text, self._commands))
            except TartuSyntaxError as exc:
                bad_input.info("rejected %r: %s", item.text[:80], exc)
                reply = codec.error(exc.code, str(exc))
            except CommandRejected as exc:
                bad_input.info("rotator refused %r: %s", item.text[:80], exc)
                reply = codec.error(codec.REASON_CODES.get(exc.reason, codec.E_REJECTED), str(exc))
            except UrcError as exc:     # a hardware failure
                log.warning("command %r failed: %s", item.text[:80], exc)
                reply = codec.error(codec.E_REJECTED, str(exc))
            except Exception as exc:    # a bug: the connection survives, the bug is counted
                internal_error(log, "tartu", "command %r failed", item.text[:80])
                reply = codec.error(codec.E_REJECTED, f"internal error: {exc}")
            out.append(reply)
        if self.echo:
            shown = self._echo.update(self._lines.partial)
            if shown:
                out.append(shown)
        return out

    def tick(self, now_s: float) -> list[bytes]:
        """One ``ERR 5`` line per fault that latched since the last tick."""
        faults = {(f.kind, f.axis, f.reason) for f in self.rotator.status().faults}
        seen, self._faults_seen = self._faults_seen, faults
        if seen is None:                   # a new connection: report what is latched now
            seen = set()
        return [codec.error(codec.E_FAULT, f"{axis or 'rotator'} fault: {kind}: {reason}")
                for kind, axis, reason in sorted(faults - seen, key=str)]

    # ----------------------------------------------------------------- commands
    def _execute(self, cmd: Command) -> Effects[bytes]:
        # (a handler answers at once, or is a generator: the commands that act)
        handler = getattr(self, "_cmd_" + cmd.name.lower())
        return (yield from as_effects(handler(*cmd.args)))

    def _cmd_vers(self) -> bytes:
        return codec.line(f"URC urc-{__version__} (Tartu URC command set)")

    def _cmd_help(self) -> bytes:
        return codec.help_text(self._commands)

    def _cmd_baud(self, rate: int | None = None) -> bytes:
        if rate is None:
            return codec.line(f"BAUD {self.baud}")
        self.baud = self.baud_request = rate   # a serial adapter switches after this reply
        return codec.ok()

    def _cmd_echo(self, on: bool | None = None) -> bytes:
        if on is None:
            return codec.line("ECHO " + ("ON" if self.echo else "OFF"))
        self.echo = on
        return codec.ok()

    def _goto(self, az: float | None, el: float | None) -> Effects[bytes]:
        if az is None and not has_elevation(self.rotator):
            # GOEL on a unit without elevation: ERR 7 (not supported), nothing moves;
            # GOAE there turns the azimuth and leaves the elevation aside (the service)
            raise CommandRejected("no elevation axis on this rotator (azimuth only)", "no_axis")
        yield from self._targets.goto(az, el)
        return codec.ok()

    def _cmd_goaz(self, az: float) -> Effects[bytes]:
        return self._goto(az, None)

    def _cmd_goel(self, el: float) -> Effects[bytes]:
        return self._goto(None, el)

    def _cmd_goae(self, az: float, el: float) -> Effects[bytes]:
        return self._goto(az, el)

    def _cmd_rdaz(self) -> bytes:
        return codec.line(codec.format_deg(extended_pose_deg(self.rotator.status())[0]))

    def _cmd_rdel(self) -> bytes:
        return codec.line(codec.format_deg(extended_pose_deg(self.rotator.status())[1]))

    def _cmd_wraz(self, az: float) -> Effects[bytes]:
        yield SetPosition(az_deg=az)
        self._targets.forget()
        return codec.ok()

    def _cmd_wrel(self, el: float) -> Effects[bytes]:
        yield SetPosition(el_deg=el)
        self._targets.forget()
        return codec.ok()

    def _pulses(self, axis: str) -> Effects[bytes]:
        """The axis' position pulse counter: the sensor's own count where it keeps one
        (encoder, pulse feedback), counted from the axis' reference as the position is
        (the counter itself starts at 0 in whatever pose the controller powered up),
        else the position in sensor steps. One query: one round trip at most."""
        reading = yield SensorCount(axis)
        if reading.count is not None:
            return codec.line(str(reading.count))
        pos = extended_pose_deg(self.rotator.status())[0 if axis == "az" else 1]
        return codec.line(str(round(pos / (reading.resolution_deg or 0.1))))

    def _cmd_rdap(self) -> Effects[bytes]:
        return self._pulses("az")

    def _cmd_rdep(self) -> Effects[bytes]:
        return self._pulses("el")

    def _overshoot(self, axis: str, value: float | None) -> Effects[bytes]:
        if value is None:
            return codec.line(codec.format_deg((yield OvershootQuery(axis))))
        yield SetOvershoot(axis, value)
        return codec.ok()

    def _cmd_ovra(self, value: float | None = None) -> Effects[bytes]:
        return self._overshoot("az", value)

    def _cmd_ovre(self, value: float | None = None) -> Effects[bytes]:
        return self._overshoot("el", value)

    def _stop(self, axis: str | None) -> Effects[bytes]:
        yield from self._targets.stop(axis)
        return codec.ok()

    def _cmd_halt(self) -> Effects[bytes]:
        return self._stop(None)

    def _cmd_hlta(self) -> Effects[bytes]:
        return self._stop("az")

    def _cmd_hlte(self) -> Effects[bytes]:
        return self._stop("el")

    def _cmd_lcdc(self, contrast: int | None = None) -> bytes:
        panel = _PANEL.setdefault(self.rotator, {"lcd_contrast": codec.LCD_CONTRAST_DEFAULT})
        if contrast is None:
            return codec.line(f"LCDC {panel['lcd_contrast']}")
        panel["lcd_contrast"] = contrast
        return codec.ok()

    def lcd_rows(self) -> list[str]:
        """The two 20-character rows the controller's LCD shows (for a front panel)."""
        return codec.lcd_rows(self.rotator.status())
