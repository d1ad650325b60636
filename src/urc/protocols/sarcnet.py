"""The SARCNET mini rotator's serial console (Rotator7.ino, VK3FOWL/VK3YSP), on urc.

Lines end CR, LF or CRLF. As on the Arduino, the port carries two kinds of line:

**Console** (a person at a terminal; replies end CR LF):

=======  ======================================================================
az el    go to azimuth ``az`` (0..360 or -180..180) and elevation ``el``, e.g.
         ``120 30`` or ``-90 45``; silent on success like the original, ``Error: ..``
         when refused. While paused the target is kept and flown on resume.
r        reset, as the original: prints the calibration data, stops, clears latched
         faults, leaves any mode and drives home (az 0, el 0) with the windup reset
         (azimuth 0 of the unwound cable, not 360)
b        debug mode: stream the raw sensor data ``Mx,My,Mz,Gx,Gy,Gz`` every
         ``interval_s``: the magnetometer part's vector (in its own units: the sim's
         horizontal field strength is 1) and the accelerometer's in g, three decimals
         (the document names the six values, not their scale or format)
c        the 12-direction hand-held calibration (motor supply off, board off the boom):
         prompts each direction (each face down, then along the magnetic field),
         says when each is done, shows the magnetometer (M) and accelerometer (G)
         offsets and scales when they change; ``s`` saves them (all 12 done and the
         ellipsoid fits good, else nothing changes and it says why), ``a``/ESC/ctrl-C
         or a disconnect abandon it unchanged. Motion is refused meanwhile (a local
         control hold). Then ``r`` (board back on the boom) clears the faults the
         wandering readings raised and drives home
d        demo mode: the document's cycle 0/0, 90/90, 0/180, 90/90, 0/0, -90/90, -180/0,
         -90/90 (az/el; el past 90 is over the top), the set point moving straight
         between them at 1 deg/s per axis from where the antenna is, flying it and
         printing ``azSet,elSet`` each period
m        monitor mode: stream ``az,el,azSet,elSet,azWindup,windup,azError,elError``
         every ``interval_s`` (whole degrees; az in -180..180; azWindup = azimuth with
         its cable wrap, e.g. 400 or -10; windup = 1 while that lies outside 0..360,
         the overlap urc unwinds when it next can; error = position - set point)
a        abort the running mode (debug, monitor, demo: demo motion stops)
e[NN.N]  magnetic declination: ``e`` prints it, ``e11.7`` sets it (east positive, as the
         document says): the compass driver's own setting, kept with the rotator's
         calibration across restarts; the azimuth the rotator reports shifts with it
s        save: urc saves the declination and calibration as they change; confirms
p        pause: stop and hold; ``p`` again resumes (flying a target given meanwhile)
h        help
=======  ======================================================================

**Easycomm II subset** (Hamlib rotctld model 202 / Gpredict; replies end LF only):
``AZ`` -> ``AZ123.4``, ``EL`` -> ``EL45.6``, ``AZ EL`` (Hamlib 4.5) -> ``AZ123.4 EL45.6``,
``AZx ELy`` (optionally with Easycomm I ``UPnnn XXX DNnnn XXX``) sets, ``SA``/``SE`` stop;
sets and stops are answered with nothing, malformed Easycomm lines are logged only.

Options: ``interval_s`` (0.1): period of the monitor, debug and demo streams (the
Arduino's 100 ms timer); they are emitted from ``tick(now_s)``.
"""

from __future__ import annotations

from ..errors import CalibrationError, CommandRejected, NoSuchConstant, UrcError
from ..model.messages import (ApplyCalibration, ApplyTwelveDirection, BeginHandCalibration, Goto, HoldLocal,
                            RawVectors, Reset, SensorCalibrations, Stop)
from ..procedures.calibration_twelve import TwelveDirectionCalibration
from ..model.effects import Effects, as_effects
from ..model.snapshot import Status
from .base import (MAX_PENDING_BYTES, RotatorPort, bad_input_log, internal_error,
                   protocol_logger)
from . import sarcnet_codec as codec
from .lines import LineSplitter, next_due_s
from .poses import extended_goto, extended_pose_deg, goto_named_axes, require_known
from .sarcnet_codec import SarcnetCommand, SarcnetSyntaxError, signed180
from .single_axis import wire_el_deg

log = protocol_logger("sarcnet")
bad_input = bad_input_log("sarcnet")

#: the local control the console calibration holds while the board is off the boom
CALIBRATION_HOLD = "SARCNET calibration"
DEMO_RATE_DEG_PER_S = 1.0       # the original: 0.05 deg every 50 ms
DEMO_GOTO_EVERY_S = 0.5         # refresh the rotator's target no faster than this
#: the document's demo cycle, az/el (az in -180..180)
DEMO_POINTS = ((0.0, 0.0), (90.0, 90.0), (0.0, 180.0), (90.0, 90.0), (0.0, 0.0), (-90.0, 90.0),
               (-180.0, 0.0), (-90.0, 90.0))


class SarcnetSession:
    """One connection to the SARCNET console. Option ``interval_s`` (0.1 s): period of
    the monitor, debug and demo streams."""
    wants_tick = True  # streams position lines (see base.Session)


    def __init__(self, rotator: RotatorPort, *, interval_s: float = 0.1):
        if not interval_s > 0:
            raise ValueError(f"interval_s must be > 0, got {interval_s!r}")
        self.rotator = rotator
        self.closed = False
        self.interval_s = float(interval_s)
        # tracking | monitoring | debugging | demonstrating | pausing | calibrating
        self.mode = "tracking"
        self._cal = TwelveDirectionCalibration()
        self._cal_shown: list[str] | None = None
        self._lines = LineSplitter(MAX_PENDING_BYTES, backspace=True, log=bad_input)
        self._next_s: float | None = None
        self._last_s: float | None = None
        self._held: tuple[float, float] | None = None      # target given while paused
        self._demo = [0.0, 0.0]                             # set point: az (-180..180), el
        self._demo_next = 0                                 # index of the point it heads for
        self._demo_goto_s = -1e300

    # ------------------------------------------------------------------ Session
    def receive(self, data: bytes) -> Effects[list[bytes]]:
        out: list[bytes] = []
        if self.mode == "calibrating" and (b"\x1b" in data or b"\x03" in data):
            # ESC or ctrl-C: as 'a' (a terminal user's reflex); the rest of the chunk and
            # the line typed so far are dropped with it
            self._lines = LineSplitter(MAX_PENDING_BYTES, backspace=True, log=bad_input)
            return (yield from self._end_calibration("Calibration aborted: nothing changed"))
        for item in self._lines.feed(data):
            if item.overflowed:
                out.append(codec.console(f"Error: line too long (over {MAX_PENDING_BYTES} characters)"))
                continue
            try:
                cmd = codec.parse_line(item.text)
                if cmd is None:
                    continue
                out.extend((yield from self._execute(cmd)))
            except SarcnetSyntaxError as exc:
                bad_input.info("rejected %r: %s", item.text[:80], exc)
                # Easycomm has no error reply (Hamlib reads none): log only
                if item.text.strip().lstrip(b";").strip()[:2] not in (b"AZ", b"EL", b"SA", b"SE"):
                    out.append(codec.console(f"Error: {exc}"))
            except UrcError as exc:     # refused by the rotator, or a hardware failure
                bad_input.info("line %r failed: %s", item.text[:80], exc)
                out.append(codec.console(f"Error: {exc}"))
            except Exception:           # a bug: logged with its traceback and counted
                internal_error(log, "sarcnet", "line %r failed", item.text[:80])
                out.append(codec.console("Error: internal error"))
        return out

    def tick(self, now_s: float) -> Effects[list[bytes]]:
        if self.mode not in ("monitoring", "debugging", "demonstrating", "calibrating"):
            self._next_s = self._last_s = None
            return []
        nxt = next_due_s(self._next_s, now_s, self.interval_s)
        if nxt is None:
            return []
        dt = 0.0 if self._last_s is None else max(0.0, now_s - self._last_s)
        self._next_s, self._last_s = nxt, now_s
        st = self.rotator.status()
        if self.mode == "monitoring":
            return [self._monitor_row(st)]
        if self.mode == "debugging":
            return [(yield from self._raw_row())]
        if self.mode == "calibrating":
            return (yield from self._calibration_step())
        return (yield from self._demo_step(st, now_s, dt))

    # ----------------------------------------------------------------- commands
    def _execute(self, cmd: SarcnetCommand) -> Effects[list[bytes]]:
        if self.mode == "calibrating" and cmd.kind != "ec_query" and \
                not (cmd.kind == "letter" and cmd.letter in "ash"):
            # the board is in the operator's hand: no motion, no other mode
            return [codec.console("Error: calibrating: s to save, a to abort")]
        if cmd.kind == "goto":
            assert cmd.az_deg is not None and cmd.el_deg is not None
            try:
                yield from self._set(cmd.az_deg, cmd.el_deg)
            except CommandRejected as exc:
                bad_input.info("goto %g %g refused: %s", cmd.az_deg, cmd.el_deg, exc)
                return [codec.console(f"Error: {exc}")]
            return []
        if cmd.kind == "ec_query":
            st = require_known(self.rotator.status())
            return [codec.easycomm_position(cmd.axes, st.az_deg, wire_el_deg(st))]
        if cmd.kind == "ec_set":
            try:
                yield from self._set(cmd.az_deg, cmd.el_deg)
            except CommandRejected as exc:
                given = " ".join(f"{n} {v:g}" for n, v in (("az", cmd.az_deg), ("el", cmd.el_deg)) if v is not None)
                bad_input.warning("Easycomm set %s refused (%s): %s", given, exc.reason, exc)
            return []
        if cmd.kind == "ec_stop":
            yield Stop(cmd.axes[0] if len(set(cmd.axes)) == 1 else None)
            return []
        # (a letter answers at once, or is a generator: those that act)
        return (yield from as_effects(getattr(self, "_letter_" + cmd.letter)(cmd)))

    def _set(self, az: float | None, el: float | None) -> Effects[None]:
        """Fly (az, el), or keep it for later while paused; None (an Easycomm set of one
        axis): that axis keeps its target, or where it is after a stop. Azimuth 0..360
        or -180..180: the SARCNET unwinds by itself, so it names a direction, not a wrap
        pose."""
        if az is not None:
            if not -180.0 <= az <= 360.0:
                raise CommandRejected(f"azimuth {az:g} outside 0..360 (or -180..180)", "limit")
            az %= 360.0
        if self.mode == "pausing":
            held = self._held
            if held is None:                         # paused: stopped where it is
                st = self.rotator.status()
                held = (st.az_deg, wire_el_deg(st))
            self._held = (held[0] if az is None else az, held[1] if el is None else el)
            return
        if self.mode == "demonstrating":
            # as on the Arduino, the cycle carries on from the new set point
            self._demo = [self._demo[0] if az is None else signed180(az), self._demo[1] if el is None else el]
        yield from goto_named_axes(az, el)

    def _letter_r(self, cmd: SarcnetCommand) -> Effects[list[bytes]]:
        out = [codec.console("Reset in progress")]
        # the constants listed, stop, clear, home (windup reset): one step over there
        home = extended_goto(self.rotator.status(), 0.0, 0.0)
        outcome = yield Reset(home)
        out += [codec.console(f"{name}: {value}") for name, value in calibration_rows(outcome.calibrations)]
        self.mode, self._held = "tracking", None
        if outcome.refused is not None:
            out.append(codec.console(f"Error: {outcome.refused}"))
        out.append(codec.console("Reset complete"))
        return out

    def _raw_vectors(self) -> Effects[tuple[tuple[float, ...], tuple[float, ...]] | None]:
        """(magnetometer, accelerometer) vectors from the compass driver's and the tilt
        driver's (or the compass's own) parts, before any calibration; None where the
        rotator has no such parts. One query: one round trip."""
        return (yield RawVectors())

    def _raw_row(self) -> Effects[bytes]:
        """Mx,My,Mz,Gx,Gy,Gz straight from the parts, before any calibration."""
        vectors = yield from self._raw_vectors()
        if vectors is None:
            return codec.console("Error: no raw magnetometer/accelerometer on this rotator")
        return codec.console(",".join(f"{v:.3f}" for v in (*vectors[0], *vectors[1])))

    def _letter_b(self, cmd: SarcnetCommand) -> list[bytes]:
        self._enter("debugging")
        return [codec.console("Debugging in progress: Press 'a' to abort")]

    def _letter_m(self, cmd: SarcnetCommand) -> list[bytes]:
        self._enter("monitoring")
        return [codec.console("Monitoring in progress: Press 'a' to abort")]

    # ------------------------------------------------------ 12-direction calibration
    def _letter_c(self, cmd: SarcnetCommand) -> Effects[list[bytes]]:
        # the board is off the boom: nothing may drive on its readings meanwhile (the
        # document has the motor supply disconnected); the hold says why everywhere
        # (stop and hold: one step where the rotator is, one round trip)
        if not (yield BeginHandCalibration(CALIBRATION_HOLD)):
            return [codec.console("Error: no raw magnetometer/accelerometer on this rotator")]
        self._enter("calibrating")
        self._cal = TwelveDirectionCalibration()
        self._cal_shown = None
        return [codec.console(row) for row in codec.CALIBRATION_INTRO] + [self._next_prompt()]

    def _next_prompt(self) -> bytes:
        left = self._cal.remaining
        if not left:
            return codec.console("All 12 directions done: keep moving gently to refine, "
                                 "s to save, a to abort")
        face, along = left[0]
        return codec.console(f"Next: {codec.direction_text(face, along)} "
                             f"({len(self._cal.done)} of 12 done)")

    def _calibration_step(self) -> Effects[list[bytes]]:
        out: list[bytes] = []
        try:
            vectors = yield from self._raw_vectors()
            if vectors is None:
                raise UrcError("the magnetometer/accelerometer is gone")
            got = self._cal.feed(*vectors)
        except UrcError as exc:            # the sensor stopped answering
            return (yield from self._end_calibration(f"Calibration aborted: {exc}; nothing changed"))
        if got is None:
            return out
        out.append(codec.console(f"Point {len(self._cal.done)} of 12 done: "
                                 f"{codec.direction_text(*got)}"))
        try:
            fits = self._cal.fits()
        except CalibrationError:
            fits = None                    # not enough directions for the ellipsoids yet
        if fits is not None:
            shown = codec.calibration_rows(*fits)
            if shown != self._cal_shown:   # as the original: only when the data changes
                self._cal_shown = shown
                out += [codec.console(row) for row in shown]
        out.append(self._next_prompt())
        return out

    def _save_calibration(self) -> Effects[list[bytes]]:
        try:
            # (loaded, the hold is released with it: one round trip)
            on_disk = yield ApplyTwelveDirection(self._cal.result(), release=CALIBRATION_HOLD)
        except (CalibrationError, UrcError, ValueError) as exc:
            bad_input.info("calibration not saved: %s", exc)
            return [codec.console(f"Error: calibration not saved: {exc}; nothing changed")]
        self.mode = "tracking"
        rows = codec.calibration_rows(*self._cal.fits())
        if not on_disk:
            rows.append("Warning: the state file could not be written; the calibration "
                        "is in use but not yet kept across a restart")
        return [codec.console(row) for row in rows] + [codec.console(
            "Calibration saved: put the sensor back on the boom, then r to reset")]

    def _end_calibration(self, text: str) -> Effects[list[bytes]]:
        yield from self._hold(False)
        self.mode = "tracking"
        return [codec.console(text)]

    def _hold(self, held: bool) -> Effects[None]:
        """Take or release the local-control hold (a rotator without one: nothing)."""
        if getattr(self.rotator, "hold_local", None) is not None:
            yield HoldLocal(CALIBRATION_HOLD, held)

    def disconnected(self) -> Effects[None]:
        """The client went away (TCP closed, serial port hung up): a calibration under
        way ends unsaved and its hold is released."""
        if self.mode == "calibrating":
            yield from self._end_calibration("")
            log.info("calibration abandoned by a disconnect: nothing changed")

    def _letter_d(self, cmd: SarcnetCommand) -> list[bytes]:
        st = self.rotator.status()
        self._demo = [signed180(st.az_deg), wire_el_deg(st)]
        self._demo_next = 0
        self._demo_goto_s = -1e300
        self._enter("demonstrating")
        return [codec.console("Demo in progress: Press 'a' to abort")]

    def _letter_a(self, cmd: SarcnetCommand) -> Effects[list[bytes]]:
        if self.mode == "calibrating":
            return (yield from self._end_calibration("Calibration aborted: nothing changed"))
        if self.mode == "demonstrating":
            yield Stop()
        self.mode, self._held = "tracking", None
        return [codec.console("Function aborted")]

    def _letter_e(self, cmd: SarcnetCommand) -> Effects[list[bytes]]:
        no_compass = [codec.console("Error: this rotator has no magnetic compass")]
        if not cmd.text:
            cal = (yield SensorCalibrations())["az"]
            if "declination_deg" not in cal:
                return no_compass
            return [codec.console(f"Magnetic declination: {cal['declination_deg']:.1f}")]
        value = float(cmd.text)
        if not -90.0 <= value <= 90.0:
            return [codec.console(f"Error: declination {cmd.text} outside -90..90")]
        # the compass driver's setting, persisted with the rotator's calibration; the
        # rotator re-references by the change (refused if that breaks its limits)
        try:
            yield ApplyCalibration("az", {"declination_deg": value}, require=("declination_deg",))
        except NoSuchConstant:
            return no_compass
        return [codec.console(f"Magnetic declination: {value:.1f}")]

    def _letter_s(self, cmd: SarcnetCommand) -> Effects[list[bytes]]:
        if self.mode == "calibrating":
            return (yield from self._save_calibration())
        return [codec.console("Saved: urc keeps the declination and calibration as they change")]

    def _letter_p(self, cmd: SarcnetCommand) -> Effects[list[bytes]]:
        if self.mode != "pausing":
            yield Stop()
            self.mode, self._held = "pausing", None
            return [codec.console("Paused")]
        self.mode = "tracking"
        held, self._held = self._held, None
        if held is not None:
            try:
                yield from self._set(*held)
            except CommandRejected as exc:
                return [codec.console("Resumed"), codec.console(f"Error: {exc}")]
        return [codec.console("Resumed")]

    def _letter_h(self, cmd: SarcnetCommand) -> list[bytes]:
        return [b"".join(codec.console(row) for row in codec.HELP)]

    def _enter(self, mode: str) -> None:
        self.mode, self._held = mode, None
        self._next_s = self._last_s = None

    # ------------------------------------------------------------------ streams
    def _monitor_row(self, st: Status) -> bytes:
        az, el = signed180(st.az_deg), wire_el_deg(st)
        az_set = az if st.target_az_deg is None else signed180(st.target_az_deg)
        el_set = el if st.target_el_deg is None else st.target_el_deg
        az_windup = extended_pose_deg(st)[0]
        return codec.monitor_line(az, el, az_set, el_set, az_windup, not 0.0 <= az_windup < 360.0,
                                  signed180(az - az_set), el - el_set)

    def _demo_step(self, st: Status, now_s: float, dt: float) -> Effects[list[bytes]]:
        budget = DEMO_RATE_DEG_PER_S * dt
        for _ in range(len(DEMO_POINTS)):           # several points within one period
            target = DEMO_POINTS[self._demo_next]
            left = max(abs(t - v) for t, v in zip(target, self._demo))
            if left > budget:
                self._demo = [v + max(-budget, min(budget, t - v)) for t, v in zip(target, self._demo)]
                break
            self._demo, budget = list(target), budget - left
            self._demo_next = (self._demo_next + 1) % len(DEMO_POINTS)
        out = [codec.demo_line(*self._demo)]
        if now_s - self._demo_goto_s >= DEMO_GOTO_EVERY_S:
            self._demo_goto_s = now_s
            try:
                yield Goto(self._demo[0] % 360.0, self._demo[1])
            except CommandRejected as exc:
                self.mode = "tracking"
                out.append(codec.console(f"Demo stopped: {exc}"))
        return out


def calibration_rows(calibrations: dict[str, dict]) -> list[tuple[str, str]]:
    """(name, value text) of each sensor's calibration constants (numbers with %g, a
    matrix as its numbers comma separated)."""
    rows: list[tuple[str, str]] = []
    for axis, cal in calibrations.items():
        for key, value in sorted(cal.items()):
            values = value if isinstance(value, (list, tuple)) else [value]
            rows.append((f"{axis} {key}", ",".join(f"{float(v):g}" for v in values)))
    return rows
