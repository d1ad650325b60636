"""urc hw check on emulated iron: parts, readings, magnet and I2C problems, and the jog
that finds a motor wired against its sensor."""

from __future__ import annotations

import re
from pathlib import Path

from click.testing import CliRunner

from urc.assembly import hardware_options, settings_from_config
from urc.cli import main, with_emulation
from urc.clock import VirtualClock
from urc.config import load_config
from urc.hardware import build_hardware
from urc.hardware.check import check
from urc.hardware.parts import MagnetStatus

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def emulated_hw(name: str, tmp_path: Path, stepper_driver: str | None = None, **sim):
    cfg = with_emulation(load_config(EXAMPLES / f"{name}.toml"))
    if sim or stepper_driver:
        data = cfg.to_dict()
        if sim:
            data["hardware"]["sim"] = sim
        for axis in ("az", "el") if stepper_driver else ():
            data["hardware"]["gpio"][axis]["stepper_driver"] = stepper_driver
        cfg = type(cfg).from_dict(data)
    caps = settings_from_config(cfg).caps
    clock = VirtualClock(1000.0)
    hw = build_hardware("gpio", caps, clock, tmp_path, hardware_options(cfg))
    hw.poll(clock.now_s())
    return cfg, caps, clock, hw


def run_check(cfg, caps, clock, hw, move):
    lines: list[str] = []
    n = check(hw, caps, gpio=cfg.hardware.gpio, move=move, sleep=clock.advance, now=clock.now_s,
              out=lines.append)
    return n, "\n".join(lines)


def test_reversed_motor_is_found_and_the_fix_printed(tmp_path):
    cfg, caps, clock, hw = emulated_hw("tartu-urc", tmp_path)
    hw.world.inject("az", "reverse_wiring")
    n, text = run_check(cfg, caps, clock, hw, move=True)
    assert n == 1, text
    assert "az" in text and "counted DOWN" in text and "[hardware.gpio.az] swap ina and inb" in text
    assert "el: motor" in text and "motor and sensor agree" in text
    # the VNH5019 CS pins on the MCP3008: current at rest, and while jogging
    assert "motor current: 0.00 A (current sense)" in text and "jog: motor current up to" in text


def test_relay_machine_reversed_fix_names_its_pins(tmp_path):
    cfg, caps, clock, hw = emulated_hw("g5500", tmp_path, start_el_deg=45.0)
    hw.world.inject("el", "reverse_wiring")
    n, text = run_check(cfg, caps, clock, hw, move=True)
    assert "[hardware.gpio.el] swap cw and ccw" in text, text


def test_magnet_and_i2c_problems_are_reported(tmp_path):
    cfg, caps, clock, hw = emulated_hw("berkeley", tmp_path)
    hw.gpio.i2c_buses[1].mux_channel(0x70, 0)[0x36].status = MagnetStatus(True, too_strong=True)
    hw.gpio.i2c_buses[1].mux_channel(0x70, 1)[0x36].nack = True
    n, text = run_check(cfg, caps, clock, hw, move=False)
    assert n >= 2
    assert "too strong" in text and "I2C failed" in text


def test_cli_lists_parts_and_limit_switches(tmp_path):
    r = CliRunner().invoke(main, ["hw", "check", "--config", str(EXAMPLES / "bigras.toml"), "--emulate",
                                  "--state-dir", str(tmp_path)])
    assert r.exit_code == 0, r.output
    assert "az pulse counter" in r.output and "limit switch min: closed circuit, not active" in r.output
    assert "no problems found" in r.output


def test_a_broken_limit_circuit_is_shown(tmp_path):
    """Normally-closed limit switches (the default): a wire that breaks reads as the
    switch opening, and both of an axis' limits open at once can only be the circuit."""
    cfg, caps, clock, hw = emulated_hw("bigras", tmp_path)
    n, text = run_check(cfg, caps, clock, hw, move=False)
    assert n == 0 and "broken limit circuit" not in text
    # the el switches' common wire cut: both inputs read high (through the simulated
    # switches: the check polls the emulation while it tests the safety chain, and each
    # poll drives the limit pins from them)
    hw.world.inject("el", "limit_switch", which="both")
    clock.advance(0.1)                                  # longer than the debounce
    n, text = run_check(cfg, caps, clock, hw, move=False)
    assert n == 1 and "both el limits read active: a broken limit circuit" in text, text
    assert hw.el.limit_min.is_active() and not hw.az.limit_min.is_active()


def test_lost_encoder_edges_are_shown(tmp_path):
    """urc hw check shows the encoder's lost edges and the bound they put on the position."""
    cfg, caps, clock, hw = emulated_hw("tartu-urc", tmp_path)
    n, text = run_check(cfg, caps, clock, hw, move=False)
    assert n == 0 and "az:" in text and "encoder lost edges: 0 since the last reference" in text, text
    counter = hw.az.sensor.counter
    level = counter.a.state
    counter._edge(2, counter.a, not level)       # a report of A's new level ...
    counter._edge(2, counter.a, not level)       # ... and the same again: an edge was lost
    n, text = run_check(cfg, caps, clock, hw, move=False)
    assert "encoder lost edges: 1 since the last reference (position uncertain by up to 0.40 deg)" in text, text


def test_encoder_index_is_shown(tmp_path):
    cfg = with_emulation(load_config(EXAMPLES / "tartu-urc.toml"))
    data = cfg.to_dict()
    data["hardware"]["gpio"]["az"]["pins"]["enc_z"] = 19
    data["hardware"]["gpio"]["az"]["encoder_index_deg"] = 1.0
    cfg = type(cfg).from_dict(data)
    caps = settings_from_config(cfg).caps
    clock = VirtualClock(1000.0)
    hw = build_hardware("gpio", caps, clock, tmp_path, hardware_options(cfg))
    n, text = run_check(cfg, caps, clock, hw, move=True)
    assert "encoder index: not seen yet" in text
    n, text = run_check(cfg, caps, clock, hw, move=False)      # the first jog went over it
    assert "encoder index: last at count" in text, text


def test_the_safety_chain_is_measured(tmp_path):
    """urc hw check runs the chain's self-test (the motors off) and shows the timeout it
    measured on the read-back; a chain that does not cut is a problem."""
    cfg, caps, clock, hw = emulated_hw("tartu-urc", tmp_path)
    n, text = run_check(cfg, caps, clock, hw, move=False)
    assert n == 0, text
    assert re.search(r"safety chain: measured timeout 0\.22[01] s \(configured 0\.22 s\)", text), text
    hw.world.inject("chain", "contact_welded")
    n, text = run_check(cfg, caps, clock, hw, move=False)
    assert n == 1 and "safety chain: PROBLEM the relay's contact still showed the enable on" in text, text


def test_the_safety_chain_without_a_read_back_is_not_measured(tmp_path):
    cfg = with_emulation(load_config(EXAMPLES / "g5500.toml"))
    data = cfg.to_dict()
    data["hardware"]["gpio"].pop("motor_enable_sense_pin")
    cfg = type(cfg).from_dict(data)
    clock = VirtualClock(1000.0)
    hw = build_hardware("gpio", settings_from_config(cfg).caps, clock, tmp_path, hardware_options(cfg))
    n, text = run_check(cfg, settings_from_config(cfg).caps, clock, hw, move=False)
    assert n == 0 and "safety chain: not measured: no read-back input (motor_enable_sense_pin)" in text, text


def test_cli_shows_the_measured_timeout(tmp_path):
    r = CliRunner().invoke(main, ["hw", "check", "--config", str(EXAMPLES / "sarcnet-mini.toml"), "--emulate",
                                  "--state-dir", str(tmp_path)])
    assert r.exit_code == 0, r.output
    assert "safety chain: measured timeout 0.22" in r.output and "no problems found" in r.output


def test_the_self_tests_cut_widens_the_step_counts_bound(tmp_path):
    """Review finding 5: the check's self-test drops the steppers' supply, which resets
    their indexers: up to 2 full steps (1/15 deg on satnogs-v3), said per axis."""
    cfg, caps, clock, hw = emulated_hw("satnogs-v3", tmp_path, stepper_driver="drv8825", wind=False)
    n, text = run_check(cfg, caps, clock, hw, move=False)
    assert n == 0, text
    assert text.count("step count: the rotor may be up to 0.067 deg from it after 1 motor-supply") == 2, text
