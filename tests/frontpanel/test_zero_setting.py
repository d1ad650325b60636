"""The G4JNT power-on zero-setting procedure (seed 003) with the panel's buttons:
switched on with both turn buttons held, L/R change Z, SLOW stores it."""

from __future__ import annotations

import pytest

from urc.errors import CommandRejected
from urc.frontpanel.lcd import CharLcd, Pcf8574Hd44780
from urc.procedures.calibration import average_reading_deg


def test_zero_setting_changes_and_stores_z(panel_rig):
    chip = Pcf8574Hd44780(0x27, 20, 2)
    rig = panel_rig("g4jnt", display=CharLcd(chip, 0x27, 20, 2), held=("cw", "ccw"))
    zero = rig.panel.zero
    assert zero is not None and zero.active and zero.label == "Z" and zero.value_deg == 0.0
    rig.release("cw")
    rig.release("ccw")
    rig.settle()
    az_before = rig.rot.status().az.pos_deg
    rig.panel.refresh_display()
    assert chip.text() == ["ZERO SET   Z    0.0 ", "L/R change SLOW=save"]
    # no other source moves the rotator meanwhile, and the buttons do not jog
    with pytest.raises(CommandRejected, match="ZERO SET"):
        rig.rot.goto(100.0, 0.0)
    for _ in range(3):
        rig.press("cw")
        rig.run(0.1)
        rig.release("cw")
    assert zero.value_deg == pytest.approx(0.3)
    rig.press("cw")            # held: repeats after 0.5 s, every 0.1 s
    rig.run(1.02)
    rig.release("cw")
    assert zero.value_deg == pytest.approx(0.3 + 0.1 + 6 * 0.1)
    rig.press("ccw")
    rig.release("ccw")
    assert zero.value_deg == pytest.approx(0.9)
    assert rig.rot.status().az.duty == 0 and abs(rig.rot.status().az.pos_deg - az_before) < 0.5
    rig.panel.refresh_display()
    assert chip.text()[0] == "ZERO SET   Z    0.9 "
    sensor = rig.rot.hw.axis("az").sensor
    theta_before = average_reading_deg(sensor, 400)
    bearing_before = rig.rot.status().az_deg
    rig.press("slow")          # store
    rig.release("slow")
    assert not zero.active and rig.panel.beeper.played[-1] == "stored"
    st = rig.run(1.0)
    # stored as entered, in the document's 0.1 deg units (it was 0.9 +- 0.15: one noisy
    # pot reading folded back into Z by the re-reference)
    z_stored = sensor.calibration()["Z"]
    assert z_stored == pytest.approx(0.9, abs=1e-9)
    # and added to the bearing, exactly: Z turns bearings (bearing = theta + Z), not the
    # pot angle theta, whose readings stay as they were (within what 400 readings tell)
    assert abs(average_reading_deg(sensor, 400) - theta_before) < 0.05
    assert st.offsets["az"] == pytest.approx(0.9), "Z is added to the bearing"
    assert (st.az_deg - bearing_before) % 360.0 == pytest.approx(0.9, abs=0.3)
    assert st.az.pos_deg == pytest.approx(az_before, abs=0.3)
    assert st.local_control == ()
    rig.rot.goto(10.0, 0.0)    # back to normal operation
    rig.panel.refresh_display()
    assert chip.text()[0].startswith("AZ ")
    # kept across a restart, like the PIC's non-volatile memory
    rig.rot.save_now()
    again = rig.bench.restart()
    assert again.rot.hw.axis("az").sensor.calibration()["Z"] == pytest.approx(0.9, abs=1e-9)


def test_zero_setting_refused_value_stays_in_the_procedure(panel_rig):
    rig = panel_rig("g4jnt", held=("cw", "ccw"))
    rig.release("cw")
    rig.release("ccw")
    rig.settle()
    rig.press("ccw")
    rig.run(3.0)               # -0.1, repeats, then 1 deg steps: a Z below 0
    rig.release("ccw")
    assert rig.panel.zero.value_deg < -5
    rig.rot.hold_local("ir", True)      # another local control: the rotator refuses the set
    rig.press("slow")
    rig.release("slow")
    assert rig.panel.zero.active and rig.panel.beeper.played[-1] == "refused"
    assert rig.rot.hw.axis("az").sensor.calibration()["Z"] == 0.0
    rig.rot.hold_local("ir", False)
    # a Z below 0 is a bearing like any other (it used to be refused as 'below the az 0
    # limit': the limits belong to the pot angle, Z only turns bearings)
    rig.press("slow")
    rig.release("slow")
    assert not rig.panel.zero.active and rig.panel.beeper.played[-1] == "stored"
    assert rig.rot.hw.axis("az").sensor.calibration()["Z"] == rig.panel.zero.value_deg


def test_without_both_buttons_no_zero_setting(panel_rig):
    rig = panel_rig("g4jnt", held=("cw",))
    assert rig.panel.zero is None
    rig.release("cw")


def test_zero_setting_on_a_sensor_without_z_re_references(panel_rig):
    rig = panel_rig("tartu-urc", held=("cw", "ccw"))  # incremental encoder: no Z constant
    zero = rig.panel.zero
    assert zero.label == "AZ"
    rig.release("cw")
    rig.release("ccw")
    for _ in range(5):
        rig.press("cw")
        rig.release("cw")
    rig.press("slow")
    rig.release("slow")
    st = rig.run(0.5)
    assert st.az.pos_deg == pytest.approx(zero.value_deg, abs=0.06)
    assert zero.value_deg == pytest.approx(round(0.05 + 0.5, 1), abs=0.11)
