"""Hardware: small device interfaces and the factories that build them by name."""

from .interfaces import AxisHardware, Brake, Hardware, LimitSwitch, Motor, PositionSensor, Positioner
from .factory import available_backends, build_hardware, register_backend

__all__ = ["AxisHardware", "Brake", "Hardware", "LimitSwitch", "Motor", "PositionSensor", "Positioner",
           "available_backends", "build_hardware", "register_backend"]
