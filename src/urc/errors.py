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


class ProtocolError(UrcError, ValueError):
    """Input a protocol could not parse; says what was expected and what was found.

    The root of every protocol's input errors (with ``CommandRejected`` from the rotator
    and ``HardwareError``, the only exceptions a session answers as bad input; anything
    else is a bug, see :func:`urc.protocols.base.internal_error`), raised by the wire
    codecs (:mod:`urc.wire`) and the sessions alike. ``ProtocolError("text")`` carries a
    ready message; ``ProtocolError(expected, found)`` builds one.
    """

    def __init__(self, expected: str, found: bytes | None = None):
        self.expected, self.found = expected, found
        super().__init__(expected if found is None else f"expected {expected}, found {found!r}")


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
