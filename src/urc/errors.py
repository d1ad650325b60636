"""One root exception; every subsystem raises a subclass of it.

Protocols map these to their own wire replies (``RPRT -n``, ``?>`` ...).
"""


class UrcError(Exception):
    """Root of every error urc raises on purpose."""


class ConfigError(UrcError):
    """A configuration file or value is wrong.

    The message names the file, the key, what was expected and what was found.
    """

    def __init__(self, message: str, *, path: str | None = None, key: str | None = None,
                 expected: str | None = None, found: object = None):
        self.path, self.key, self.expected, self.found = path, key, expected, found
        super().__init__(message)


class CommandRejected(UrcError):
    """A command was refused before it moved anything (limits, keep-out, fault, uncertainty)."""

    #: short machine-readable reason ("limit", "keepout", "fault", "uncertain", "invalid")
    reason: str = "invalid"

    def __init__(self, message: str, reason: str = "invalid"):
        self.reason = reason
        super().__init__(message)


class HardwareError(UrcError):
    """A hardware part failed to do what it was asked (bus error, vanished device)."""


class SensorError(HardwareError):
    """A position sensor gave no usable reading."""


class StateFileError(UrcError):
    """The persistent state file is corrupt, truncated or from an incompatible version."""


class CalibrationError(UrcError):
    """A calibration cannot be done or its result is not trustworthy."""


class NoSuchConstant(CalibrationError):
    """The sensor has no such constant (it is not the kind of sensor a command is for)."""
