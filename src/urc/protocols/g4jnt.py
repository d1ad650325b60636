"""The G4JNT PIC rotator controller's serial port (seed 003), on urc.

At power-on (a connection's first tick; a pty's start) it prints the banner with the
stored constants (Table 1), then every ``interval_s`` (0.5 s) a stream line
``b059.3,p1415``: P is the ratiometric pot value the azimuth sensor last read (P = 4096
N / (K - N) from its 10-bit count N) and b the bearing the controller computes from
that P and its constants (see g4jnt_codec): the stream always agrees with itself and
with Table 1's arithmetic.

The constants Z, M, C, K are the rotator's own pot calibration, kept where urc keeps
every sensor calibration (the rotator's state file, through
:func:`urc.procedures.calibration.apply_sensor_calibration`), across connections and
restarts, like the PIC's non-volatile memory. As in the document, M and C (and K) give
the angle theta from the end-stop reference, to which the travel limits belong (-10..370
on the g4jnt profile), and Z is the bearing of that reference: ``#Z1807`` turns the
bearings the rotator reports and takes, for every protocol (nothing moves, no limit
moves), and a goto reaches a bearing at the theta inside the travel that gives it.

A calibration routine loads M and C one after the other: an M whose theta, with the C in
force, would lie outside the travel is not an error but held, answered
``M -15897 held: ...``, and stored together with the next constant(s) that make the set
consistent (``#C3758`` -> ``C 3758``). Held constants belong to the connection and are
listed after the stored ones by ``?``; nothing moves while they are held, the rotator
keeps working on the constants in force.

A g4jnt session on a rotator without a ratiometric pot keeps the constants for the
connection only (nothing to calibrate) and derives P backwards from the bearing.

Commands: ``#`` + Z/C/K/M + signed integer; ``L``/``R`` go-left/go-right pulses (one
``PULSE_DEG`` step: the relay drive's slow pulse); ``G123.4[,45]`` go to; ``S`` stop;
``?`` the constants again. Errors: one line ``? <what was expected>, got '<what came>'``.
"""

from __future__ import annotations

from ..errors import CommandRejected, NoSuchConstant, UrcError
from ..model.messages import ApplyCalibration, PotReading, PotState
from ..model.effects import Effects, drive
from .base import MAX_PENDING_BYTES, RotatorPort, bad_input_log, internal_error, protocol_logger
from . import g4jnt_codec as codec
from .g4jnt_codec import Constants, G4jntCommand, G4jntSyntaxError
from .lines import LineSplitter, next_due_s
from .poses import ExtendedTarget, PositionUnknown, extended_pose_deg, require_known

log = protocol_logger("g4jnt")
bad_input = bad_input_log("g4jnt")

#: one go-left/go-right pulse turns the azimuth this far. The document's slow drive
#: pulses the motor at 2 Hz; a step is what one such pulse turns on the relay-driven
#: rotators it was built for, and more than the drive's restart band (1.8 deg on the
#: g4jnt profile), so that a pulse always moves.
PULSE_DEG = 2.0


class G4jntSession:
    wants_tick = True  # banner and position stream (see base.Session)

    def __init__(self, rotator: RotatorPort, *, interval_s: float = 0.5):
        if not interval_s > 0:
            raise ValueError(f"interval_s must be > 0, got {interval_s!r}")
        self.rotator = rotator
        self.closed = False
        self.interval_s = float(interval_s)
        #: without a pot: this connection's constants (a 0..360 deg pot over P 0..4096)
        self._own = Constants(z=0, m=round(3600 * codec.M_SCALE / 4096), c=0, k=2048)
        self._lines = LineSplitter(MAX_PENDING_BYTES, backspace=True, log=bad_input)
        self._targets = ExtendedTarget(rotator, named=True)  # its own azimuth: a set names the pose
        self._next_s: float | None = None
        self._powered = False
        #: constants set but not yet consistent (see the module notes): held, not stored
        self._held: dict[str, int] = {}

    def _pot(self) -> Effects[PotReading | None]:
        """The azimuth's ratiometric pot: its constants and last ADC count (one query, one
        round trip: each command and each stream line asks once), None without one."""
        return (yield PotState())

    def _constants(self, pot: PotReading | None) -> Constants:
        return self._own if pot is None else codec.from_sensor(pot.calibration)

    @property
    def constants(self) -> Constants:
        """The constants in force now (for tests and tools: the query is performed at
        once; the session itself yields it)."""
        return self._constants(drive(self._pot(), self.rotator))

    # ------------------------------------------------------------------ Session
    def receive(self, data: bytes) -> Effects[list[bytes]]:
        out: list[bytes] = []
        for item in self._lines.feed(data):
            if item.overflowed:
                out.append(codec.line(f"? line too long: expected at most {MAX_PENDING_BYTES} characters"))
                continue
            try:
                cmd = codec.parse_line(item.text)
                if cmd is not None:
                    out.append((yield from self._execute(cmd)))
            except G4jntSyntaxError as exc:
                bad_input.info("rejected %r: %s", item.text[:80], exc)
                out.append(codec.line(f"? {exc}"))
            except CommandRejected as exc:
                bad_input.info("rotator refused %r: %s", item.text[:80], exc)
                out.append(codec.line(f"? refused ({exc.reason}): {exc}"[:120]))
            except UrcError as exc:     # a hardware or calibration failure
                log.warning("line %r failed: %s", item.text[:80], exc)
                out.append(codec.line(f"? failed: {exc}"[:120]))
            except Exception as exc:    # a bug: the connection survives, the bug is counted
                internal_error(log, "g4jnt", "line %r failed", item.text[:80])
                out.append(codec.line(f"? internal error: {exc}"[:120]))
        return out

    def tick(self, now_s: float) -> Effects[list[bytes]]:
        out = []
        nxt = next_due_s(self._next_s, now_s, self.interval_s)
        pot = (yield from self._pot()) if nxt is not None or not self._powered else None
        if not self._powered:
            self._powered = True
            out.append(codec.banner(self._constants(pot)))
        if nxt is not None:
            self._next_s = nxt
            try:
                out.append((yield from self.stream_line(pot)))
            except PositionUnknown as exc:    # homing: no bearing to stream, say why
                out.append(codec.line(f"? {exc}"))
        return out

    def stream_line(self, pot: PotReading | None = None) -> Effects[bytes]:
        """One stream line from ``pot`` (asked for when not given)."""
        if pot is None:
            pot = yield from self._pot()
        k = self._constants(pot)
        require_known(self.rotator.status())
        if pot is not None:
            p = codec.linearise(pot.last_counts, k.k)
        else:
            p = codec.p_for_bearing(extended_pose_deg(self.rotator.status())[0], k)
        return codec.stream_line(codec.bearing_tenths(p, k), p)

    # ----------------------------------------------------------------- commands
    def _execute(self, cmd: G4jntCommand) -> Effects[bytes]:
        if cmd.kind == "const":
            assert cmd.value is not None
            # (the rotator applies a re-reference at its next tick: answer with the
            # value accepted, not a read-back that may precede it)
            return (yield from self._set_constant(cmd.name, cmd.value))
        if cmd.kind == "all":
            constants = self._constants((yield from self._pot()))
            listing = b"".join(codec.constant_line(n, constants) for n in codec.CONSTANT_ORDER)
            held = [n for n in codec.CONSTANT_ORDER if n in self._held and self._held[n] != constants.get(n)]
            if held:
                listing += codec.line("Held (not stored) - " + " ".join(f"{n} {self._held[n]}" for n in held))
            return listing
        if cmd.kind == "stop":
            yield from self._targets.stop()
            return codec.line("S")
        if cmd.kind == "pulse":
            az = extended_pose_deg(self.rotator.status())[0]
            yield from self._targets.goto(az + cmd.direction * PULSE_DEG, None)
            return codec.line("L" if cmd.direction < 0 else "R")
        assert cmd.kind == "goto" and cmd.az_deg is not None
        yield from self._targets.goto(cmd.az_deg, cmd.el_deg)
        echo = f"G{cmd.az_deg:g}" + ("" if cmd.el_deg is None else f",{cmd.el_deg:g}")
        return codec.line(echo)

    def _set_constant(self, name: str, value: int) -> Effects[bytes]:
        """One round trip: the new constant, with those held, goes to the pot (the rotator
        keeps the others in force); a rotator without a ratiometric pot refuses it and the
        connection keeps its own."""
        changes = {**self._held, name: value}
        # the rotator re-references to what the new constants say, persists them with
        # its state, and refuses (CommandRejected) if that would break its limits
        try:
            yield ApplyCalibration("az", codec.sensor_values(changes), require=POT_CONSTANTS)
        except NoSuchConstant:
            self._own = self._own.with_value(name, value)
            return codec.line(f"{name} {value}")
        except CommandRejected as exc:
            if exc.reason != "limit":
                raise
            # one of a pair still to come (M then C): hold it, store nothing yet
            self._held = changes
            bad_input.info("holding %s %d: %s", name, value, exc)
            return codec.line(f"{name} {value} held: {exc}; stored once the constants "
                              "that follow make theta fit"[:160])
        self._held = {}
        return codec.line(f"{name} {value}")


#: the constants that make the azimuth sensor a G4JNT-style ratiometric pot
POT_CONSTANTS = ("K", "M")
