"""The step/dir review's defects (review of the new hardware code): stopping a stepper
at rest on lg, the halt racing a drive, the AS5600 check's tolerance, lg's start delay."""

from __future__ import annotations

import sys
import types

import pytest
from gpiozero.pins.mock import MockFactory

from urc.caps import SensorCaps
from urc.clock import VirtualClock
from urc.hardware.drivers.stepper import ENVELOPE_ACCEL_FACTOR, StepCountSensor, StepDirMotor
from urc.hardware.gpio.emulate_stepdir import LG_BAD_PWM_MICROS, EmulatedStepDirChip, EmulatedTxQueue, LgError
from urc.hardware.gpio.pins import PinOut
from urc.hardware.gpio.stepdir import LG_ERROR_TEXT, LG_TX_BUF, STEPDIR_CHIPS, LgpioStepPulses, lg_error_code
from urc.hardware.sim.stepper import StepperAxis, satnogs_v3_stepper
from urc.profiles import PROFILES

SATNOGS = PROFILES["satnogs-v3"].az


class FakeLg(types.ModuleType):
    """lgpio's calls the pulse train makes, with xSetAsPwm's rule for (0, 0)
    (joan2937/lg lgGpio.c): a stop with no train running is LG_BAD_PWM_MICROS, raised."""

    TX_PWM = 0

    class error(Exception):
        pass

    def __init__(self):
        super().__init__("lgpio")
        self.running = False
        self.writes: list[tuple[int, int]] = []

    def gpio_claim_output(self, h, g, level):
        return 0

    def tx_busy(self, h, g, kind):
        return int(self.running)

    def tx_pulse(self, h, g, on, off, offset, cycles):
        if not on and not off:
            if not self.running:
                raise self.error("bad PWM micros")      # lg: -86
            self.running = False
            return 0
        self.running = True
        return 9

    def gpio_write(self, h, g, level):
        self.writes.append((g, level))
        return 0


def test_lg_cut_at_rest_does_not_raise_and_leaves_the_pin_low(monkeypatch):
    lg = FakeLg()
    monkeypatch.setitem(sys.modules, "lgpio", lg)
    pulses = LgpioStepPulses(types.SimpleNamespace(_handle=1), 17)
    pulses.cut()                                   # at rest: lg would say -86
    assert lg.writes == [(17, 0)]
    pulses.queue(156, 156, 10)
    pulses.cut()                                   # running: stopped, then low
    assert not lg.running and lg.writes[-1] == (17, 0)


def test_the_emulated_queue_refuses_a_stop_at_rest_as_lg_does():
    clock = VirtualClock()
    q = EmulatedTxQueue(clock.now_s, lambda *a: None)
    assert LG_BAD_PWM_MICROS == -86                # lgpio.h:2960
    with pytest.raises(LgError) as err:
        q.tx_pulse(0, 0, 0)
    assert err.value.value == "bad PWM micros"    # the text only, as lgpio.error
    assert lg_error_code(err.value) == -86
    q.cut()                                        # the driver's cut asks only while busy
    assert q.queue(156, 156, 5) == 9 and q.busy()
    q.cut()
    assert not q.busy() and q.cuts == 1


class Rig:
    def __init__(self, queue_cls=EmulatedTxQueue, check=None, microsteps=8, steps_per_deg=240.0):
        self.clock = VirtualClock()
        self.factory = MockFactory()
        self.dir_out = PinOut(self.factory, 20)
        self.en_out = PinOut(self.factory, 21, active_low=True)
        self.axis = StepperAxis(satnogs_v3_stepper(), 0.0)
        self.chip = EmulatedStepDirChip(STEPDIR_CHIPS["a4988"], self.axis, self.dir_out.pin, self.en_out.pin)
        self.queue = queue_cls(self.clock.now_s, self.chip.on_pulses)
        self.motor = StepDirMotor("az", STEPDIR_CHIPS["a4988"], self.queue, self.dir_out, self.en_out,
                                  self.clock.now_s, steps_per_deg=steps_per_deg,
                                  max_rate_deg_per_s=SATNOGS.max_rate_deg_per_s,
                                  max_accel_deg_per_s2=ENVELOPE_ACCEL_FACTOR * SATNOGS.accel_deg_per_s2)

    def run(self, duty, seconds, dt=0.02):
        for _ in range(round(seconds / dt)):
            self.motor.set_drive(duty)
            self.clock.advance(dt)
            self.queue.advance()


class CutRaises(EmulatedTxQueue):
    """A cut that fails (lg's -86 as the old cut met it at rest)."""

    def cut(self):
        raise LgError("bad PWM micros")


def test_force_safe_disables_the_chip_even_when_the_cut_raises():
    rig = Rig(CutRaises)
    rig.run(0.0, 0.2)
    assert rig.en_out.read_back()
    with pytest.raises(LgError):
        rig.motor.force_safe()
    assert not rig.en_out.read_back()              # ENABLE off all the same
    assert rig.motor.rate_sps == 0.0 and rig.motor.duty == 0.0
    with pytest.raises(LgError):
        rig.motor.close()
    assert rig.motor.closed


class HaltDuringQueue(EmulatedTxQueue):
    """force_safe arriving while set_drive holds the lock, inside tx_pulse: it waits its
    10 ms for the lock, then cuts without it (the tick thread is still in set_drive)."""

    motor: StepDirMotor | None = None
    halt_at: str = ""

    def tx_pulse(self, high_us, low_us, cycles):
        if self.motor is not None and high_us and self.halt_at == "before":
            self.halt_at = ""
            self.motor.force_safe()
        left = super().tx_pulse(high_us, low_us, cycles)
        if self.motor is not None and high_us and self.halt_at == "after":
            self.halt_at = ""
            self.motor.force_safe()
        return left


@pytest.mark.parametrize("when", ["before", "after"])
def test_a_halt_racing_a_drive_leaves_no_pulse_queued_after_its_cut(when):
    rig = Rig(HaltDuringQueue)
    rig.run(0.5, 1.0)                              # moving
    rig.queue.motor, rig.queue.halt_at = rig.motor, when
    rig.motor.set_drive(0.5)                       # the tick's drive, force_safe inside it
    assert rig.queue.halt_at == ""                 # (it did run)
    assert not rig.en_out.read_back()
    assert not rig.queue.busy(), "pulses queued after the cut"
    assert rig.motor.rate_sps == 0.0
    emitted = rig.queue.emitted
    rig.clock.advance(0.1)
    rig.queue.advance()
    assert rig.queue.emitted == emitted
    assert rig.motor.at_rest() and rig.motor.position_lost     # (cut while moving)


def test_at_rest_waits_for_lgs_late_started_train():
    """lg starts a train at its thread's next pass, up to 20 ms after tx_pulse
    (lgPthTx.c:61): the schedule ends before the last pulse is out; until it is, the
    axis is not at rest (the AS5600 check compares only at rest)."""
    rig = Rig()
    seen_ahead = False
    for i in range(200):
        if i % 20 == 0:
            rig.motor.set_drive(0.2 if i == 0 else 0.0)   # one short train from rest, then stop
        rig.clock.advance(0.001)
        rig.queue.advance()
        if not rig.motor._sched and rig.queue.busy():
            seen_ahead = True                      # the schedule done, lg's pulses still going
            assert not rig.motor.at_rest()
        if rig.motor.at_rest():
            assert rig.motor.steps() == rig.axis.steps_taken > 0
    assert seen_ahead and rig.motor.at_rest()


def test_the_as5600_tolerance_follows_the_microstep_and_the_backlash():
    """4 full steps at the axis' own microstep (it assumed 1/8), plus the profile's gear
    play (after a reversal the count and an axis-side sensor differ by up to it)."""
    rig = Rig(microsteps=16, steps_per_deg=240.0)
    caps = SensorCaps(kind="encoder", resolution_deg=1 / 240, absolute=False)
    check = types.SimpleNamespace(caps=SensorCaps(kind="as5600", resolution_deg=360 / 4096, absolute=True))
    tol = StepCountSensor(caps, "az", rig.motor, check=check, microsteps=16).check_tol_deg
    assert tol == pytest.approx(4 * 16 / 240)                 # 4 full steps of 1/15 deg
    tol = StepCountSensor(caps, "az", rig.motor, check=check, microsteps=16, backlash_deg=0.5).check_tol_deg
    assert tol == pytest.approx(4 * 16 / 240 + 0.5)


def test_the_built_satnogs_axis_uses_its_microstep(tmp_path):
    from pathlib import Path

    from urc.assembly import build_rotator
    from urc.cli import with_emulation
    from urc.config import Config, load_config
    example = Path(__file__).resolve().parents[2] / "examples" / "satnogs-v3.toml"
    data = with_emulation(load_config(example)).to_dict()
    data["hardware"]["gpio"]["az"].update(microsteps=16, steps_per_deg=240.0, as5600_check=True)
    rot = build_rotator(Config.from_dict(data), VirtualClock(1000.0), tmp_path, durable_state=False,
                        fast_virtual=True)
    try:
        sensor = rot.hw.axis("az").sensor
        assert sensor.check_tol_deg == pytest.approx(4 * 16 / 240 + rot.caps.az.backlash_deg)
    finally:
        rot.hw.close()


def test_a_refused_queue_gives_lgs_code_from_the_text_lgpio_raises(monkeypatch):
    """Review finding 3: lgpio's _u2i raises error(error_text(status)), the text only,
    so the old queue() returned -1 for a full queue, not LG_TX_QUEUE_FULL -96. The
    emulation's LgError carried the int and hid it; now it carries the text too."""
    lgpio = pytest.importorskip("lgpio")
    for code, text in LG_ERROR_TEXT.items():
        assert lgpio.error_text(code) == text
    real = lgpio.error(lgpio.error_text(-96))           # what lgpio raises for a full queue
    assert real.value == "TX queue full" and real.args == ("TX queue full",)

    def tx_pulse(*a):
        raise real

    fake = types.SimpleNamespace(error=lgpio.error, error_text=lgpio.error_text, TX_PWM=lgpio.TX_PWM,
                                 gpio_claim_output=lambda *a: 0, tx_pulse=tx_pulse)
    monkeypatch.setitem(sys.modules, "lgpio", fake)
    pulses = LgpioStepPulses(types.SimpleNamespace(_handle=1), 17)
    assert pulses.queue(100, 100, 5) == -96
    fake.tx_pulse = lambda *a: (_ for _ in ()).throw(lgpio.error("some other text"))
    assert pulses.queue(100, 100, 5) == -1
    # the emulation raises the same shape, and its queue maps it back the same way
    q = EmulatedTxQueue(VirtualClock().now_s, lambda *a: None)
    for _ in range(LG_TX_BUF):
        q.tx_pulse(156, 156, 1000)
    with pytest.raises(LgError) as err:
        q.tx_pulse(156, 156, 1000)
    assert err.value.value == real.value and str(err.value) == str(real) and err.value.args == real.args
    assert not hasattr(err.value, "code")
    assert q.queue(156, 156, 1000) == -96
