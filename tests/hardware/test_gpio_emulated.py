"""The gpio backend's real drivers on pins and chips emulated from the simulator:
every shipped example runs, goes where it is told (judged by simulator truth), and
the pin map is validated."""

from __future__ import annotations

from pathlib import Path

import pytest

from urc.assembly import build_rotator
from urc.cli import with_emulation
from urc.clock import VirtualClock
from urc.config import Config, load_config
from urc.errors import ConfigError
from urc.rotator.loop import run_virtual

EXAMPLES = sorted(p for p in (Path(__file__).resolve().parents[2] / "examples").glob("*.toml")
                  if 'backend = "gpio"' in p.read_text())   # (a bridge example has no parts of urc's)


def emulated(path: Path, tmp_path: Path, **sim):
    data = with_emulation(load_config(path)).to_dict()
    data.setdefault("hardware", {}).setdefault("sim", {}).update({"wind": False, **sim})
    cfg = Config.from_dict(data)
    clock = VirtualClock(1000.0)
    return build_rotator(cfg, clock, tmp_path, durable_state=False, fast_virtual=True), clock


def test_there_is_an_example_per_seed_machine_and_a_g5500():
    assert {p.stem for p in EXAMPLES} >= {"tartu-urc", "sarcnet-mini", "bigras", "g4jnt", "berkeley", "g5500"}


def _a_goto(s) -> tuple[float, float]:
    """A pose inside any example's range: az 40 (or short of its top), el 30 (or half
    way up a lower range)."""
    az = min(s.limits["az"][1] - 5.0, 40.0)
    # a single-axis example (trc-turntable) has no elevation: the goto's el is left aside
    el_hi = s.limits["el"][1] if s.has_el else 0.0
    return az, 30.0 if el_hi >= 30 else el_hi / 2


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.stem)
def test_example_goes_where_it_is_told(path, tmp_path):
    rot, clock = emulated(path, tmp_path)
    assert rot.hw.backend == "gpio" and rot.hw.gpio.emulated
    s = rot.status()
    assert s.sim_truth is not None and not s.faults
    az, el = _a_goto(s)
    rot.goto(az, el)
    s = run_virtual(rot, clock, 120.0, until=lambda s: not s.moving and all(
        a is None or a.mode in ("holding", "idle") for a in (s.az, s.el))
        and abs(s.az_deg - az) < 1 and (s.el_deg is None or abs(s.el_deg - el) < 1))
    assert not s.faults, s.faults
    truth = s.sim_truth
    caps = rot.caps
    tol = {a: caps.axis(a).tolerance_deg + 2 * caps.axis(a).sensor.resolution_deg + 4 * caps.axis(a).sensor.noise_deg + 0.5
           for a in caps.axes}
    assert abs(truth["az"]["deg"] - az) <= tol["az"], (truth["az"]["deg"], az)
    if s.has_el:
        assert abs(truth["el"]["deg"] - el) <= tol["el"], (truth["el"]["deg"], el)
    else:  # nothing drives the elevation joint: it stands where the simulator started it
        assert s.el is None and s.el_deg is None and truth["el"]["rate_deg_per_s"] == 0.0
    rot.hw.close()


def _cfg(**gpio):
    base = {"motor": "vnh5019", "pins": {"ina": 5, "inb": 6, "pwm": 12, "enc_a": 17, "enc_b": 27, "brake": 16}}
    el = {"motor": "vnh5019", "pins": {"ina": 20, "inb": 21, "pwm": 13, "enc_a": 22, "enc_b": 23, "brake": 26}}
    g = {"az": base, "el": el, **gpio}
    return {"rotator": {"profile": "tartu-urc"}, "hardware": {"backend": "gpio", "gpio": g}}


def test_pin_map_errors_name_key_expected_found():
    Config.from_dict(_cfg())
    bad = _cfg()
    bad["hardware"]["gpio"]["el"]["pins"]["pwm"] = 12          # used twice
    with pytest.raises(ConfigError, match=r"hardware.gpio.el.pins.pwm.*already used.*GPIO12"):
        Config.from_dict(bad)
    bad = _cfg()
    del bad["hardware"]["gpio"]["az"]["pins"]["enc_b"]         # missing
    with pytest.raises(ConfigError, match=r"hardware.gpio.az.pins.enc_b"):
        Config.from_dict(bad)
    bad = _cfg()
    bad["hardware"]["gpio"]["az"]["motor"] = "relay"           # a relay drive for a PWM profile
    with pytest.raises(ConfigError, match=r"hardware.gpio.az"):
        Config.from_dict(bad)


def test_two_as5600_on_one_bus_and_adc_channel_range():
    d = {"rotator": {"profile": "berkeley"}, "hardware": {"backend": "gpio", "gpio": {
        "az": {"motor": "pwm_dir", "pins": {"pwm": 12, "dir": 5}},
        "el": {"motor": "pwm_dir", "pins": {"pwm": 13, "dir": 6}}}}}
    with pytest.raises(ConfigError, match=r"i2c_address.*two AS5600 need two buses"):
        Config.from_dict(d)
    d["hardware"]["gpio"]["el"]["i2c_bus"] = 3
    Config.from_dict(d)
    del d["hardware"]["gpio"]["el"]["i2c_bus"]
    # one bus through a TCA9548A: two channels are fine, one channel is not
    d["hardware"]["gpio"]["az"]["i2c_mux_channel"] = 0
    d["hardware"]["gpio"]["el"]["i2c_mux_channel"] = 0
    with pytest.raises(ConfigError, match=r"el.i2c_address.*bus 1 mux channel 0.*0x36"):
        Config.from_dict(d)
    d["hardware"]["gpio"]["el"]["i2c_mux_channel"] = 8
    with pytest.raises(ConfigError, match=r"i2c_mux_channel"):
        Config.from_dict(d)
    d["hardware"]["gpio"]["el"]["i2c_mux_channel"] = 1
    Config.from_dict(d)
    del d["hardware"]["gpio"]["az"]["i2c_mux_channel"]     # one on the bus itself meets every channel
    with pytest.raises(ConfigError, match=r"el.i2c_address.*0x36"):
        Config.from_dict(d)
    d["hardware"]["gpio"]["az"]["i2c_mux_channel"] = 0
    d["hardware"]["gpio"]["fram_address"] = 0x70             # a chip where the mux answers
    with pytest.raises(ConfigError, match=r"i2c_mux_address.*TCA9548A"):
        Config.from_dict(d)
    g = {"rotator": {"profile": "g5500"}, "hardware": {"backend": "gpio", "gpio": {
        "az": {"motor": "relay", "pins": {"cw": 5, "ccw": 6}, "adc_channel": 4},
        "el": {"motor": "relay", "pins": {"cw": 20, "ccw": 21}, "adc_channel": 1}}}}
    with pytest.raises(ConfigError, match=r"adc_channel.*0..3"):
        Config.from_dict(g)
    # an MCP3008 on SPI0 has 8 inputs; SPI0's pins are its own; CE0 or CE1 only
    for a in ("az", "el"):
        g["hardware"]["gpio"][a]["adc"] = "mcp3008"
    Config.from_dict(g)
    g["hardware"]["gpio"]["az"]["adc_channel"] = 8
    with pytest.raises(ConfigError, match=r"az.adc_channel.*MCP3008 input 0..7"):
        Config.from_dict(g)
    g["hardware"]["gpio"]["az"]["adc_channel"] = 7
    g["hardware"]["gpio"]["el"]["pins"]["ccw"] = 10
    with pytest.raises(ConfigError, match=r"el.pins.ccw.*GPIO10 is SPI0 MOSI"):
        Config.from_dict(g)
    g["hardware"]["gpio"]["el"]["pins"]["ccw"] = 21
    g["hardware"]["gpio"]["el"]["spi_device"] = 2
    with pytest.raises(ConfigError, match=r"spi_device"):
        Config.from_dict(g)
    g["hardware"]["gpio"]["el"]["spi_device"] = 0
    g["hardware"]["gpio"]["el"]["adc_channel"] = 7              # the az pot's input on the same chip
    with pytest.raises(ConfigError, match=r"el.adc_channel.*MCP3008 input 7 is hardware.gpio.az.adc_channel"):
        Config.from_dict(g)
    g["hardware"]["gpio"]["el"]["adc_channel"] = 1
    g["hardware"]["gpio"]["el"]["current_sense_channel"] = 2    # relays have no current-sense output
    with pytest.raises(ConfigError, match=r"el.current_sense_channel.*current-sense output"):
        Config.from_dict(g)
    del g["hardware"]["gpio"]["el"]["current_sense_channel"]
    g["hardware"]["gpio"]["el"]["adc"] = "mcp3009"
    with pytest.raises(ConfigError, match=r"el.adc.*mcp3008"):
        Config.from_dict(g)
    t = _cfg()
    t["hardware"]["gpio"]["az"].update(adc="ads1115", current_sense_channel=4)   # ADS1115: 0..3
    with pytest.raises(ConfigError, match=r"az.current_sense_channel.*ADS1115 input 0..3"):
        Config.from_dict(t)
    t["hardware"]["gpio"]["az"]["current_sense_channel"] = 0
    t["hardware"]["gpio"]["el"].update(adc="ads1115", current_sense_channel=0)
    with pytest.raises(ConfigError, match=r"el.current_sense_channel.*input 0 is hardware.gpio.az"):
        Config.from_dict(t)
    t["hardware"]["gpio"]["el"]["current_sense_channel"] = 1
    Config.from_dict(t)


def test_i2c_nack_is_a_sensor_fault_that_never_moves(tmp_path):
    rot, clock = emulated(next(p for p in EXAMPLES if p.stem == "berkeley"), tmp_path)
    run_virtual(rot, clock, 0.5)
    bus = rot.hw.gpio.i2c_buses[1]
    bus.mux_channel(0x70, 0)[0x36].nack = True
    s = run_virtual(rot, clock, 1.0)
    assert any("I2C" in f.reason for f in s.faults), s.faults
    t0 = s.sim_truth["az"]["deg"]
    try:
        rot.goto(100.0, 10.0)
    except Exception:
        pass
    s = run_virtual(rot, clock, 3.0)
    assert abs(s.sim_truth["az"]["deg"] - t0) < 0.5


def test_magnet_too_weak_is_a_fault(tmp_path):
    from urc.hardware.parts import MagnetStatus
    rot, clock = emulated(next(p for p in EXAMPLES if p.stem == "berkeley"), tmp_path)
    run_virtual(rot, clock, 0.5)
    rot.hw.gpio.i2c_buses[1].mux_channel(0x70, 1)[0x36].status = MagnetStatus(True, too_weak=True)
    s = run_virtual(rot, clock, 1.0)
    assert any("too weak" in f.reason for f in s.faults), s.faults


def _power_fail_rig(tmp_path, machine: str):
    data = with_emulation(load_config(next(p for p in EXAMPLES if p.stem == machine))).to_dict()
    data["hardware"]["sim"] = {"wind": False}
    data["hardware"]["gpio"].setdefault("power_fail_pin", 14)
    data.setdefault("state", {})["save_interval_s"] = 10.0
    clock = VirtualClock(1000.0)
    return build_rotator(Config.from_dict(data), clock, tmp_path, durable_state=False), clock


def _pin_drives(ax) -> list[float]:
    """What the motor driver's output pins put on the motor now: read back from the pins
    and decoded as the bridge's truth table does (a VNH5019's off has PWM at 100 %
    with INA = INB = 0: a brake, no drive)."""
    from urc.hardware.gpio.feed import emulated_motor_duty
    return [abs(emulated_motor_duty(ax.motor.kind, ax.motor.driver, ax.motor.levels))]


@pytest.mark.parametrize("machine", ["bigras", "tartu-urc"])
def test_power_fail_edge_stops_the_motors_brakes_saves_and_shows_a_fault(tmp_path, machine):
    from urc.persistence import StateStore
    rot, clock = _power_fail_rig(tmp_path, machine)
    rot.goto(120.0, 40.0)
    run_virtual(rot, clock, 6.0)              # moving; the last periodic record is older
    assert any(d > 0 for d in _pin_drives(rot.hw.az)), "the az motor should be driving"
    if rot.hw.az.brake is not None:
        assert rot.hw.az.brake.driver.coil.read_back()
    store = StateStore(tmp_path / "state.json")
    before = store.load()["axes"]["az"]["mech_deg"]
    pos = rot.status().az.pos_deg
    assert abs(before - pos) > 1.0
    pf = rot.hw.power_fail
    pf.emulate_power_fail()
    # at once, on the edge's callback, before any further tick: every motor pin off,
    # brake coils off (engaged); the state write follows on a thread of its own
    for ax in (rot.hw.az, rot.hw.el):
        assert _pin_drives(ax) == [0.0] * len(_pin_drives(ax))
        if ax.brake is not None:
            assert not ax.brake.driver.coil.read_back()
    pf.saver.join(5.0)
    assert not pf.saver.is_alive()
    after = store.load()["axes"]["az"]["mech_deg"]
    assert after == pytest.approx(pos, abs=0.6) and rot.hw.power_fail.events == 1
    s = rot.status()
    assert [f.kind for f in s.faults] == ["power_fail"] and "motors stopped" in s.faults[0].reason
    # the loop does not drive again, and motion is refused until the fault is cleared
    t0 = run_virtual(rot, clock, 3.0).sim_truth["az"]["deg"]
    s = run_virtual(rot, clock, 3.0)
    assert s.sim_truth["az"]["deg"] == pytest.approx(t0, abs=0.05) and s.az.duty == 0.0
    with pytest.raises(Exception, match="fault"):
        rot.goto(10.0, 10.0)
    rot.hw.power_fail.emulate_power_back()
    rot.clear_faults()
    rot.goto(100.0, 30.0)
    s = run_virtual(rot, clock, 2.0)
    assert not s.faults and any(d > 0 for d in _pin_drives(rot.hw.az))


def test_power_fail_input_low_at_start_is_a_fault(tmp_path, monkeypatch):
    from urc.hardware.gpio import PowerFailInput
    monkeypatch.setattr(PowerFailInput, "supply_ok", lambda self: False)   # no edge will come
    rot, clock = _power_fail_rig(tmp_path, "bigras")
    assert [f.kind for f in rot.status().faults] == ["power_fail"]
    with pytest.raises(Exception, match="fault"):
        rot.goto(60.0, 20.0)


def test_encoder_counting_with_motor_off_is_a_fault_that_moves_nothing(tmp_path):
    rot, clock = emulated(next(p for p in EXAMPLES if p.stem == "tartu-urc"), tmp_path)
    run_virtual(rot, clock, 3.0)                  # standing, motor off
    counter = rot.hw.az.sensor.counter
    seq = [0b00, 0b01, 0b11, 0b10]
    state = (1 if counter.a.state else 0) << 1 | (1 if counter.b.state else 0)
    i = seq.index(state)
    for _ in range(30):                           # noise on A/B: 30 counts, shaft still
        i = (i + 1) % 4
        for pin, bit in ((counter.a, 2), (counter.b, 1)):
            if bool(seq[i] & bit) != bool(pin.state):
                (pin.drive_high if seq[i] & bit else pin.drive_low)()
    s = run_virtual(rot, clock, 0.5)
    assert any("motor off" in f.reason for f in s.faults), s.faults
    t0 = s.sim_truth["az"]["deg"]
    s = run_virtual(rot, clock, 3.0)
    assert s.sim_truth["az"]["deg"] == pytest.approx(t0, abs=0.05) and s.az.duty == 0.0


def test_sarcnet_on_an_lsm303agr(tmp_path):
    data = with_emulation(load_config(next(p for p in EXAMPLES if p.stem == "sarcnet-mini"))).to_dict()
    for a in ("az", "el"):
        data["hardware"]["gpio"][a]["compass"] = "lsm303agr"
    data["hardware"]["sim"] = {"wind": False}
    clock = VirtualClock(1000.0)
    rot = build_rotator(Config.from_dict(data), clock, tmp_path, durable_state=False, fast_virtual=True)
    assert set(rot.hw.gpio.i2c_buses[1].devices) == {0x19, 0x1E}
    rot.goto(120.0, 40.0)
    s = run_virtual(rot, clock, 120.0, until=lambda s: not s.moving and abs(s.az_deg - 120) < 0.5
                    and abs(s.el_deg - 40) < 0.5)
    assert not s.faults
    assert abs(s.sim_truth["az"]["deg"] - 120.0) < 1.0 and abs(s.sim_truth["el"]["deg"] - 40.0) < 1.0


def test_relay_slow_pulse_rate_is_a_setting(tmp_path):
    """G4JNT: the slow speed pulses at 2 Hz unless [hardware.gpio.<axis>] relay_pulse_hz says."""
    data = with_emulation(load_config(next(p for p in EXAMPLES if p.stem == "g4jnt"))).to_dict()
    data["hardware"]["gpio"]["el"]["relay_pulse_hz"] = 4.0
    rot = build_rotator(Config.from_dict(data), VirtualClock(1000.0), tmp_path, durable_state=False,
                        fast_virtual=True)
    assert rot.hw.az.motor.pulse_period_s == 0.5 and rot.hw.el.motor.pulse_period_s == 0.25
    rot.hw.close()
    data["hardware"]["gpio"]["el"]["relay_pulse_hz"] = 0
    with pytest.raises(ConfigError, match="relay_pulse_hz"):
        Config.from_dict(data)


@pytest.mark.parametrize("declination_deg", [12.0, -3.5])
def test_emulated_compass_keeps_the_configured_declination(tmp_path, declination_deg):
    """examples/sarcnet-mini.toml says 12.0: emulated, the compass keeps it (the
    simulator's own 12.5 used to replace it) and the emulated site's field agrees, so
    the antenna still goes where it is told."""
    data = with_emulation(load_config(next(p for p in EXAMPLES if p.stem == "sarcnet-mini"))).to_dict()
    assert data["hardware"]["gpio"]["az"]["declination_deg"] == 12.0
    data["hardware"]["gpio"]["az"]["declination_deg"] = declination_deg
    data["hardware"]["sim"] = {"wind": False}
    clock = VirtualClock(1000.0)
    rot = build_rotator(Config.from_dict(data), clock, tmp_path, durable_state=False, fast_virtual=True)
    assert rot.hw.az.sensor.calibration()["declination_deg"] == declination_deg
    rot.goto(200.0, 30.0)
    s = run_virtual(rot, clock, 200.0, until=lambda s: not s.moving and abs(s.az_deg - 200) < 0.5
                    and abs(s.el_deg - 30) < 0.5)
    assert not s.faults and abs(s.sim_truth["az"]["deg"] - 200.0) < 1.0
    rot.hw.close()


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.stem)
def test_urc_run_emulate_process(path, tmp_path):
    """`urc run --config examples/<machine>.toml --emulate` on a laptop: it starts,
    serves its API on the gpio backend with simulator truth, and stops on SIGTERM."""
    import subprocess
    import sys
    import time

    import httpx

    from urc_process import HTTP, free_port
    port = free_port()
    # (its rotctld on a port of its own: the example's 4533 may be another test's meanwhile)
    proc = subprocess.Popen([sys.executable, "-m", "urc", "run", "--config", str(path), "--emulate",
                             "--state-dir", str(tmp_path / "state"), "--port", str(port),
                             "--serve", f"rotctld=tcp:127.0.0.1:{free_port()}"],
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        deadline = time.monotonic() + 60
        status = None
        while time.monotonic() < deadline and status is None:
            assert proc.poll() is None, proc.stdout.read()
            try:
                status = HTTP.get(f"http://127.0.0.1:{port}/api/status", timeout=1.0).json()
            except httpx.HTTPError:
                time.sleep(0.2)
        assert status is not None and status["simulator_truth"] is not None and not status["faults"]
        info = HTTP.get(f"http://127.0.0.1:{port}/api/info", timeout=2.0).json()
        assert info["backend"] == "gpio" and info["simulator"]
    finally:
        proc.terminate()
        proc.wait(timeout=30)
    assert proc.returncode == 0


def test_current_sense_through_the_adc_trips_overcurrent(tmp_path):
    """tartu-urc: the VNH5019 CS outputs on an MCP3008. The motor current the rotator
    sees comes through the ADC (cut the CS wire and it reads 0 while the motor runs);
    a jam trips the overcurrent fault before the stall detector would."""
    rot, clock = emulated(next(p for p in EXAMPLES if p.stem == "tartu-urc"), tmp_path)
    fake = rot.hw.gpio.fake_spi[0]
    rot.goto(150.0, 60.0)
    s = run_virtual(rot, clock, 3.0)
    truth_a = abs(s.sim_truth["az"]["current_a"])
    assert truth_a > 0.3 and s.az.current_a == pytest.approx(truth_a, abs=0.05)
    lsb_a = 3.3 / 1024 / 0.14
    assert {t[1] for t in fake.transactions} == {0, 1}
    assert s.az.current_a / lsb_a == pytest.approx(round(s.az.current_a / lsb_a), abs=1e-6)  # ADC counts
    cs = fake.inputs.pop(0)                       # the az CS wire cut: 0 V on CH0
    s = run_virtual(rot, clock, 0.1)
    assert s.az.current_a == 0.0 and abs(s.sim_truth["az"]["current_a"]) > 0.3
    fake.inputs[0] = cs
    rot.hw.world.inject("az", "jam")
    s = run_virtual(rot, clock, 0.6)               # overcurrent holds 0.25 s; a stall takes > 1.5 s
    assert [(f.kind, f.axis) for f in s.faults] == [("overcurrent", "az")], s.faults
    assert s.az.duty == 0.0 and s.el.duty == 0.0


def test_no_current_sense_reads_zero_as_on_iron(tmp_path):
    rot, clock = emulated(next(p for p in EXAMPLES if p.stem == "berkeley"), tmp_path)
    rot.goto(100.0, 30.0)
    s = run_virtual(rot, clock, 2.0)
    assert abs(s.sim_truth["az"]["current_a"]) > 0.1 and s.az.current_a == 0.0


def test_encoder_index_rereferences_in_an_emulated_run(tmp_path):
    """tartu-urc with its Track N wired: the emulated shaft pulses Z at 100 deg; edges
    lost on the way leave the reading 0.8 deg off, and the
    next pass over the index puts it right."""
    data = with_emulation(load_config(next(p for p in EXAMPLES if p.stem == "tartu-urc"))).to_dict()
    data["hardware"]["sim"] = {"wind": False}
    az = data["hardware"]["gpio"]["az"]
    az["pins"]["enc_z"] = 19
    az["encoder_index_deg"] = 100.0
    clock = VirtualClock(1000.0)
    rot = build_rotator(Config.from_dict(data), clock, tmp_path, durable_state=False, fast_virtual=True)
    enc, quad = rot.hw.az.sensor, rot.hw.gpio.emulation["az"]

    def go(az_deg):
        rot.goto(az_deg, 30.0)
        return run_virtual(rot, clock, 60.0, until=lambda s: not s.moving and abs(s.az_deg - az_deg) < 0.3
                           and s.az.mode in ("holding", "idle"))

    go(80.0)
    assert enc.index_rereferences == 0 and not enc.index_seen()
    errors0 = enc.counter.errors()
    # 2 lost reports of A on the way: each loses the double step (2 counts) and, decoding
    # from the reports' levels, B's next two reports count +1 -1 until A's next report
    # (an error: A already had that level) brings the decoder back: 4 counts each (the
    # encoder's bound, 0.8 deg, stays under its 1 deg fault limit)
    quad.miss = 2
    s = go(90.0)
    assert enc.counter.errors() - errors0 == 2 and enc.uncertainty_deg() == pytest.approx(0.8)
    assert s.sim_truth["az"]["deg"] - s.az_deg == pytest.approx(0.8, abs=0.2)
    corrections = []
    rot.goto(130.0, 30.0)                           # over the index at 100 deg
    s = run_virtual(rot, clock, 60.0, on_tick=lambda _s: corrections.append(enc.last_index_correction_deg),
                    until=lambda s: not s.moving and abs(s.az_deg - 130.0) < 0.3 and s.az.mode in ("holding", "idle"))
    assert not s.faults, s.faults
    assert enc.index_rereferences >= 1 and max(corrections) == pytest.approx(0.8, abs=0.15)
    assert enc.lost_edges() == 0                    # the mark wiped the bound
    assert abs(s.sim_truth["az"]["deg"] - s.az_deg) < 0.25
    # back over it the other way: the reading was right, the index only confirms it
    pulses, n = enc.counter.index_pulses, enc.index_rereferences
    s = go(70.0)
    assert enc.counter.index_pulses > pulses
    assert enc.index_rereferences == n or abs(enc.last_index_correction_deg) <= 0.1 + 1e-9
    assert abs(s.sim_truth["az"]["deg"] - s.az_deg) < 0.25


def test_lost_encoder_edges_past_the_bound_are_a_sensor_fault(tmp_path):
    """Review 20 #3: 7 lost reports of A leave tartu-urc's reading 2.8 deg off; the
    encoder's bound (4 counts per lost report) passes its 1 deg limit, so the axis
    reports a sensor fault instead of calling that position known."""
    data = with_emulation(load_config(next(p for p in EXAMPLES if p.stem == "tartu-urc"))).to_dict()
    data["hardware"]["sim"] = {"wind": False}
    clock = VirtualClock(1000.0)
    rot = build_rotator(Config.from_dict(data), clock, tmp_path, durable_state=False, fast_virtual=True)
    rot.hw.gpio.emulation["az"].miss = 7
    rot.goto(80.0, 30.0)
    s = run_virtual(rot, clock, 60.0, until=lambda s: any(f.axis == "az" for f in s.faults))
    (f,) = [f for f in s.faults if f.axis == "az"]
    assert "encoder lost" in f.reason and "re-reference" in f.reason, f


#: what a dead az sensor looks like through each machine's parts: a chip that NACKs is
#: unreadable; encoder or reed lines that carry nothing read as an axis that does not
#: turn (with current sense: at running current); an open pot wiper reads 0 V: on an
#: MCP3008 with no reference input 0 counts is what a missing chip reads too, so it is
#: unreadable (review 20 #9), elsewhere a jump or out of range
DEAD_SENSOR_FAULTS = {"tartu-urc": {"sensor_stuck"}, "bigras": {"stall"}, "berkeley": {"sensor_dead"},
                      "sarcnet-mini": {"sensor_dead"}, "g4jnt": {"sensor_dead"},
                      "g5500": {"sensor_jump", "sensor_range"}, "trc-turntable": {"stall"}}


# (not satnogs-v3: its position is the step count, no sensor part for the fault to reach)
@pytest.mark.parametrize("path", [p for p in EXAMPLES if p.stem != "satnogs-v3"], ids=lambda p: p.stem)
def test_simulator_sensor_dead_reaches_the_emulated_part(path, tmp_path):
    rot, clock = emulated(path, tmp_path)
    world = rot.hw.world
    lo, hi = rot.status().limits["az"]
    rot.goto_az(min(hi - 5.0, 150.0))
    run_virtual(rot, clock, 2.0)
    assert rot.status().moving and not rot.status().faults
    world.inject("az", "sensor_dead")
    s = run_virtual(rot, clock, 8.0, until=lambda s: bool(s.faults))
    assert {f.kind for f in s.faults if f.axis == "az"} & DEAD_SENSOR_FAULTS[path.stem], s.faults
    t0 = run_virtual(rot, clock, 2.0).sim_truth["az"]["deg"]
    s = run_virtual(rot, clock, 2.0)
    assert s.az.duty == 0.0 and s.sim_truth["az"]["deg"] == pytest.approx(t0, abs=0.05)
    rot.hw.close()


def test_power_fail_edge_does_not_wait_for_the_disk(tmp_path):
    """The state write runs on a thread of its own: the pin callback thread (which also
    counts the encoder edges while the axes coast) returns while the disk is still busy."""
    import threading
    rot, clock = _power_fail_rig(tmp_path, "tartu-urc")
    pf, disk_free, saved = rot.hw.power_fail, threading.Event(), []

    def slow_save():
        disk_free.wait(5.0)                       # an SD card that takes its time
        saved.append(rot.save_now())
        return saved[-1]
    pf.save = slow_save
    rot.goto(120.0, 40.0)
    run_virtual(rot, clock, 3.0)
    pf.emulate_power_fail()                       # returns although the write has not begun
    assert pf.saver.is_alive() and not saved
    assert [f.kind for f in rot.status().faults] == ["power_fail"] and _pin_drives(rot.hw.az) == [0.0]
    disk_free.set()
    pf.saver.join(5.0)
    assert saved == [True]


def test_slow_read_stalls_an_emulated_bus_and_the_watchdog_sees_it(tmp_path):
    """Real time, the control loop on its thread: a bus transaction of the berkeley AS5600
    hangs 0.7 s (the simulator's slow_read); the tick that made it is seen late and
    the motors are held (the same as the sim backend's process test in test_app)."""
    import time

    from urc.clock import RealClock
    from urc.rotator.loop import ControlThread
    data = with_emulation(load_config(next(p for p in EXAMPLES if p.stem == "berkeley"))).to_dict()
    data["hardware"]["sim"] = {"wind": False}
    clock = RealClock()
    rot = build_rotator(Config.from_dict(data), clock, tmp_path, durable_state=False)
    control = ControlThread(rot, clock).start()
    try:
        time.sleep(0.3)
        assert rot.status().loop["stalls"] == 0
        rot.hw.world.inject("az", "slow_read", delay_s=0.7)
        deadline = time.monotonic() + 10.0
        while time.monotonic() < deadline and rot.status().loop["stalls"] < 1:
            time.sleep(0.05)
        loop = rot.status().loop
        assert loop["stalls"] == 1 and loop["last_stall_ms"] >= 700, loop
    finally:
        control.stop()
        rot.shutdown()
        rot.hw.close()


def _ticks_of_a_goto(path: Path, state_dir: Path, seconds: float = 6.0) -> list[tuple]:
    """Every tick of a goto on the emulated example: each output pin's level, what the
    controller reads and the simulator's truth (compared bit for bit)."""
    rot, clock = emulated(path, state_dir)
    factory = rot.hw.gpio.pin_factory
    outputs = sorted((p for p in factory.pins.values() if p.function == "output"), key=lambda p: p.info.name)
    s = rot.status()
    rot.goto(*_a_goto(s))
    ticks: list[tuple] = []

    def record(s) -> None:
        truth = s.sim_truth
        ticks.append((s.az_deg, s.el_deg, truth["az"]["deg"], truth["az"]["gear_deg"], truth["el"]["deg"],
                      truth["el"]["gear_deg"], tuple(float(p.state) for p in outputs), tuple(f.reason for f in s.faults)))
    run_virtual(rot, clock, seconds, on_tick=record)
    rot.hw.close()
    return ticks


class _RacingWall:
    """A wall clock running far ahead of the virtual one: 0.25 s more at every read."""

    def __init__(self, start_s: float):
        self.t_s = start_s

    def __call__(self) -> float:
        self.t_s += 0.25
        return self.t_s


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.stem)
def test_emulated_run_is_a_function_of_the_virtual_clock(path, tmp_path, monkeypatch):
    """The emulated backend on the virtual clock depends on nothing else: a goto flown
    twice gives the same pins, readings and truth at every tick, the second time with a
    wall clock that races ahead. Wall time or thread timing leaking into a tick (a
    time.monotonic() pacing a part, a callback thread) would make the runs differ."""
    import time

    first = _ticks_of_a_goto(path, tmp_path / "first")
    monkeypatch.setattr(time, "monotonic", _RacingWall(time.monotonic()))
    monkeypatch.setattr(time, "perf_counter", _RacingWall(time.perf_counter()))
    monkeypatch.setattr(time, "time", _RacingWall(time.time()))
    second = _ticks_of_a_goto(path, tmp_path / "second")
    assert len(first) == len(second) == 300
    moved = [abs(t[2] - first[0][2]) + abs(t[4] - first[0][4]) for t in first]
    assert max(moved) > 1.0, "the goto should move the axes"
    diverged = next((i for i, (a, b) in enumerate(zip(first, second)) if a != b), None)
    assert diverged is None, (f"tick {diverged}: {first[diverged]} then {second[diverged]}")


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.stem)
def test_emulated_pins_keep_no_growing_history(path, tmp_path):
    """gpiozero's MockPin records every level change; the heartbeat output toggles each
    tick, so a day of ``urc run --emulate`` would hold millions of them. Only the last
    tick's changes are kept."""
    rot, clock = emulated(path, tmp_path)
    rot.goto(*_a_goto(rot.status()))
    run_virtual(rot, clock, 10.0)
    pins = rot.hw.gpio.pin_factory.pins.values()
    assert max(len(p.states) for p in pins) <= 4, {p.info.name: len(p.states) for p in pins}
    rot.hw.close()
