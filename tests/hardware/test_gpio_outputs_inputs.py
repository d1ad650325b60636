"""Outputs (claimed at their safe level, active low, held at close, hardware PWM
off at start and close, the PWM chip found), inputs (debounce, normally-closed limits,
encoder scale) and the bridges' fault outputs, on mock pins and emulated iron."""

from __future__ import annotations

from pathlib import Path

import pytest
from gpiozero.pins.mock import MockFactory, MockPWMPin

from urc.assembly import build_rotator
from urc.cli import with_emulation
from urc.clock import VirtualClock
from urc.config import Config, load_config
from urc.hardware.drivers.motors import (LMD18200_TRUTH_TABLE, SENSE_V_PER_A, VNH5019_TRUTH_TABLE,
                                         lmd18200_state)
from urc.hardware.gpio.feed import emulated_bridge_open
from urc.hardware.gpio.pins import PinIn, PinOut
from urc.hardware.gpio.pwm import detect_pwm_chip
from urc.rotator.loop import run_virtual

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


@pytest.fixture
def factory():
    f = MockFactory(pin_class=MockPWMPin)
    yield f
    f.close()


class Recording(MockPWMPin):
    """A mock pin that records every level it is driven to as an output."""

    def _set_state(self, value):
        self.factory.driven.append((self.info.name, self._function, bool(value)))
        super()._set_state(value)

    def _set_function(self, value):
        self.factory.driven.append((self.info.name, value, bool(self._state)))
        super()._set_function(value)


def test_an_active_low_output_is_claimed_high_and_never_passes_low(factory):
    f = MockFactory(pin_class=Recording)
    f.driven = []
    out = PinOut(f, 23, active_low=True)
    levels = [lvl for _, fn, lvl in f.driven if fn == "output"]
    assert levels and all(levels), f.driven           # off (high) from the claim on
    assert bool(out.pin.state) is True and out.read_back() is False
    out.write(True)
    assert bool(out.pin.state) is False and out.read_back() is True
    f.close()


def emulated(name: str, tmp_path: Path, **changes):
    data = with_emulation(load_config(EXAMPLES / f"{name}.toml")).to_dict()
    data["hardware"]["sim"] = {"wind": False}
    for axis, kv in changes.items():
        data["hardware"]["gpio"][axis].update(kv)
    clock = VirtualClock(1000.0)
    return build_rotator(Config.from_dict(data), clock, tmp_path, durable_state=False, fast_virtual=True), clock


def test_close_holds_every_output_at_its_safe_level(tmp_path):
    """gpiozero's close would float the outputs (inputs); urc releases the inputs only."""
    rot, clock = emulated("g5500", tmp_path, az={"active_low": ["cw", "ccw"]})
    factory = rot.hw.gpio.pin_factory
    rot.goto_az(rot.status().az_deg + 30.0)
    run_virtual(rot, clock, 3.0)
    rot.hw.drive_safe()
    rot.hw.close()
    levels = {pin.info.name: (pin.function, pin.state) for pin in factory.pins.values()}
    assert levels["GPIO23"] == ("output", True) and levels["GPIO24"] == ("output", True)   # active low: off
    assert levels["GPIO20"] == ("output", False) and levels["GPIO21"] == ("output", False)
    assert all(fn == "output" for fn, _ in levels.values())


def test_limit_input_counts_a_level_once_it_held_the_debounce(factory):
    t = [0.0]
    pin = PinIn(factory, 22, debounce_s=0.02, now_s=lambda: t[0])
    pin.pin.drive_low()
    assert pin.read() is False                       # first read: the live level
    pin.pin.drive_high()                             # a bounce
    pin.pin.drive_low()
    t[0] = 0.01
    pin.pin.drive_high()
    assert pin.read() is False                       # not held yet
    t[0] = 0.031
    assert pin.read() is True and pin.edges() == 4


def _noisy(pin, t, level: bool, until_s: float, spike_every_s: float = 0.005):
    """The line at ``level`` with a spike to the other level every ``spike_every_s``
    (PWM pickup on a limit cable next to the motor leads); reads after each spike."""
    reads = []
    while t[0] < until_s - 1e-9:
        t[0] += spike_every_s
        (pin.pin.drive_low if level else pin.pin.drive_high)()
        (pin.pin.drive_high if level else pin.pin.drive_low)()
        reads.append(pin.read())
    return reads


def test_a_noisy_limit_line_shows_the_limit_at_once_and_clears_only_when_quiet(tmp_path):
    """BIG-RAS's normally-closed limit (active high): the switch opens at the limit
    while noise spikes the line every 5 ms. A symmetric debounce never saw a quiet
    0.02 s and hid the limit for as long as the noise lasted; the limit's active level
    counts at once, and only the way back waits for the debounce."""
    rot, clock = emulated("bigras", tmp_path)
    lim = rot.hw.az.limit_max
    assert lim is not None and lim.active_low is False
    pin, t = lim.pin, [0.0]
    pin._now_s = lambda: t[0]
    pin.pin.drive_low()                              # switch closed: not at the limit
    assert lim.is_active() is False
    pin.pin.drive_high()                             # the switch opens ...
    assert all(r == pin.urgent_level for r in _noisy(pin, t, True, 1.0))   # ... and the noise goes on
    assert lim.is_active() is True
    # back off the limit: noisy low stays "active" while the noise lasts (safe side) ...
    pin.pin.drive_low()
    assert set(_noisy(pin, t, False, 1.5)) == {True}
    t[0] += 0.021                                    # ... and clears once quiet for the debounce
    assert lim.is_active() is False
    # one spike to the active level seen only as an edge report, gone before the read
    pin.pin.drive_high()
    pin.pin.drive_low()
    assert lim.is_active() is True


def test_pulse_debounce_rejects_bounce_in_an_emulated_run(tmp_path):
    """A bouncing reed (two extra closures 0.2 ms after each pulse) counts as many
    pulses as a clean one: the BIG-RAS antenna still ends where the counter says."""
    rot, clock = emulated("bigras", tmp_path)
    drv = rot.hw.gpio.emulation["az"]
    drv.bounce = 2
    start = rot.status().az_deg
    rot.goto_az(start + 40.0)
    s = run_virtual(rot, clock, 60.0, until=lambda s: not s.moving and abs(s.az_deg - start - 40.0) < 1.5)
    counter = rot.hw.az.sensor.counter
    assert counter.rejected >= 2 * 30                # the bounces, rejected
    assert abs(s.sim_truth["az"]["deg"] - s.az_deg) <= 1.5


def test_pulse_debounce_rejects_bounce_on_opening_in_an_emulated_run(tmp_path):
    """A reed that re-closes twice as it opens (0.2 ms apart, half a pulse period after
    the closure) still counts one pulse per closure: the counter counts a falling edge
    only after the line was high for the debounce, and the emulated pulses have a width."""
    rot, clock = emulated("bigras", tmp_path)
    drv = rot.hw.gpio.emulation["az"]
    drv.bounce_open = 2
    start = rot.status().az_deg
    rot.goto_az(start + 40.0)
    s = run_virtual(rot, clock, 60.0, until=lambda s: not s.moving and abs(s.az_deg - start - 40.0) < 1.5)
    counter = rot.hw.az.sensor.counter
    assert counter.rejected >= 2 * 30                # the re-closures, rejected
    assert abs(s.sim_truth["az"]["deg"] - s.az_deg) <= 1.5


def test_an_as5600_with_dir_to_vdd_counts_down_and_as5600_reversed_reads_it_up(tmp_path):
    """The emulated chip counts the other way with as5600_reversed (its DIR tied to VDD:
    counterclockwise counts up, AS5600 datasheet "Direction"); urc still goes where told."""
    rot, clock = emulated("berkeley", tmp_path, az={"as5600_reversed": True})
    chip = rot.hw.az.sensor.part
    raw0 = chip.read_raw_angle()
    rot.goto_az(rot.status().az_deg + 50.0)
    s = run_virtual(rot, clock, 60.0, until=lambda s: not s.moving and abs(s.az_deg - 50.0) < 0.3)
    assert abs(s.sim_truth["az"]["deg"] - 50.0) < 0.5 and not s.faults
    counted = (chip.read_raw_angle() - raw0 + 2048) % 4096 - 2048
    assert counted == pytest.approx(-50.0 * 4096 / 360, abs=8)     # the raw count went down


def test_encoder_counts_per_degree_are_configurable(tmp_path):
    """A 4096-count encoder geared 1:1 (x4: 11.378 counts/deg) on tartu-urc's pins."""
    rot, clock = emulated("tartu-urc", tmp_path, az={"encoder_counts_per_deg": 4096 * 4 / 360})
    rot.goto_az(50.0)
    s = run_virtual(rot, clock, 60.0, until=lambda s: not s.moving and abs(s.az_deg - 50.0) < 0.3)
    assert abs(s.sim_truth["az"]["deg"] - 50.0) < 0.5
    assert rot.hw.az.sensor.counts() == pytest.approx(50.0 * 4096 * 4 / 360, abs=8)


def test_lmd18200_table_and_the_emulation_coast_against_brake():
    # TI's Table 1, all eight rows
    assert [lmd18200_state(*k) for k in sorted(LMD18200_TRUTH_TABLE)] == [
        "brake", "coast", "brake", "coast", "reverse", "brake", "forward", "brake"]
    assert VNH5019_TRUTH_TABLE[(0, 0)] == "brake to GND"
    # BTS7960 k_ILIS typ 8500 (4.4.6) into the IBT-2's two 1 kOhm IS resistors, tied
    assert SENSE_V_PER_A["bts7960"] == pytest.approx(0.0588, abs=1e-4)


def test_emulated_lmd18200_coasts_further_than_it_brakes(tmp_path):
    """The emulated bridge follows the table: BRAKE high with PWM high (urc's off)
    stops the motor sooner than BRAKE high with PWM low (every switch off)."""
    travel = {}
    for mode in ("brake", "coast"):
        rot, clock = emulated("sarcnet-mini", tmp_path / mode)
        m = rot.hw.az
        rot.goto_az(rot.status().az_deg + 60.0)
        run_virtual(rot, clock, 8.0)
        world = rot.hw.world
        x0 = world.truth()["az"]["deg"]
        assert abs(world.truth()["az"]["rate_deg_per_s"]) > 1.0
        m.motor.set_drive(0.0)                      # BRAKE high, PWM high
        if mode == "coast":
            m.motor.driver.pwm_out.write_duty(0.0)  # BRAKE high, PWM low
            m.motor.set_drive(0.0)                  # (the pins read back into the bridge)
        assert world.axes["az"].bridge_open == (mode == "coast")
        for _ in range(200):
            clock.advance(0.02)
            rot.hw.poll(clock.now_s())
        travel[mode] = abs(world.truth()["az"]["deg"] - x0)
    assert travel["coast"] > travel["brake"]


def test_emulated_vnh5019_brakes_at_off_and_coasts_with_pwm_low(tmp_path):
    """ST VNH5019A-E §2.4: INA = INB = 0 brakes to GND only with PWM high; a '0' on PWM
    turns both low sides off (every switch off: coast). The emulated bridge follows the
    datasheet: urc's off brakes, PWM low coasts further."""
    travel = {}
    for mode in ("brake", "coast"):
        rot, clock = emulated("tartu-urc", tmp_path / mode)
        m = rot.hw.az
        rot.goto_az(rot.status().az_deg + 60.0)
        run_virtual(rot, clock, 8.0)
        world = rot.hw.world
        x0 = world.truth()["az"]["deg"]
        assert abs(world.truth()["az"]["rate_deg_per_s"]) > 1.0
        m.motor.set_drive(0.0)                      # urc's off
        assert world.axes["az"].bridge_open is False
        if mode == "coast":
            m.motor.driver.pwm.write_duty(0.0)      # INA = INB = 0, PWM low
            # the pins read back into the bridge (as EmulatedMotor does after a drive)
            world.axes["az"].bridge_open = emulated_bridge_open("vnh5019", m.motor.driver)
            world.axes["az"].set_command(0.0)
            assert world.axes["az"].bridge_open is True
        for k in range(200):
            clock.advance(0.02)
            rot.hw.heartbeat.write(k % 2 == 0)       # the safety relay keeps the bridge powered
            rot.hw.poll(clock.now_s())
        travel[mode] = abs(world.truth()["az"]["deg"] - x0)
    assert travel["coast"] > travel["brake"]


def test_a_bridge_fault_output_stops_the_axes_with_a_driver_fault(tmp_path):
    rot, clock = emulated("tartu-urc", tmp_path, az={"pins": {
        **load_config(EXAMPLES / "tartu-urc.toml").hardware.gpio.az.pins, "diag": 19}})
    run_virtual(rot, clock, 0.5)
    assert not rot.status().faults
    rot.hw.az.motor.driver.fault_in.pin.drive_low()   # the VNH5019 pulls EN/DIAG low
    s = run_virtual(rot, clock, 0.5)
    (f,) = [f for f in s.faults if f.kind == "driver"]
    assert f.axis == "az" and "EN/DIAG pulled low" in f.reason


def _sysfs(tmp_path: Path, chips: dict[int, tuple[str, int]]) -> Path:
    root = tmp_path / "pwm"
    for n, (dev, npwm) in chips.items():
        d = root / f"pwmchip{n}"
        d.mkdir(parents=True)
        (d / "npwm").write_text(f"{npwm}\n")
        target = tmp_path / "devices" / dev
        target.mkdir(parents=True, exist_ok=True)
        (d / "device").symlink_to(target)
    return root


def test_the_pwm_chip_is_found_pi4_and_pi5_before_and_after_6_12(tmp_path):
    gpio = load_config(EXAMPLES / "bigras.toml").hardware.gpio
    assert detect_pwm_chip(gpio, _sysfs(tmp_path / "a", {0: ("fe20c000.pwm", 2)})) == (0, None)
    # a Pi 5 before 6.12: the RP1's PWM0 is pwmchip2 (0 and 1 are other chips' PWMs)
    pi5 = _sysfs(tmp_path / "b", {0: ("1f0009c000.pwm-fan", 1), 2: ("1f00098000.pwm", 4)})
    assert detect_pwm_chip(gpio, pi5) == (2, "4chan")
    assert detect_pwm_chip(gpio, _sysfs(tmp_path / "c", {0: ("1f00098000.pwm", 4)})) == (0, "4chan")
    assert detect_pwm_chip(gpio, tmp_path / "none") == (0, None)


def test_a_pi5s_fan_pwm_is_never_taken_for_the_motor_pwm(tmp_path):
    """Review 20 #11: the RP1's PWM1 (the fan's, 1f0009c000.pwm) has 4 channels too and
    is numbered first before kernel 6.12; only PWM0's base address (1f00098000) counts,
    and chips sort by number (pwmchip10 after pwmchip2)."""
    gpio = load_config(EXAMPLES / "bigras.toml").hardware.gpio
    fan_first = _sysfs(tmp_path / "a", {0: ("1f0009c000.pwm", 4), 3: ("1f00098000.pwm", 4)})
    assert detect_pwm_chip(gpio, fan_first) == (3, "4chan")
    only_fan = _sysfs(tmp_path / "b", {0: ("1f0009c000.pwm", 4)})
    assert detect_pwm_chip(gpio, only_fan) == (0, None)          # none found: as configured
    numeric = _sysfs(tmp_path / "c", {10: ("fe20c000.pwm", 2), 2: ("1f00098000.pwm", 4)})
    assert detect_pwm_chip(gpio, numeric) == (2, "4chan")


def test_relay_dead_time_below_a_relays_release_time_is_refused():
    """Review 20 #6: a relay opens 5-15 ms after its coil goes off; a reversal dead time
    under 50 ms can close CW and CCW at once (the phase capacitor shorted)."""
    from urc.errors import ConfigError
    from urc.hardware.drivers import RelayMotor
    data = load_config(EXAMPLES / "g5500.toml").to_dict()
    data["hardware"]["gpio"]["az"]["relay_dead_time_s"] = 0.0
    with pytest.raises(ConfigError, match=r"hardware.gpio.az.relay_dead_time_s.*0.05"):
        Config.from_dict(data)
    f = MockFactory(pin_class=MockPWMPin)
    try:
        with pytest.raises(ConfigError, match="CW and CCW at once"):
            RelayMotor("az", PinOut(f, 20), PinOut(f, 21), VirtualClock(0.0), reverse_dead_time_s=0.01)
    finally:
        f.close()


def test_emulated_relays_both_closed_is_a_fault(tmp_path):
    """The emulated contacts release 15 ms after their coil (not at once): a reversal
    with no dead time closes both, and the emulation says so instead of reading 0."""
    from urc.errors import HardwareError
    from urc.hardware.gpio.feed import RelayContacts
    c = RelayContacts("az")
    assert c.update(False, True, 0.0) is None
    assert c.update(False, False, 1.0) is None              # CCW's coil off at 1.0 s ...
    assert "phase capacitor" in c.update(True, False, 1.01)  # ... its contact still closed
    c = RelayContacts("az")
    c.update(False, True, 0.0)
    c.update(False, False, 1.0)
    assert c.update(True, False, 1.05) is None               # after the 50 ms minimum
    rot, clock = emulated("g5500", tmp_path)
    m = rot.hw.az.motor
    m.set_drive(-1.0)                                        # CCW
    clock.advance(0.1)
    m.driver.reverse_dead_time_s = 0.0                       # what config now refuses
    with pytest.raises(HardwareError, match="CW and CCW contacts closed at once"):
        m.set_drive(1.0)
    m.driver.reverse_dead_time_s = 0.5
    clock.advance(0.02)                                      # (the contacts settle)
    m.set_drive(0.0)
    clock.advance(0.6)
    m.set_drive(-1.0)
    clock.advance(0.1)
    m.set_drive(1.0)                                         # off first: waits the dead time
    assert m.driver.energised() == 0

