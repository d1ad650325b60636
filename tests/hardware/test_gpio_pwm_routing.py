"""A pin the overlay routed to the PWM peripheral stays routed (review 35 #3): claiming it
as a GPIO line (lgpio) re-muxes it until the next boot, so neither the takeover nor the
software-PWM fallback may claim it. The pins' function select is modelled
(MuxedMockFactory: a claim makes a pin a GPIO, nothing routes it back) and the PWM
chip is a sysfs tree in tmp_path."""

from __future__ import annotations

import sys
import types
from pathlib import Path

import pytest
from gpiozero import Device

from urc.assembly import hardware_options, settings_from_config
from urc.clock import VirtualClock
from urc.config import Config, load_config
from urc.errors import ConfigError
from urc.hardware import build_hardware
from urc.hardware.check import check
from urc.hardware.drivers.motors import lmd18200_state, vnh5019_state
from urc.hardware.gpio.emulate import MuxedMockFactory
from urc.hardware.gpio.outputs_only import take_gpio_outputs
from urc.hardware.gpio.pinmux import Pinctrl, pwm_channel_of
from urc.hardware.gpio.pwm import make_pwm

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
PI4_PWM = {12: "PWM0_0", 13: "PWM0_1"}        # dtoverlay=pwm-2chan,pin=12,func=4,pin2=13,func2=4


def cfg_of(name: str) -> Config:
    return load_config(EXAMPLES / f"{name}.toml")


def pwm_sysfs(root: Path, device: str = "fe20c000.pwm", *, running: dict[int, tuple[int, int]]) -> Path:
    """A pwmchip0 whose device is ``device``; ``running`` {channel: (duty, period)}
    exported and enabled, as a killed urc leaves them."""
    chip = root / "pwmchip0"
    chip.mkdir(parents=True)
    (root / device).mkdir()
    (chip / "device").symlink_to(root / device)
    (chip / "export").write_text("")
    for ch, (duty, period) in running.items():
        d = chip / f"pwm{ch}"
        d.mkdir()
        (d / "duty_cycle").write_text(str(duty))
        (d / "period").write_text(str(period))
        (d / "enable").write_text("1")
    return root


def read(ch: Path) -> tuple[int, int, int]:
    return tuple(int((ch / n).read_text()) for n in ("duty_cycle", "period", "enable"))  # type: ignore[return-value]


@pytest.fixture
def factory():
    f = MuxedMockFactory(dict(PI4_PWM))
    yield f
    f.close()


def test_takeover_leaves_routed_pwm_pins_on_their_channel_and_stops_it_through_sysfs(factory, tmp_path):
    """tartu-urc after a kill: both VNH5019 PWM channels left running at 90 %. The old
    takeover claimed GPIO12/13 as outputs (low): the pins became GPIOs until reboot and
    every later start's hardware PWM drove nothing (axes that never move)."""
    sys_pwm = pwm_sysfs(tmp_path, running={0: (900_000, 1_000_000), 1: (900_000, 1_000_000)})
    held = take_gpio_outputs(cfg_of("tartu-urc").hardware.gpio, ("az", "el"), factory, sys_pwm=sys_pwm)
    assert held.failed == []
    assert factory.pin_functions.function(12) == "PWM0_0" and factory.pin_functions.function(13) == "PWM0_1"
    assert 12 not in factory.pin_functions.claims and 13 not in factory.pin_functions.claims
    for ch in (0, 1):
        assert read(sys_pwm / "pwmchip0" / f"pwm{ch}") == (0, 1_000_000, 0)      # duty 0, disabled: idles low
    levels = held.levels()
    for axis in ("az", "el"):
        assert vnh5019_state(*(levels[f"{axis} vnh5019 {k}"] for k in ("ina", "inb", "pwm"))) == "brake"
    assert levels["heartbeat"] is False and 18 in factory.pin_functions.claims


def test_takeover_holds_an_lmd18200_pwm_high_on_its_channel(factory, tmp_path):
    """sarcnet-mini: urc's off is BRAKE high with PWM high (TI Table 1). The old takeover
    claimed the PWM pin high as a GPIO: after the restart it stayed a GPIO, held high,
    and every move ran at 100 % whatever speed was asked. Now the channel runs at
    duty = period; BRAKE is set first (with BRAKE high PWM only picks brake or coast)."""
    sys_pwm = pwm_sysfs(tmp_path, running={0: (300_000, 1_000_000), 1: (0, 0)})   # az left at 30 %; el: no period yet
    gpio = cfg_of("sarcnet-mini").hardware.gpio
    held = take_gpio_outputs(gpio, ("az", "el"), factory, sys_pwm=sys_pwm)
    assert held.failed == []
    assert [p for p in factory.pin_functions.claims if p in (12, 13)] == []
    assert read(sys_pwm / "pwmchip0" / "pwm0") == (1_000_000, 1_000_000, 1)
    el_period = round(1e9 / gpio.el.pwm_frequency_hz)
    assert read(sys_pwm / "pwmchip0" / "pwm1") == (el_period, el_period, 1)    # a period given, then held high
    lv = held.levels()
    for axis in ("az", "el"):
        assert lmd18200_state(lv[f"{axis} lmd18200 pwm"], lv[f"{axis} lmd18200 dir"],
                              lv[f"{axis} lmd18200 bridge_brake"]) == "brake"
    assert list(held.outputs)[:3] == ["az lmd18200 bridge_brake", "az lmd18200 dir", "az lmd18200 pwm"]


def test_takeover_claims_a_pwm_pin_that_is_a_gpio_already(tmp_path):
    """GPIO13 not routed by the overlay (software PWM ran on it): claimed like any output."""
    f = MuxedMockFactory({12: "PWM0_0"})
    sys_pwm = pwm_sysfs(tmp_path, running={})
    held = take_gpio_outputs(cfg_of("tartu-urc").hardware.gpio, ("az", "el"), f, sys_pwm=sys_pwm)
    assert 13 in f.pin_functions.claims and 12 not in f.pin_functions.claims
    assert held.levels()["el vnh5019 pwm"] is False and held.failed == []
    f.close()


class RightsNotYet:
    """rpi-hardware-pwm before udev has given the gpio group its sysfs files."""

    def __init__(self, pwm_channel, hz, chip=0):
        raise PermissionError(13, f"Permission denied: '/sys/class/pwm/pwmchip{chip}/pwm{pwm_channel}/period'")


def test_a_routed_pin_whose_channel_cannot_open_is_refused_not_claimed(factory, tmp_path):
    """The old fallback claimed GPIO12 for software PWM: routed to GPIO for good."""
    sys_pwm = pwm_sysfs(tmp_path, running={})
    with pytest.raises(ConfigError, match=r"GPIO12: hardware PWM0 .*cannot be opened.*will not claim it"):
        make_pwm(factory, 12, 0, 1000.0, emulated=False, pwm_class=RightsNotYet,
                 functions=factory.pin_functions, sys_pwm=sys_pwm)
    assert factory.pin_functions.function(12) == "PWM0_0" and factory.pin_functions.claims == []


def test_no_pwm_chip_at_all_falls_back_to_software_pwm(factory, tmp_path):
    """No overlay (no pwmchip, routing unknown): nothing routed the pin, software PWM."""
    from urc.hardware.gpio.pins import PinPwm
    part = make_pwm(factory, 12, 0, 1000.0, emulated=False, pwm_class=RightsNotYet, functions=None,
                    sys_pwm=tmp_path)
    assert isinstance(part, PinPwm)


def test_a_pin_not_routed_to_its_channel_runs_software_pwm_and_hw_check_says_so(monkeypatch, tmp_path):
    """tartu-urc with only GPIO12 routed: el's GPIO13 gets software PWM (its channel would
    drive whichever pin is routed to it, if any), and `urc hw check` no longer prints
    "hardware PWM1" for it."""
    made: list[int] = []

    class Library:
        def __init__(self, pwm_channel, hz, chip=0):
            made.append(pwm_channel)

        def start(self, duty):
            pass

        def change_duty_cycle(self, duty):
            pass

        def stop(self):
            pass

    f = MuxedMockFactory({12: "PWM0_0"})
    monkeypatch.setattr(Device, "pin_factory", f)
    monkeypatch.setitem(sys.modules, "rpi_hardware_pwm", types.SimpleNamespace(HardwarePWM=Library))
    data = cfg_of("tartu-urc").to_dict()
    for a in ("az", "el"):                           # no MCP3008 on this machine
        del data["hardware"]["gpio"][a]["adc"], data["hardware"]["gpio"][a]["current_sense_channel"]
    cfg = Config.from_dict(data)
    caps = settings_from_config(cfg).caps
    hw = build_hardware("gpio", caps, VirtualClock(1000.0), tmp_path, hardware_options(cfg))
    assert made == [0]
    lines: list[str] = []
    check(hw, caps, gpio=cfg.hardware.gpio, out=lines.append)
    text = "\n".join(lines)
    assert "az.pwm GPIO12: hardware PWM0 (pwmchip0, routed to PWM0)" in text
    assert "el.pwm GPIO13: software PWM (planned hardware PWM1: NOT routed to PWM1 (pinctrl: output))" in text
    assert "hardware PWM1" not in text.replace("planned hardware PWM1", "")
    hw.close()
    f.close()


def test_pinctrl_names_per_chip():
    """raspberrypi/utils pinctrl's function names: BCM2835 PWM0/PWM1, BCM2711
    PWM0_0/PWM0_1, RP1 PWM0_CHAN0..3 (the fan's PWM1_CHANn is not the motor PWM)."""
    assert [pwm_channel_of(n) for n in ("PWM0", "PWM1", "PWM0_0", "PWM0_1", "PWM0_CHAN2", "PWM0_CHAN3")] == \
        [0, 1, 0, 1, 2, 3]
    assert [pwm_channel_of(n) for n in ("input", "output", "PWM1_CHAN2", "TXD0", None)] == [None] * 5

    def run(argv, **_k):
        assert argv[1:] == ["get", "12"]
        return types.SimpleNamespace(returncode=0, stdout="12: a0    pd | lo // GPIO12 = PWM0_0\n")
    assert Pinctrl(exe="pinctrl", run=run).function(12) == "PWM0_0"
    assert Pinctrl(exe=None).function(12) is None


PI5_PWM = {12: "PWM0_CHAN0", 13: "PWM0_CHAN1", 18: "PWM0_CHAN2", 19: "PWM0_CHAN3"}


def test_a_pi5_uses_its_detected_four_channel_table_everywhere(monkeypatch, tmp_path, caplog):
    """bigras on a Pi 5 (the RP1's PWM0 found in sysfs) with hardware_pwm left at "2chan":
    the build used the 4-channel table, but the start log's advice and `urc hw check`
    used the 2-channel plan (el's GPIO18/19 "share PWM0/PWM1 ... software PWM") while
    both ran hardware PWM2/3. Now all three use the detected table."""
    import logging

    from click.testing import CliRunner

    from urc.cli import main
    from urc.hardware.gpio import pwm as pwm_mod
    made: list[int] = []

    class Library:
        def __init__(self, pwm_channel, hz, chip=0):
            made.append(pwm_channel)

        def start(self, duty):
            pass

        def change_duty_cycle(self, duty):
            pass

        def stop(self):
            pass

    sys_pwm = pwm_sysfs(tmp_path / "sys", "1f00098000.pwm", running={})
    monkeypatch.setattr(pwm_mod, "SYS_PWM", sys_pwm)
    f = MuxedMockFactory(dict(PI5_PWM))
    monkeypatch.setattr(Device, "pin_factory", f)
    monkeypatch.setitem(sys.modules, "rpi_hardware_pwm", types.SimpleNamespace(HardwarePWM=Library))
    cfg = cfg_of("bigras")
    assert cfg.hardware.gpio.hardware_pwm == "2chan" and not cfg.hardware.gpio.emulate
    caps = settings_from_config(cfg).caps
    with caplog.at_level(logging.WARNING):
        hw = build_hardware("gpio", caps, VirtualClock(1000.0), tmp_path, hardware_options(cfg))
    assert made == [0, 1, 2, 3]
    assert "shares PWM" not in caplog.text
    lines: list[str] = []
    check(hw, caps, gpio=cfg.hardware.gpio, out=lines.append)
    text = "\n".join(lines)
    for where, pin, ch in (("az.rpwm", 12, 0), ("az.lpwm", 13, 1), ("el.rpwm", 18, 2), ("el.lpwm", 19, 3)):
        assert f"{where} GPIO{pin}: hardware PWM{ch} (pwmchip0, routed to PWM{ch})" in text
    hw.close()
    r = CliRunner().invoke(main, ["config", "check", str(EXAMPLES / "bigras.toml")])
    assert r.exit_code == 0 and "shares PWM" not in r.output, r.output
    f.close()


def test_the_fallback_advice_names_bookworms_config_txt_and_never_the_heartbeats_pins(factory, tmp_path, caplog):
    """Review 35 #8: the fallback told the user to add plain dtoverlay=pwm-2chan (its
    default pins are GPIO18/19, and GPIO18 is the heartbeat in five examples) and passed
    on rpi-hardware-pwm's /boot/config.txt."""
    import logging

    class NoOverlay:
        def __init__(self, pwm_channel, hz, chip=0):
            raise OSError("Need to add 'dtoverlay=pwm-2chan' to /boot/config.txt and reboot")

    with caplog.at_level(logging.WARNING):
        make_pwm(factory, 12, 0, 1000.0, emulated=False, pwm_class=NoOverlay, sys_pwm=tmp_path, heartbeat_pin=18)
        make_pwm(factory, 19, 1, 1000.0, emulated=False, pwm_class=NoOverlay, sys_pwm=tmp_path, heartbeat_pin=18)
    first, second = [r.getMessage() for r in caplog.records]
    assert "/boot/firmware/config.txt: dtoverlay=pwm-2chan,pin=12,func=4,pin2=13,func2=4" in first
    assert "no PWM overlay loaded" in first
    assert "GPIO18 is the heartbeat, so do not route GPIO18/19 to PWM" in second
    assert "/boot/config.txt" not in first + second and "dtoverlay=pwm-2chan " not in first + second


def test_the_docs_give_el_enc_z_a_pin_that_is_not_the_heartbeat():
    docs = (EXAMPLES.parent / "docs" / "hardware.md").read_text()
    assert "GPIO18 / 12 for el" not in docs and "GPIO6 / 31 for el" in docs
