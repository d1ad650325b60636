"""Two threads on one driver, at the pins: the control tick (``set_drive``) and
``Hardware.drive_safe`` from another thread (the tick watch, the power-fail callback, a
shutdown past a hung tick), in the interleavings a review found in the real drivers.

Each race is forced, not hoped for: a thread is held at a chosen pin write (a Gate), the
other runs while it waits, then it goes on. Where the fix makes the second thread wait
for the driver's lock, the test sees it ask for the lock (LockSpy) before it lets the
first go on, so the same script runs to the end with and without the fix. The verdict is
read from the pins: after the race the driver's remembered state matches them (or is
unknown), and one more ``set_drive(0)`` or ``drive_safe`` leaves them safe.
"""

from __future__ import annotations

import importlib.util
import json
import logging
import os
import subprocess
import sys
import textwrap
import threading
import types
from pathlib import Path

import pytest
from gpiozero import Device
from gpiozero.pins.mock import MockFactory, MockPWMPin

from urc.assembly import hardware_options, settings_from_config
from urc.clock import VirtualClock
from urc.config import Config, load_config
from urc.hardware import build_hardware
from urc.hardware.drivers.motors import (Bts7960Motor, Lmd18200Motor, RelayMotor, Vnh5019Motor,
                                         lmd18200_state, vnh5019_state)
from urc.hardware.gpio.pins import PinOut, PinPwm
from urc.hardware.gpio.pwm import HardwarePwm
from urc.hardware.interfaces import AxisHardware, Hardware

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
WAIT_S = 10.0


@pytest.fixture
def factory():
    f = MockFactory(pin_class=MockPWMPin)
    yield f
    f.close()


class Gate:
    """Holds the thread that reaches it until the test opens it."""

    def __init__(self) -> None:
        self.reached, self.opened = threading.Event(), threading.Event()

    def hold(self) -> None:
        self.reached.set()
        assert self.opened.wait(WAIT_S), "gate never opened"

    def open(self) -> None:
        self.opened.set()


def hold_at(part, method: str, gate: Gate, thread: str, value, *, after: bool = False) -> None:
    """Hold the thread named ``thread`` at its first ``part.method(value)``, before the
    write reaches the pin (or just after it)."""
    write = getattr(part, method)
    fired: list[bool] = []

    def held(v):
        mine = not fired and threading.current_thread().name == thread and v == value
        if mine:
            fired.append(True)
        if mine and not after:
            gate.hold()
        write(v)
        if mine and after:
            gate.hold()
    setattr(part, method, held)


class LockSpy:
    """Stands in for a driver's lock and tells when the tick thread asks for it (while
    the other thread holds it, the tick then waits). Unused by a driver without one."""

    def __init__(self, lock, asked: threading.Event):
        self.lock, self.asked = lock, asked

    def acquire(self, blocking: bool = True, timeout: float = -1) -> bool:
        if threading.current_thread().name == "tick":
            self.asked.set()
        return self.lock.acquire(blocking, timeout)

    def release(self) -> None:
        self.lock.release()

    def __enter__(self):
        self.acquire()
        return self

    def __exit__(self, *exc) -> None:
        self.release()


def spy_lock(driver, asked: threading.Event) -> None:
    driver._lock = LockSpy(getattr(driver, "_lock", None) or threading.Lock(), asked)


class Run:
    """``fn`` on a thread of that name; ``join`` re-raises what it raised. ``done`` is
    set when it ends."""

    def __init__(self, name: str, fn, done: threading.Event | None = None):
        self.done = done or threading.Event()
        self.error: BaseException | None = None

        def body() -> None:
            try:
                fn()
            except BaseException as exc:  # (re-raised in the test's thread)
                self.error = exc
            finally:
                self.done.set()
        self.thread = threading.Thread(target=body, name=name, daemon=True)
        self.thread.start()

    def join(self) -> None:
        self.thread.join(WAIT_S)
        assert not self.thread.is_alive(), f"{self.thread.name} did not finish"
        if self.error is not None:
            raise self.error


def one_axis(motor) -> Hardware:
    return Hardware("gpio", AxisHardware(motor=motor, sensor=None), None)


# ------------------------------------------------------------------ 1. LMD18200


def test_lmd18200_drive_safe_against_a_tick_never_leaves_it_driving_while_it_thinks_it_brakes(factory):
    """The watch (off) sees ``_braking`` False, writes PWM 0 and BRAKE high and is held
    before PWM 1.0; the tick (+0.3) writes PWM 0, DIR, BRAKE low, PWM 0.3; the watch
    writes PWM 1.0 and notes braking. Unfixed: BRAKE low + PWM 100 % = full drive, and
    every later off returns early without writing a pin."""
    pwm, dir_, brake = PinPwm(factory, 12), PinOut(factory, 5), PinOut(factory, 6)
    m = Lmd18200Motor("az", pwm, dir_, brake)
    hw = one_axis(m)

    def state():
        return lmd18200_state(pwm.read_back() > 0.0, dir_.read_back(), brake.read_back())

    def brake_pins():
        return brake.read_back() and pwm.read_back() == 1.0

    m.set_drive(0.3)                                    # driving when the watch fires
    gate, tick_on = Gate(), threading.Event()
    hold_at(pwm, "write_duty", gate, "watch", 1.0)
    spy_lock(m, tick_on)
    watch = Run("watch", hw.drive_safe)
    assert gate.reached.wait(WAIT_S)
    assert (pwm.read_back(), brake.read_back()) == (0.0, True)    # PWM 0, BRAKE high written
    tick = Run("tick", lambda: m.set_drive(0.3), tick_on)
    assert tick_on.wait(WAIT_S)                         # ran through, or waits for the lock
    gate.open()
    watch.join()
    tick.join()
    assert m._braking == brake_pins(), (state(), m._braking)      # remembered = the pins
    m.set_drive(0.0)                                    # the next tick
    assert state() == "brake" and brake_pins() and m._braking
    m.set_drive(0.3)
    hw.drive_safe()
    assert state() == "brake" and brake_pins()


# ------------------------------------------------------------------ 2. VNH5019


def test_vnh5019_reversal_against_drive_safe_is_undone_by_the_next_off(factory, caplog):
    """From reverse, the tick reverses to +0.4 (held after its PWM 0) while the watch
    writes off: PWM 0, INA 0, INB 0 (held); the tick writes INA 1, INB 0, PWM 0.4; the
    watch writes PWM 1.0. The pins are INA 1, INB 0, PWM 100 %. Unfixed the driver
    notes direction 0, so every later off rewrites only PWM 1.0: full drive for good.
    Fixed, the watch could not get the driver (the tick holds it), wrote the pattern
    anyway and left the direction unknown: the next off writes every pin."""
    ina, inb, pwm = PinOut(factory, 20), PinOut(factory, 21), PinPwm(factory, 13)
    m = Vnh5019Motor("el", ina, inb, pwm)
    hw = one_axis(m)
    m.set_drive(-0.4)
    tick_gate, watch_gate = Gate(), Gate()
    hold_at(pwm, "write_duty", tick_gate, "tick", 0.0, after=True)
    hold_at(inb, "write", watch_gate, "watch", False, after=True)
    with caplog.at_level(logging.WARNING):
        tick = Run("tick", lambda: m.set_drive(0.4))
        assert tick_gate.reached.wait(WAIT_S)
        watch = Run("watch", hw.drive_safe)
        assert watch_gate.reached.wait(WAIT_S)
        tick_gate.open()
        tick.join()
        watch_gate.open()
        watch.join()
    pins_dir = int(ina.read_back()) - int(inb.read_back())
    assert m._dir in (None, pins_dir), (m._dir, ina.read_back(), inb.read_back(), pwm.read_back())
    m.set_drive(0.0)                                    # the next tick
    assert vnh5019_state(ina.read_back(), inb.read_back(), pwm.read_back() > 0.0) == "brake"
    assert (ina.read_back(), inb.read_back(), pwm.read_back(), m._dir) == (False, False, 1.0, 0)
    assert "el motor off: written without the driver's lock" in caplog.text


# ------------------------------------------------------------------ 3. hardware PWM duty cache


class SysfsPwm:
    """rpi_hardware_pwm.HardwarePWM (0.3.1) on a channel, as sysfs is left: ``start`` =
    duty then enable 1, ``stop`` = duty 0 then enable 0, ``change_duty_cycle`` = duty."""

    made: list["SysfsPwm"] = []

    def __init__(self, pwm_channel: int, hz: float, chip: int = 0):
        self.channel, self.duty_pct, self.enabled = pwm_channel, 0.0, False
        self.made.append(self)

    def start(self, duty_pct: float) -> None:
        self.change_duty_cycle(duty_pct)
        self.enabled = True

    def stop(self) -> None:
        self.change_duty_cycle(0)
        self.enabled = False

    def change_duty_cycle(self, duty_pct: float) -> None:
        self.duty_pct = duty_pct

    def level(self) -> float:
        """The duty the pin makes (a disabled channel idles low)."""
        return self.duty_pct / 100.0 if self.enabled else 0.0


class NotedDuty:
    """The BTS7960 current sense as the driver sees it: told each duty."""

    def __init__(self) -> None:
        self.duty = 0.0

    def note_duty(self, duty: float) -> None:
        self.duty = duty

    def read_current_a(self) -> float:
        return 0.0


def test_hardware_pwm_duty_cache_never_hides_a_driven_pin(tmp_path):
    """BTS7960 on hardware PWM. The watch's duty-0 sysfs write lands and the watch is
    held before it notes it; the tick writes 0.5 and notes it; the watch notes 0.
    Unfixed: the pin makes 50 % while the part remembers 0, so every later duty 0 is
    skipped (and the current sense is told 0)."""
    def part(pin, ch):
        return HardwarePwm(pin, ch, frequency_hz=20_000.0, pwm_class=SysfsPwm, sys_pwm=tmp_path)
    r, l = part(12, 0), part(13, 1)
    sense = NotedDuty()
    m = Bts7960Motor("az", r, l, current=sense)
    hw = one_axis(m)
    m.set_drive(0.3)
    gate, tick_on = Gate(), threading.Event()
    hold_at(r.pwm, "change_duty_cycle", gate, "watch", 0.0, after=True)
    spy_lock(m, tick_on)
    watch = Run("watch", hw.drive_safe)
    assert gate.reached.wait(WAIT_S)
    assert r.pwm.level() == 0.0
    tick = Run("tick", lambda: m.set_drive(0.5), tick_on)
    assert tick_on.wait(WAIT_S)
    gate.open()
    watch.join()
    tick.join()
    for p in (r, l):                                    # remembered = what the channel makes
        assert p.read_back() == pytest.approx(p.pwm.level()), (p.channel, p.read_back(), p.pwm.level())
    assert sense.duty == pytest.approx(r.pwm.level())
    m.set_drive(0.0)                                    # the next tick
    assert (r.pwm.level(), l.pwm.level(), sense.duty) == (0.0, 0.0, 0.0)
    m.set_drive(0.5)
    hw.drive_safe()
    assert (r.pwm.level(), l.pwm.level(), sense.duty) == (0.0, 0.0, 0.0)


# ------------------------------------------------------------------ 5. writes after close


@pytest.fixture
def tartu_iron(monkeypatch, tmp_path):
    """The gpio backend's iron path (VNH5019 on hardware PWM, brake relays) on mock pins
    and the SysfsPwm channels; no ADC (no SPI device here)."""
    f = MockFactory(pin_class=MockPWMPin)
    monkeypatch.setattr(Device, "pin_factory", f)
    SysfsPwm.made = []
    monkeypatch.setitem(sys.modules, "rpi_hardware_pwm", types.SimpleNamespace(HardwarePWM=SysfsPwm))
    data = load_config(EXAMPLES / "tartu-urc.toml").to_dict()
    for a in ("az", "el"):
        del data["hardware"]["gpio"][a]["adc"], data["hardware"]["gpio"][a]["current_sense_channel"]
    cfg = Config.from_dict(data)
    yield build_hardware("gpio", settings_from_config(cfg).caps, VirtualClock(1000.0), tmp_path,
                         hardware_options(cfg))
    f.close()


def test_a_hung_tick_resuming_after_shutdown_drives_nothing(tartu_iron, caplog):
    """The control process' shutdown with a hung tick: the tick is held in a reversal
    (PWM 0 written, INA not yet) while drive_safe and close run; then it goes on, and
    ticks once more. Unfixed: close left the direction 'neither', the closed hardware
    channel restarts at the next duty: INA 1, INB 0, PWM 50 % after exit."""
    hw = tartu_iron
    m = hw.az.motor
    assert isinstance(m.pwm, HardwarePwm)
    channel = m.pwm.pwm
    m.set_drive(-0.4)
    hw.az.brake.set_released(True)
    gate = Gate()
    hold_at(m.ina, "write", gate, "tick", True)
    with caplog.at_level(logging.WARNING):
        tick = Run("tick", lambda: m.set_drive(0.5))
        assert gate.reached.wait(WAIT_S)
        hw.drive_safe()                                 # _shutdown, the tick hung
        hw.close()
        gate.open()
        tick.join()
        Run("tick", lambda: m.set_drive(0.5)).join()    # and it ticks again before the exit

    def held():
        return m.ina.read_back(), m.inb.read_back(), channel.level(), channel.enabled
    assert held() == (True, True, 0.0, False), held()   # brake to VCC, channel off
    assert vnh5019_state(m.ina.read_back(), m.inb.read_back(), False) == "brake"
    assert hw.az.brake.coil.read_back() is False
    assert "refused: the driver is closed" in caplog.text
    hw.drive_safe()                                     # a later drive_safe keeps the hold
    assert held() == (True, True, 0.0, False)


def test_closed_pwm_parts_and_relays_never_drive_again(factory, tmp_path):
    """After close/stop: a hardware channel is not restarted, a software PWM pin not set
    (lgpio would take the duty as a plain high level: next test), relays stay off."""
    hp = HardwarePwm(12, 0, frequency_hz=20_000.0, pwm_class=SysfsPwm, sys_pwm=tmp_path)
    hp.write_duty(0.4)
    hp.close()
    hp.write_duty(0.4)
    assert (hp.pwm.level(), hp.pwm.enabled, hp.read_back()) == (0.0, False, 0.0)
    hp.force_duty(1.0)                                  # (drive_safe's way past the cache)
    assert (hp.pwm.level(), hp.pwm.enabled, hp.read_back()) == (0.0, False, 0.0)
    sw = PinPwm(factory, 13)
    sw.write_duty(0.4)
    sw.stop()
    sw.write_duty(0.4)
    assert sw.read_back() == 0.0 and sw.pin.frequency is None
    cw, ccw = PinOut(factory, 22), PinOut(factory, 23)
    rm = RelayMotor("az", cw, ccw, VirtualClock())
    rm.set_drive(1.0)
    rm.close()
    rm.set_drive(1.0)
    rm.set_drive(-1.0)
    assert (cw.read_back(), ccw.read_back()) == (False, False)


LGPIO_PRELUDE = textwrap.dedent('''
    import json, threading
    import lgpio
    from gpiozero.pins.lgpio import LGPIOFactory

    calls, level, pwm = [], {}, {}          # what lgpio was told; the pin as it then is
    lgpio.gpiochip_open = lambda chip: 0
    for name in ("gpio_claim_input", "gpio_free", "gpiochip_close"):
        setattr(lgpio, name, lambda *a, **k: 0)
    mode = {}
    def claim_out(h, g, level_=0, lFlags=0):
        mode[g] = 2
        level[g] = level_
    def write(h, g, v):
        calls.append(["write", g, int(v)])
        level[g] = int(v)
    hooks = {}
    def tx_pwm(h, g, f, d, *a):
        hook = hooks.get((threading.current_thread().name, d))
        if hook:
            hook()
        calls.append(["tx_pwm", g, f, d])
        pwm[g] = (f, d) if f else None      # lgpio: frequency 0 ends the PWM
        return 0
    lgpio.gpio_claim_output = claim_out
    lgpio.gpio_get_mode = lambda h, g: mode.get(g, 0)
    lgpio.gpio_write = write
    lgpio.tx_pwm = tx_pwm
    LGPIOFactory._get_revision = lambda self: 0xC03111          # a Pi 4 B
    factory = LGPIOFactory(chip=0)
    from urc.hardware.gpio.pins import PinPwm
    p = PinPwm(factory, 12, frequency_hz=1000)
    out = {}
''')


def run_lgpio(tmp_path: Path, body: str) -> dict:
    script = LGPIO_PRELUDE + textwrap.dedent(body) + "\nprint(json.dumps(out))\n"
    env = dict(os.environ)
    env.pop("LG_WD", None)
    r = subprocess.run([sys.executable, "-c", script], cwd=tmp_path, env=env, capture_output=True,
                       text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    return json.loads(r.stdout.strip().splitlines()[-1])


needs_lgpio = pytest.mark.skipif(importlib.util.find_spec("lgpio") is None, reason="lgpio not installed")


@needs_lgpio
def test_software_pwm_after_stop_is_never_set_high_on_lgpio(tmp_path):
    """gpiozero's LGPIOPin: with its PWM stopped (frequency None) a state is a plain
    gpio_write(bool(state)): duty 0.4 would be the pin high, 100 %."""
    out = run_lgpio(tmp_path, '''
        p.write_duty(0.4)
        p.stop()
        n = len(calls)
        p.write_duty(0.4)
        out["after"], out["level"], out["pwm"] = calls[n:], level.get(12), pwm.get(12)
    ''')
    assert out == {"after": [], "level": 0, "pwm": None}


@needs_lgpio
def test_software_pwm_stopped_in_the_middle_of_a_write_ends_stopped_on_lgpio(tmp_path):
    """A write under way (gpiozero has noted duty 40 but lgpio not yet been told) while
    another thread stops the pin: lgpio is told 40 % after the stop. The pin must end
    with no PWM and low."""
    out = run_lgpio(tmp_path, '''
        p.write_duty(0.2)
        reached, go = threading.Event(), threading.Event()
        hooks[("tick", 40)] = lambda: (reached.set(), go.wait(10))
        t = threading.Thread(target=lambda: p.write_duty(0.4), name="tick")
        t.start()
        reached.wait(10)
        p.stop()                                 # close, from the shutdown's thread
        go.set()
        t.join(10)
        out["level"], out["pwm"], out["tail"] = level.get(12), pwm.get(12), calls[-3:]
    ''')
    assert out["pwm"] is None and out["level"] == 0, out


# ------------------------------------------------------------------ 6. relay dead time


class FrozenClock:
    def __init__(self, t: float = 100.0):
        self.t = t

    def now_s(self) -> float:
        return self.t


def test_relay_reversal_dead_time_counts_from_the_real_off(factory):
    """The tick reads the clock, then freezes 10 s (SIGSTOP) before it writes the CW
    coil off. Unfixed, the dead time counted from the clock read: CCW came on 20 ms
    after CW went off. CCW must stay off for the whole dead time after the real off."""
    clock = FrozenClock()
    cw, ccw = PinOut(factory, 22), PinOut(factory, 23)
    m = RelayMotor("az", cw, ccw, clock, reverse_dead_time_s=0.5)
    m.set_drive(1.0)
    clock.t += 1.0
    write_cw = cw.write
    off_at: list[float] = []

    def frozen_before_off(value: bool) -> None:
        if not value and not off_at:
            clock.t += 10.0                             # the freeze, between clock read and write
            off_at.append(clock.t)
        write_cw(value)
    cw.write = frozen_before_off
    m.set_drive(-1.0)                                   # reversal: CW off, dead time starts
    assert off_at and (cw.read_back(), ccw.read_back()) == (False, False)
    on_at = None
    for _ in range(100):                                # ticks every 20 ms
        clock.t += 0.02
        m.set_drive(-1.0)
        assert not (cw.read_back() and ccw.read_back())
        if ccw.read_back():
            on_at = clock.t
            break
    assert on_at is not None and on_at - off_at[0] >= 0.5 - 1e-9, (on_at, off_at)
    assert on_at - off_at[0] < 0.5 + 0.03                # and not much longer
