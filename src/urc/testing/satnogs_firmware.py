"""An emulation of the SatNOGS rotator controller firmware (stepper_motor_controller),
written from what its source says, for tests and benchmarks; served on a pty.

Facts used, each from the firmware's source (the GitHub mirror
pschneiders/satnogs-rotator-firmware, commit 02bc016, the last upstream commit there,
2018-10-08; "ino" is stepper_motor_controller/stepper_motor_controller.ino, the headers are
under libraries/). No code of it is copied; this is a model of its behaviour.

Mechanics
* ino:26-31: gear ratio 54, 1/8 microstep, 1600 steps per motor turn (with the
  microstep), top speed 3200 steps/s, acceleration 1600 steps/s^2. So 240 steps per
  degree of the axis (deg2step, ino:211-213): 13.33 deg/s, 6.67 deg/s^2, a step is
  1/240 deg. Both axes alike (ino:68-78).
* ino:32-35: az 0..360, el 0..180; used only as the homing seek (ino:105-106): a target
  sent is not clamped (ino:118-119).
* ino:96-97, 224-226: the position it reports is the step count in degrees (not modulo).

Homing
* ino:101-115: with the homing flag down (at power-up, globals.h:58; after RESET,
  easycomm.h:156) and no error, the loop calls homing() before anything else.
* ino:154-200: both axes seek towards -360 / -180 deg (absolute step targets) at full
  speed; an endstop found: that axis is sent back to where it was found (the stepper
  brakes past it and returns); an axis that reaches its seek target first is a homing
  error (ino:178-181). Then HOME_DELAY (12 s, ino:37) more of motion, then both counts
  and setpoints are zero. The whole time easycomm_proc is not called: no command is
  read or answered (the Arduino's 64-byte receive buffer holds what arrives;
  HardwareSerial's SERIAL_RX_BUFFER_SIZE, the Arduino AVR core, not the firmware).
* endstop.h:45-50, ino:36: a switch reads "found" at its DEFAULT_HOME_STATE level.

Errors and the watchdog
* globals.h:16-23: status idle 1, moving 2, pointing 4, error 8; error none 1, sensor
  2, homing 4, motor 8, over temperature 12, watchdog 16.
* ino:120-127: while a target is not reached the status is pointing (4), then idle (1);
  "moving" is never set by the stepper firmware.
* ino:129-139: in the error state the motors are stopped and disabled; an error other
  than the homing error is cleared on the next pass, the homing error stays: the loop
  never homes again (ino:100), so RESET cannot clear it, only a restart.
* watchdog.h:28-37: a 2 s watchdog (the comment's figure) in interrupt-then-reset mode,
  reset every loop pass (ino:86) and in the homing loops (ino:165, 189). It is no
  command-silence timeout: it fires only when the firmware itself hangs (``RST``,
  easycomm.h:366-370, a custom command that does exactly that). Then (watchdog.h:56-100)
  the motors are disabled, status 8 and error 16 are set and an endless loop answers
  only GS, GE and RB; RB there stops resetting the watchdog, which then restarts the MCU.
* easycomm.h:371-374: RB in normal running: the watchdog armed at 2 s, then a hang:
  the MCU restarts 2 s later, and homes (the homing flag is down after a restart).

Serial commands (easycomm.h:57-384; a line ends at \\n or \\r, every reply ends \\n)
* ``AZ EL`` (first five bytes) -> ``AZ<az> EL<el>``, one decimal each (String(x, 1)).
* other ``AZ...`` lines: set, ``atof`` of each token after its two letters when it has no
  letter in it (isNumber, easycomm.h:388-394), ``EL`` as the second token; ``EL...``
  alone sets the elevation. A bare ``AZ`` is atof("") = 0: a set to azimuth 0.
* ``VU VD VL VR``: a speed mode the stepper loop never reads.
* ``SA SE`` -> the position line, and the setpoints become the position (a stop).
* ``RESET`` -> the position line, then homing. ``PARK`` -> the position line, then the
  park setpoints (``CW7,<az>`` / ``CW8,<el>``, 0 by default, globals.h:59).
* ``VE`` -> ``VESatNOGS-v2.2``; ``IP0``..``IP8`` -> ``IPn,<value>``; ``GS`` -> ``GS<n>``,
  ``GE`` -> ``GE<n>``; ``CR <n>`` -> ``<n>,<value>`` (gains 8.00 0.00 0.50 / 10.00 0.00
  0.30 by default, globals.h:51-56; park; control mode). Anything else: no answer.
"""

from __future__ import annotations

import math
import os
import re
import threading
import time
import tty

STEPS_PER_DEG = 54 * 1600 / 360.0            # ino:26, 31, 211-213
MAX_SPEED_STEPS = 3200.0                       # ino:29
ACCEL_STEPS = 1600.0                           # ino:30
SEEK_DEG = (360.0, 180.0)                      # ino:33, 35, 105-106
HOME_DELAY_S = 12.0                            # ino:37
WATCHDOG_S = 2.0                               # watchdog.h:28
RX_BUFFER_BYTES = 64                           # Arduino AVR core HardwareSerial
LINE_BUFFER_BYTES = 256                        # easycomm.h:21
VERSION = b"SatNOGS-v2.2"                      # easycomm.h:172

IDLE, POINTING, ERROR = 1, 4, 8                # globals.h:17
NO_ERROR, HOMING_ERROR, WDT_ERROR = 1, 4, 16   # globals.h:21-22

_FLOAT_RE = re.compile(rb"\s*[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")


def _atof(text: bytes) -> float:
    """C's atof: the longest number at the start, 0 when there is none."""
    m = _FLOAT_RE.match(text)
    return float(m.group(0)) if m else 0.0


def _is_number(text: bytes) -> bool:
    """easycomm.h:388-394: no letter anywhere (an empty string passes)."""
    return not any(chr(c).isalpha() for c in text)


def _fmt(value: float, decimals: int) -> bytes:
    return f"{value:.{decimals}f}".encode()


class _Stepper:
    """One axis: a step count moved towards its target at AccelStepper's limits
    (top speed, constant acceleration, braking in time to stop on the target)."""

    def __init__(self, phys_deg: float):
        self.count = 0.0          # steps, the firmware's currentPosition()
        self.target = 0.0         # steps, moveTo()
        self.speed = 0.0          # steps/s, signed
        self.zero_deg = phys_deg  # where count 0 is, in the antenna's true angle
        self.enabled = True

    @property
    def phys_deg(self) -> float:
        return self.zero_deg + self.count / STEPS_PER_DEG

    def distance_to_go(self) -> float:
        return self.target - self.count

    def run(self, dt_s: float) -> None:
        if not self.enabled:
            self.speed = 0.0      # drivers disabled: no torque, it stops where it is
            return
        to_go = self.target - self.count
        if abs(to_go) < 0.5 and abs(self.speed) < ACCEL_STEPS * dt_s * 2:
            self.count, self.speed = self.target, 0.0
            return
        direction = math.copysign(1.0, to_go)
        brake_steps = self.speed * self.speed / (2.0 * ACCEL_STEPS)
        if self.speed * direction < 0 or abs(to_go) <= brake_steps:
            self.speed -= math.copysign(min(ACCEL_STEPS * dt_s, abs(self.speed)), self.speed)
        else:
            self.speed = direction * min(MAX_SPEED_STEPS, abs(self.speed) + ACCEL_STEPS * dt_s)
        self.count += self.speed * dt_s


class SatnogsFirmware:
    """The firmware's behaviour, sans I/O: :meth:`feed` bytes, :meth:`advance` time,
    :meth:`take_output` what it wrote. ``phys_deg``: the antenna's true angle per axis
    at power-up (its endstops are at 0); ``homed``: start as if a homing had just
    finished there (no boot homing); ``home_delay_s``: HOME_DELAY and ``seek_deg`` the
    homing seek, shorter in tests (a homing error then comes in seconds, not 30 s)."""

    def __init__(self, phys_deg: tuple[float, float] = (0.0, 0.0), homed: bool = True,
                 home_delay_s: float = HOME_DELAY_S, watchdog_s: float = WATCHDOG_S,
                 seek_deg: tuple[float, float] = SEEK_DEG):
        self.home_delay_s, self.watchdog_s, self.seek_deg = home_delay_s, watchdog_s, seek_deg
        self.axes = (_Stepper(phys_deg[0]), _Stepper(phys_deg[1]))
        self.broken_endstop = [False, False]
        self.received = b""
        self.homings = 0
        self._out = bytearray()
        self._boot()
        if homed:   # (its counts already true: zero at the endstops)
            self.homing_flag = True
            for i, ax in enumerate(self.axes):
                ax.zero_deg, ax.count = 0.0, phys_deg[i] * STEPS_PER_DEG
                ax.target, self.setpoint[i] = ax.count, phys_deg[i]

    # ------------------------------------------------------------- state
    def _boot(self) -> None:
        """Power-up or restart: counts zero where the antenna is, homing flag down."""
        for ax in self.axes:
            ax.zero_deg, ax.count, ax.target, ax.speed, ax.enabled = ax.phys_deg, 0.0, 0.0, 0.0, True
        self.state = "run"           # run | homing | hung | wdt | rebooting
        self.status, self.error = IDLE, NO_ERROR
        self.homing_flag = False
        self.setpoint = [0.0, 0.0]
        self.park = [0.0, 0.0]
        self.gains = [8.0, 0.0, 0.5, 10.0, 0.0, 0.3]
        self.control_mode = 0
        self._rx = bytearray()       # the UART's receive buffer
        self._line = bytearray()     # easycomm_proc's line buffer
        self._wdt_line = bytearray()  # the watchdog interrupt's own
        self._timer_s = 0.0
        self._homing_phase = ""
        self._found = [False, False]

    def break_endstop(self, axis: str, broken: bool = True) -> None:
        """An endstop that never reads "found" (a broken wire): the next homing fails."""
        self.broken_endstop["azel".index(axis) // 2] = broken

    def endstop(self, i: int) -> bool:
        """The switch reads found at and below the axis' true zero (endstop.h:45-50)."""
        return not self.broken_endstop[i] and self.axes[i].phys_deg <= 0.0

    def position_deg(self) -> tuple[float, float]:
        """What it reports: the step counts in degrees (ino:96-97)."""
        return self.axes[0].count / STEPS_PER_DEG, self.axes[1].count / STEPS_PER_DEG

    def true_deg(self) -> tuple[float, float]:
        return self.axes[0].phys_deg, self.axes[1].phys_deg

    # ------------------------------------------------------------- serial
    def feed(self, data: bytes) -> None:
        self.received += data
        room = RX_BUFFER_BYTES - len(self._rx)
        self._rx += data[:max(0, room)]   # (beyond it, bytes are lost)
        self._serve()

    def take_output(self) -> bytes:
        out, self._out = bytes(self._out), bytearray()
        return out

    def _serve(self) -> None:
        """Read the receive buffer where the firmware reads it now."""
        if self.state == "run":
            self._read_lines(self._line, self._command)
        elif self.state == "wdt":
            self._read_lines(self._wdt_line, self._wdt_command)

    def _read_lines(self, buf: bytearray, handle) -> None:
        while self._rx and self.state in ("run", "wdt"):
            c = self._rx.pop(0)
            if c in b"\r\n":
                handle(bytes(buf))
                buf.clear()
            elif len(buf) < LINE_BUFFER_BYTES:
                buf.append(c)

    def _position_line(self) -> bytes:
        az, el = self.position_deg()
        return b"AZ" + _fmt(az, 1) + b" EL" + _fmt(el, 1) + b"\n"

    def _command(self, line: bytes) -> None:   # noqa: C901 (one branch per command, as the firmware)
        out = self._out
        if line[:2] == b"AZ":
            if line[2:5] == b" EL":
                out += self._position_line()
                return
            self.control_mode = 0
            tokens = line.split(b" ")
            if _is_number(tokens[0][2:12]):
                self.setpoint[0] = _atof(tokens[0][2:12])
            if len(tokens) > 1 and tokens[1][:2] == b"EL" and _is_number(tokens[1][2:12]):
                self.setpoint[1] = _atof(tokens[1][2:12])
        elif line[:2] == b"EL":
            self.control_mode = 0
            token = line.split(b" ")[0]
            if _is_number(token[2:12]):
                self.setpoint[1] = _atof(token[2:12])
        elif line[:2] in (b"VU", b"VD", b"VL", b"VR"):
            self.control_mode = 1          # never read by the stepper loop
        elif line[:5] == b"SA SE":
            out += self._position_line()
            self.control_mode = 0
            self.setpoint = list(self.position_deg())
        elif line[:5] == b"RESET":
            out += self._position_line()
            self.homing_flag = False
        elif line[:4] == b"PARK":
            out += self._position_line()
            self.control_mode = 0
            self.setpoint = list(self.park)
        elif line[:2] == b"VE":
            out += b"VE" + VERSION + b"\n"
        elif line[:2] == b"IP" and line[2:3].isdigit() and line[2:3] != b"9":
            k = int(line[2:3])
            values = [b"0", b"%d" % self.endstop(0), b"%d" % self.endstop(1), _fmt(self.position_deg()[0], 2),
                      _fmt(self.position_deg()[1], 2), b"0", b"0", b"0.00", b"0.00"]
            out += b"IP%d," % k + values[k] + b"\n"
        elif line[:2] == b"GS":
            out += b"GS%d\n" % self.status
        elif line[:2] == b"GE":
            out += b"GE%d\n" % self.error
        elif line[:2] == b"CR":
            reg = line[3:4]
            if reg.isdigit() and reg != b"0":
                k = int(reg)
                value = _fmt(self.gains[k - 1], 2) if k <= 6 else _fmt(self.park[k - 7], 2) if k <= 8 \
                    else b"%d" % self.control_mode
                out += reg + b"," + value + b"\n"
        elif line[:2] == b"CW":
            reg = line[2:3]
            value = line.split(b",", 1)[1][:10] if b"," in line else b""
            if reg.isdigit() and 1 <= int(reg) <= 8 and _is_number(value):
                k = int(reg)
                if k <= 6:
                    self.gains[k - 1] = _atof(value)
                else:
                    self.park[k - 7] = _atof(value)
        elif line[:3] == b"RST":
            self.state, self._timer_s = "hung", 0.0
        elif line[:2] == b"RB":
            self.state, self._timer_s = "rebooting", 0.0

    def _wdt_command(self, line: bytes) -> None:
        if line[:2] == b"GS":
            self._out += b"GS%d\n" % self.status
        elif line[:2] == b"GE":
            self._out += b"GE%d\n" % self.error
        elif line[:2] == b"RB":
            self.state, self._timer_s = "rebooting", 0.0

    # ------------------------------------------------------------- time
    def advance(self, dt_s: float, step_s: float = 0.002) -> None:
        while dt_s > 1e-12:
            h = min(step_s, dt_s)
            self._tick(h)
            dt_s -= h

    def _tick(self, h: float) -> None:
        self._timer_s += h
        if self.state in ("hung", "rebooting"):
            if self._timer_s >= self.watchdog_s:
                if self.state == "hung":       # the watchdog interrupt takes over
                    for ax in self.axes:
                        ax.enabled = False
                    self.state, self.status, self.error = "wdt", ERROR, WDT_ERROR
                    self._serve()
                else:
                    self._boot()
            return
        if self.state == "wdt":
            return
        if self.state == "homing":
            self._homing_tick(h)
            return
        self._serve()
        if self.status == ERROR:
            for ax in self.axes:
                ax.enabled = False
            if self.error != HOMING_ERROR:
                self.status, self.error = IDLE, NO_ERROR
            return
        if not self.homing_flag:
            self._start_homing()
            return
        for i, ax in enumerate(self.axes):
            ax.target = float(int(self.setpoint[i] * STEPS_PER_DEG))   # deg2step truncates
            ax.run(h)
        pointing = any(ax.distance_to_go() != 0 for ax in self.axes)
        self.status = POINTING if pointing else IDLE

    def _start_homing(self) -> None:
        self.state, self._homing_phase, self._found = "homing", "seek", [False, False]
        self.homings += 1
        for i, ax in enumerate(self.axes):
            ax.enabled = True
            ax.target = -self.seek_deg[i] * STEPS_PER_DEG

    def _homing_tick(self, h: float) -> None:
        axes = self.axes
        if self._homing_phase == "seek":
            for i, ax in enumerate(axes):
                if not self._found[i] and self.endstop(i):
                    ax.target, self._found[i] = float(round(ax.count)), True
            for i, ax in enumerate(axes):
                if not self._found[i] and ax.distance_to_go() == 0:
                    self.state, self.status, self.error = "run", ERROR, HOMING_ERROR
                    return
            if all(self._found):
                self._homing_phase, self._timer_s = "delay", 0.0
        elif self._timer_s >= self.home_delay_s:
            for ax in axes:   # (setCurrentPosition also zeroes the speed)
                ax.zero_deg, ax.count, ax.target, ax.speed = ax.phys_deg, 0.0, 0.0, 0.0
            self.setpoint = [0.0, 0.0]
            self.state, self.status, self.error, self.homing_flag = "run", IDLE, NO_ERROR, True
            return
        for ax in axes:
            ax.run(h)


class SatnogsOnPty:
    """:class:`SatnogsFirmware` on a pseudo-terminal (symlinked at ``link``), in real
    time on a thread of its own. ``with fw.lock:`` to look at or change it."""

    def __init__(self, link: str, **firmware_args):
        self.fw = SatnogsFirmware(**firmware_args)
        self.lock = threading.Lock()
        self.master, self.slave = os.openpty()
        tty.setraw(self.slave)
        self.link = link
        os.symlink(os.ttyname(self.slave), link)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="satnogs-fw", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        os.set_blocking(self.master, False)
        last = time.monotonic()
        while not self._stop.is_set():
            try:
                data = os.read(self.master, 256)
            except (BlockingIOError, OSError):
                data = b""
            now = time.monotonic()
            with self.lock:
                self.fw.advance(now - last)
                if data:
                    self.fw.feed(data)
                out = self.fw.take_output()
            last = now
            if out:
                try:
                    os.write(self.master, out)
                except OSError:
                    pass
            if not data:
                time.sleep(0.002)

    def close(self) -> None:
        self._stop.set()
        self._thread.join(2.0)
        for fd in (self.master, self.slave):
            try:
                os.close(fd)
            except OSError:
                pass
        try:
            os.unlink(self.link)
        except OSError:
            pass
