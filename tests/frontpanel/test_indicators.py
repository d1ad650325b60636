"""Status LEDs (direction, error blink codes) and the beeper on emulated pins."""

from __future__ import annotations

from urc.frontpanel.indicators import BLINK_GAP_S, BLINK_OFF_S, BLINK_ON_S, blink_on, fault_code


def flashes(code: int, step_s: float = 0.01) -> int:
    """Count the rising edges of one period of a blink code."""
    period = code * (BLINK_ON_S + BLINK_OFF_S) + BLINK_GAP_S
    states = [blink_on(code, i * step_s) for i in range(round(period / step_s))]
    return sum(1 for a, b in zip([False] + states, states) if b and not a)


def test_blink_codes_flash_their_number():
    assert [flashes(c) for c in range(1, 7)] == [1, 2, 3, 4, 5, 6]
    assert fault_code("stall") == 1 and fault_code("sensor_jump") == 3 and fault_code("watchdog") == 6


def led_flashes_per_period(rig, code: int) -> int:
    """Rising edges of the error LED over one period of ``code``, on the virtual clock
    (counted circularly: the period may start in the middle of a flash)."""
    samples = []
    period_s = code * (BLINK_ON_S + BLINK_OFF_S) + BLINK_GAP_S
    rig.run(period_s, on_tick=lambda s: samples.append(rig.led("fault")))
    return sum(1 for a, b in zip([samples[-1]] + samples, samples) if b and not a)


def test_latched_jam_blinks_its_code_and_refuses_buttons(panel_rig):
    rig = panel_rig()
    rig.settle()
    assert not rig.led("fault")
    rig.bench.world.inject("az", "jam")  # tartu-urc: the motor current trips first
    rig.rot.goto(90.0, 90.0)
    st = rig.run(10.0, until=lambda s: bool(s.faults))
    assert st.faults and st.faults[0].kind == "overcurrent"
    assert rig.panel.beeper.played[-1] == "fault"
    assert led_flashes_per_period(rig, 5) == 5
    # a turn button is refused with the fault; the beeper says so
    rig.press("cw")
    rig.run(0.2)
    assert rig.panel.beeper.played[-1] == "refused"
    assert "fault latched" in rig.panel.controls.last_refusal
    assert rig.rot.status().az.duty == 0
    rig.release("cw")


def test_sensor_fault_blinks_code_3(panel_rig):
    rig = panel_rig()
    rig.rot.goto(60.0, 60.0)
    rig.run(1.0)
    rig.bench.world.inject("el", "sensor_dead")
    st = rig.run(2.0, until=lambda s: bool(s.faults))
    assert st.faults[0].kind == "sensor_dead"
    assert led_flashes_per_period(rig, 3) == 3


def test_stall_blinks_code_1(panel_rig):
    rig = panel_rig(config={"faults": {"overcurrent_a": 1000.0}})  # no current trip: a stall
    rig.rot.goto(60.0, 0.0)
    rig.run(0.5)
    rig.bench.world.inject("az", "jam")
    st = rig.run(10.0, until=lambda s: bool(s.faults))
    assert st.faults[0].kind == "stall"
    assert led_flashes_per_period(rig, 1) == 1


def test_uncertain_position_lights_the_error_led_steady(panel_rig):
    rig = panel_rig()
    rig.rot.axes["az"].uncertainty_deg = 2.0  # what a crash mid-move leaves behind
    samples = []
    rig.run(3.0, on_tick=lambda s: samples.append(rig.led("fault")))
    assert all(samples)
