"""The rotator service: the single owner of both axes and their state."""

from .rotator import Rotator
from .settings import RotatorSettings
from .snapshot import AxisStatus, Status

__all__ = ["Rotator", "RotatorSettings", "Status", "AxisStatus"]
