"""The safety chain's faults, modelled, and the start-up self-test that catches them
(issue 35): a stuck enable, a floating trigger and a welded contact each fail the test
with the reason; a relay dropping out within the margin passes with the time measured.
On the simulator's model and on the emulated gpio backend (mock pins, the read-back
driven from the model), all on a virtual clock."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from urc.assembly import hardware_options, settings_from_config
from urc.cli import with_emulation
from urc.clock import VirtualClock
from urc.config import Config, load_config
from urc.hardware import build_hardware
from urc.hardware.safety_test import self_test
from urc.hardware.sim.safety import MotorPowerEnable
from urc.profiles import get_profile

TIMEOUT_S, MARGIN_S = 0.22, 0.05
EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def sim_hw(tmp_path, timeout_s=TIMEOUT_S, **opts):
    clock = VirtualClock(0.0)
    hw = build_hardware("sim", get_profile("tartu-urc"), clock, tmp_path,
                        {"wind": False, "truth_file": None, "motor_enable_timeout_s": timeout_s, **opts})
    hw.poll(0.0)
    return hw, clock


def emulated_hw(tmp_path, example="tartu-urc", **gpio):
    data = with_emulation(load_config(EXAMPLES / f"{example}.toml")).to_dict()
    data["hardware"]["gpio"].update(gpio)
    data["hardware"]["sim"] = {"wind": False}
    cfg = Config.from_dict(data)
    clock = VirtualClock(1000.0)
    hw = build_hardware("gpio", settings_from_config(cfg).caps, clock, tmp_path, hardware_options(cfg))
    hw.poll(clock.now_s())
    return hw, clock


BACKENDS = {"sim": sim_hw, "emulated": emulated_hw}

#: each fault that keeps the motors powered with the heartbeat stopped, and what the
#: reason must name
NEVER_CUTS = {"enable_stuck": "Q stuck high or Q1 failed shorted",
              "trigger_floating": "a trigger floating now (the heartbeat wire broken with no 100 kOhm",
              "contact_welded": "a welded relay contact"}


@pytest.mark.parametrize("backend", BACKENDS)
def test_a_sound_chain_passes_with_its_timeout_measured(backend, tmp_path):
    hw, clock = BACKENDS[backend](tmp_path)
    r = self_test(hw, TIMEOUT_S, MARGIN_S, clock)
    assert r.ok is True, r.why
    assert r.measured_s == pytest.approx(TIMEOUT_S, abs=0.002)
    assert r.resolution_s <= 0.0011
    assert re.search(r"fell 0\.22[01] s after the last heartbeat edge at the relay's contact", r.why), r.why
    assert hw.world.motor_power()             # re-armed: the heartbeat brought it back
    assert hw.world.enable.trips == 1         # the one cut the test made


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("fault", NEVER_CUTS)
def test_a_chain_that_does_not_cut_fails_and_says_why(backend, fault, tmp_path):
    hw, clock = BACKENDS[backend](tmp_path)
    hw.world.inject("chain", fault)
    r = self_test(hw, TIMEOUT_S, MARGIN_S, clock)
    assert r.ok is False and r.measured_s is None
    assert "the chain does not cut" in r.why and NEVER_CUTS[fault] in r.why, r.why
    assert "still showed the enable on 0.27" in r.why
    assert hw.world.motor_power() and hw.world.enable.trips == 0     # the motors never lost power
    hw.world.clear("chain")
    assert self_test(hw, TIMEOUT_S, MARGIN_S, clock).ok is True      # repaired: it passes


@pytest.mark.parametrize("backend", BACKENDS)
def test_a_relay_drop_out_within_the_margin_passes_with_the_time_it_took(backend, tmp_path):
    hw, clock = BACKENDS[backend](tmp_path)
    hw.world.inject("chain", "relay_dropout", delay_s=0.03)
    r = self_test(hw, TIMEOUT_S, MARGIN_S, clock)
    assert r.ok is True, r.why
    assert r.measured_s == pytest.approx(TIMEOUT_S + 0.03, abs=0.002)


@pytest.mark.parametrize("backend", BACKENDS)
def test_a_relay_slow_to_release_fails(backend, tmp_path):
    hw, clock = BACKENDS[backend](tmp_path)
    hw.world.inject("chain", "relay_dropout", delay_s=0.2)
    r = self_test(hw, TIMEOUT_S, MARGIN_S, clock)
    # (the margin named: a release slower by less, a plain diode's tens of ms, passes)
    assert r.ok is False and "a relay releasing more than 0.05 s late" in r.why, r.why


def test_a_chain_that_cuts_too_soon_fails(tmp_path):
    """A monostable whose period is not the configured one (here 0.1 s against 0.22 s):
    a chain that drops at once is wrong too."""
    hw, clock = sim_hw(tmp_path, timeout_s=0.1)
    r = self_test(hw, TIMEOUT_S, MARGIN_S, clock)
    assert r.ok is False and r.measured_s == pytest.approx(0.1, abs=0.002)
    assert "sooner than 0.170 to 0.270 s" in r.why, r.why


@pytest.mark.parametrize("wiring", ["at the wrong level", "always off"])
def test_a_chain_that_never_comes_on_fails(wiring, tmp_path):
    """The read-back never shows the enable (no coil supply, a broken chain, a read-back
    at the wrong level): urc cannot show that it cuts."""
    hw, clock = sim_hw(tmp_path)
    sense = hw.enable_sense

    class Miswired:
        point = "contact"

        def read(self):
            return not sense.read() if wiring == "at the wrong level" else False

    hw.enable_sense = Miswired()
    r = self_test(hw, TIMEOUT_S, MARGIN_S, clock)
    assert r.ok is False and "never showed the enable on" in r.why, r.why


def test_without_a_read_back_nothing_is_measured(tmp_path):
    hw, clock = sim_hw(tmp_path, motor_enable_sense=None)
    r = self_test(hw, TIMEOUT_S, MARGIN_S, clock)
    assert r.ok is None and r.measured_s is None
    assert r.why == "not measured: no read-back input (motor_enable_sense_pin)"
    hw, clock = emulated_hw(tmp_path, motor_enable_sense_pin=None)
    assert self_test(hw, TIMEOUT_S, MARGIN_S, clock).ok is None


def test_a_read_back_on_q_is_blind_to_a_welded_contact(tmp_path):
    """Q falls whatever the contact does: only a read-back on the contact sees it welded
    (docs/hardware.md). A stuck Q shows on either."""
    hw, clock = emulated_hw(tmp_path, motor_enable_sense_point="q")
    hw.world.inject("chain", "contact_welded")
    assert self_test(hw, TIMEOUT_S, MARGIN_S, clock).ok is True
    hw.world.inject("chain", "enable_stuck")
    r = self_test(hw, TIMEOUT_S, MARGIN_S, clock)
    assert r.ok is False and "Q still showed the enable on" in r.why and "welded" not in r.why


def test_the_emulated_read_back_is_a_pin_at_its_active_level(tmp_path):
    """An active-low read-back (an optocoupler pulling the pin low while the motors have
    power): the mock pin is low while on, and the test passes the same."""
    hw, clock = emulated_hw(tmp_path, motor_enable_sense_active_low=True)
    pin = hw.enable_sense.input.pin
    assert pin.state and not hw.enable_sense.read()          # no heartbeat yet: off, high
    hw.heartbeat.write(True)
    hw.poll(clock.now_s())
    assert not pin.state and hw.enable_sense.read()
    assert self_test(hw, TIMEOUT_S, MARGIN_S, clock).ok is True


def test_the_self_test_runs_on_a_real_clock(tmp_path):
    """The same code on a real clock (polled in wall time): a short-timeout chain on the
    model, read through the real clock's now; the verdict, not the timing, is checked."""
    import time

    class _Mono:
        def now_s(self):
            return time.monotonic()

    clock = _Mono()
    hw = build_hardware("sim", get_profile("tartu-urc"), clock, tmp_path,
                        {"wind": False, "truth_file": None, "heartbeat_file": None, "motor_enable_timeout_s": 0.05})
    hw.poll(clock.now_s())
    r = self_test(hw, 0.05, 0.5, clock)       # (a wide margin: a loaded machine wakes late)
    assert r.ok is True and 0.05 <= r.measured_s, r
    hw.world.inject("chain", "contact_welded")
    assert self_test(hw, 0.05, 0.05, clock).ok is False
    hw.close()


# ------------------------------------------------------------------- the model
def test_the_model_q_and_the_contact():
    t = [0.0]
    part = MotorPowerEnable(0.2, lambda: t[0])
    part.heartbeat(True)
    part.inject("relay_dropout", delay_s=0.03)
    assert part.q_at(0.19) and not part.q_at(0.2)
    assert part.powered_at(0.22) and not part.powered_at(0.23) and part.cut_at_s() == pytest.approx(0.23)
    part.inject("contact_welded")
    assert not part.q_at(5.0) and part.powered_at(5.0) and part.cut_at_s() == float("inf")
    part.clear()
    assert part.cut_at_s() == pytest.approx(0.2) and part.dropout_s == 0.0
    part.inject("enable_stuck")
    assert part.q_at(5.0) and part.powered_at(5.0)
    part.clear("enable_stuck")
    with pytest.raises(ValueError):
        part.inject("melted")


def test_a_floating_trigger_ignores_the_heartbeat_and_holds_after_the_hum_ends():
    """The heartbeat pin no longer reaches +TR: its writes change nothing, hum keeps Q
    up; once the trigger is repaired, hum's last edge was then."""
    t = [0.0]
    part = MotorPowerEnable(0.2, lambda: t[0])
    part.inject("trigger_floating")
    assert part.powered_at(0.0)                # hum: on without any heartbeat
    part.heartbeat(True)
    assert part.edges == 0
    t[0] = 3.0
    part.clear("trigger_floating")
    assert part.powered_at(3.19) and not part.powered_at(3.2)


@pytest.mark.parametrize("fault", ["enable_stuck", "contact_welded", "trigger_floating"])
def test_a_frozen_controller_runs_on_with_a_chain_that_does_not_cut(fault, tmp_path):
    """The faults act on the simulated iron: with the chain stuck the motor runs on
    through a freeze; repaired, the power goes at once (the last edge is long past), or
    a timeout after hum's last edge for a trigger that floated."""
    hw, clock = sim_hw(tmp_path)
    world = hw.world
    hw.heartbeat.write(True)
    hw.az.brake.set_released(True)
    clock.advance(0.1)
    hw.poll(clock.now_s())
    world.inject("chain", fault)
    hw.az.motor.set_drive(1.0)
    clock.advance(2.0)                          # frozen: no edge for 2 s
    hw.poll(clock.now_s())
    truth = hw.sim_truth()
    assert truth["motor_enable"]["powered"] and truth["motor_enable"]["faults"] == [fault]
    assert truth["az"]["rate_deg_per_s"] > 1.0
    world.clear("chain", fault)
    if fault == "trigger_floating":
        assert world.motor_power()
        clock.advance(TIMEOUT_S + 0.01)
        hw.poll(clock.now_s())
    assert not world.motor_power() and world.enable.trips == 1
    assert world.faults()["chain"] == {}


def test_chain_faults_from_the_options_and_refused_without_the_part(tmp_path):
    hw, clock = sim_hw(tmp_path, fault_injection=[{"axis": "chain", "kind": "contact_welded"}])
    assert hw.world.faults()["chain"] == {"contact_welded": {}} and hw.world.motor_power()
    hw, clock = sim_hw(tmp_path / "b", timeout_s=None)
    with pytest.raises(ValueError, match="no safety chain modelled"):
        hw.world.inject("chain", "enable_stuck")
    assert hw.enable_sense is None


def test_a_stall_of_the_test_itself_never_fails_a_good_chain():
    """Review of issue 35: a reading timed before it was taken (this process descheduled
    80 ms between the clock and the pin) made a good chain "fall too soon". Each verdict
    now uses the bound that can only make a good chain pass."""
    class Clock:
        t = 0.0

        def now_s(self):
            return self.t

        def advance(self, dt):
            self.t += dt
    clk = Clock()

    class Chain:   # a good chain: on until 0.22 s after the last rising edge
        last = None
        level = False

        def write(self, v):
            if v and not self.level:
                self.last = clk.t
            self.level = v

        def on(self):
            return self.last is not None and clk.t < self.last + 0.22
    chain = Chain()

    class Sense:
        point = "contact"
        stalled = False

        def read(self):
            if not self.stalled and chain.last is not None and clk.t - chain.last > 0.16:
                self.stalled = True
                clk.t += 0.08   # descheduled between the clock and the pin
            return chain.on()

    class Hw:
        heartbeat, enable_sense = chain, Sense()

        def poll(self, _t):
            pass
    r = self_test(Hw(), 0.22, 0.05, clk)
    assert r.ok is True and 0.17 <= r.measured_s <= 0.27 + 0.08, (r.ok, r.measured_s, r.why)
