"""The G4JNT power-on zero-setting procedure (seed 003), with the panel's buttons.

Switched on with both turn buttons held, the G4JNT controller shows its zero offset Z
(the bearing of the reference end stop) instead of the bearing; the left/right buttons
change it and the 'slow' button stores it in non-volatile memory, after which the
controller runs normally with the new Z.

On urc: Z is the azimuth sensor's own ``Z`` constant when it has one (a ratiometric pot,
as on the G4JNT), stored exactly as set through :func:`calibration.apply_sensor_calibration`
(an ApplyCalibration query)
(the axis adopts the new bearing; the state file keeps Z across restarts; nothing moves).
Precision is the document's unit, 0.1 deg: Z is kept to the step it was set in, and the
bearing moves by exactly Z; a single reading is still quantised by the 10-bit pot. A sensor without
a Z constant gets the equivalent: the procedure edits the azimuth the rotator reads now,
stored as a re-reference (Tartu WRAZ). Steps of 0.1 deg (the document's unit); a held
button repeats after 0.5 s every 0.1 s, in 1 deg steps after 2 s. While the procedure
runs it holds a local control, so no other source moves the rotator.
"""

from __future__ import annotations

from ..protocols.poses import extended_pose_deg
from ..protocols.single_axis import wire_status
from ..model.messages import ApplyCalibration, SensorCalibrations
from ..model.effects import ask

HOLD_NAME = "ZERO SET"
REPEAT_AFTER_S = 0.5
REPEAT_EVERY_S = 0.1
FAST_AFTER_S = 2.0
STEP_DEG = 0.1
FAST_STEP_DEG = 1.0


class ZeroSetting:
    def __init__(self, rotator):
        self.rotator = rotator
        self.cal = self._sensor_calibration()
        if self.cal is not None:
            self.label, self.value_deg = "Z", float(self.cal["Z"])
        else:
            self.label, self.value_deg = "AZ", round(extended_pose_deg(wire_status(rotator.status()))[0], 1)
        self.active = True
        rotator.hold_local(HOLD_NAME, True)
        #: direction held (-1 left/CCW, +1 right/CW) and since when, for repeats
        self._held: dict[int, float] = {}
        self._next_repeat_s: dict[int, float] = {}

    def _sensor_calibration(self) -> dict | None:
        try:
            cal = ask(self.rotator, SensorCalibrations())["az"]
        except Exception:  # no such sensor interface (a bridged controller)
            return None
        return cal if "Z" in cal else None

    def press(self, direction: int, now_s: float) -> None:
        self._step(direction, STEP_DEG)
        self._held[direction] = now_s
        self._next_repeat_s[direction] = now_s + REPEAT_AFTER_S

    def release(self, direction: int) -> None:
        self._held.pop(direction, None)
        self._next_repeat_s.pop(direction, None)

    def update(self, now_s: float) -> None:
        for direction, since_s in list(self._held.items()):
            while now_s >= self._next_repeat_s[direction]:
                at_s = self._next_repeat_s[direction]
                self._step(direction, FAST_STEP_DEG if at_s - since_s >= FAST_AFTER_S else STEP_DEG)
                self._next_repeat_s[direction] = at_s + REPEAT_EVERY_S

    def _step(self, direction: int, step_deg: float) -> None:
        self.value_deg = round(self.value_deg + direction * step_deg, 1)

    def store(self) -> None:
        """Save the value (the 'slow' button) and return to normal operation. A value the
        rotator refuses (CommandRejected, e.g. outside the limits) propagates and the
        procedure stays active."""
        self.rotator.hold_local(HOLD_NAME, False)   # the re-reference must not be refused
        try:
            if self.cal is not None:
                ask(self.rotator, ApplyCalibration("az", {**self.cal, "Z": self.value_deg}))
            else:
                self.rotator.set_position(az_deg=self.value_deg, local=True)
        except Exception:
            self.rotator.hold_local(HOLD_NAME, True)
            raise
        self.active = False

    def cancel(self) -> None:
        self.rotator.hold_local(HOLD_NAME, False)
        self.active = False
