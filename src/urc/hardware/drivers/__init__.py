"""Drivers: parts (:mod:`urc.hardware.parts`) -> the interfaces the controller uses.

Written once, used by the simulator and by real iron alike:

* :mod:`.motors` H-bridges (VNH5019, LMD18200, IBT-2/BTS7960, PWM+DIR), relay drives and
  a bridge's current-sense output
* :mod:`.sensors` quadrature encoder, SPID pulse counter, pot (ratiometric / linear),
  AS5600, tilt-compensated compass and accelerometer tilt
* :mod:`.switches` brake relay and limit switches
"""

from .motors import (Bts7960Motor, DirectionTracker, HBridgeMotor, Lmd18200Motor, PwmDirMotor,
                     RelayMotor, SenseCurrent, Vnh5019Motor)
from .sensors import (As5600Sensor, CompassSensor, PotSensor, QuadratureEncoder, SpidPulseSensor,
                      TiltSensor)
from .switches import LimitSwitchInput, RelayBrake

__all__ = ["As5600Sensor", "Bts7960Motor", "CompassSensor", "DirectionTracker", "HBridgeMotor",
           "LimitSwitchInput", "Lmd18200Motor", "PotSensor", "PwmDirMotor", "QuadratureEncoder",
           "RelayBrake", "RelayMotor", "SenseCurrent", "SpidPulseSensor", "TiltSensor", "Vnh5019Motor"]
