"""The SatNOGS rotator firmware's Easycomm II dialect, host side: pure parse/format.

Read from the SatNOGS rotator firmware (stepper_motor_controller, Libre Space
Foundation; the GitHub mirror pschneiders/satnogs-rotator-firmware at commit 02bc016,
the last upstream commit there, 2018-10-08). Paths below are in that tree:

* a command ends at ``\\n`` or ``\\r`` (libraries/easycomm.h:62); replies end with ``\\n``
  only (easycomm.h:72 and every ``str3 = String("\\n")``);
* the position query is exactly ``AZ EL`` as the first five bytes (easycomm.h:64-66);
  the answer ``AZ<az> EL<el>`` with one decimal each (``String(x, 1)``, easycomm.h:68-73);
* any other line starting ``AZ`` is a set: ``AZ<az> EL<el>``, each value ``atof`` of the
  token after its two letters (easycomm.h:74-90), never answered. A bare ``AZ`` (Hamlib
  4.6's query) is ``atof("") = 0``: a set to azimuth 0, which is why urc asks ``AZ EL``;
* ``SA SE`` stops (the setpoints become the current position) and answers with the
  position line (easycomm.h:133-145); so do ``RESET`` (then homes, easycomm.h:146-156)
  and ``PARK`` (then goes to the park setpoints, easycomm.h:157-168);
* ``VE`` -> ``VESatNOGS-v2.2`` (easycomm.h:169-174); ``GS`` -> ``GS<status>`` and ``GE``
  -> ``GE<error>``, each a decimal number (easycomm.h:238-249);
* status values (libraries/globals.h:16-18): idle 1, moving 2, pointing 4, error 8;
  error values (globals.h:20-23): none 1, sensor 2, homing 4, motor 8, over-temperature
  12, watchdog 16. They are enum values, not bits to OR (12 is "over-temperature", not
  motor + homing), and the stepper firmware sets only pointing/idle/error and the homing
  and watchdog errors (stepper_motor_controller.ino:100-139, watchdog.h:60-61);
* ``RB`` reboots the controller through its watchdog, answering nothing (easycomm.h:371-374).
"""

from __future__ import annotations

import re

from ..errors import ProtocolError

#: GS values (globals.h:16-18)
STATUS_IDLE, STATUS_MOVING, STATUS_POINTING, STATUS_ERROR = 1, 2, 4, 8
STATUS_TEXT = {STATUS_IDLE: "idle", STATUS_MOVING: "moving", STATUS_POINTING: "pointing",
               STATUS_ERROR: "error"}
#: GE values (globals.h:20-23)
ERROR_NONE, ERROR_SENSOR, ERROR_HOMING, ERROR_MOTOR, ERROR_OVER_TEMPERATURE, ERROR_WATCHDOG = 1, 2, 4, 8, 12, 16
ERROR_TEXT = {
    ERROR_NONE: "no error",
    ERROR_SENSOR: "sensor error",
    # homing() found no endstop before the seek ended (stepper_motor_controller.ino:176-181)
    ERROR_HOMING: "homing error: an endstop was not found (cleared only by a reboot)",
    ERROR_MOTOR: "motor error",
    ERROR_OVER_TEMPERATURE: "over temperature",
    # the main loop hung and the watchdog interrupt took over (watchdog.h:56-100)
    ERROR_WATCHDOG: "watchdog: the firmware hung, motors disabled (cleared only by a reboot)",
}


class SatnogsParseError(ProtocolError):
    def __init__(self, expected: str, found: bytes):
        super().__init__(f"expected {expected}, found {found!r}")


_POSITION_RE = re.compile(rb"AZ(-?[0-9]{1,6}\.[0-9]) EL(-?[0-9]{1,6}\.[0-9])")
_CODE_RE = re.compile(rb"(GS|GE)([0-9]{1,3})")


def _line(data: bytes) -> bytes:
    """One reply line without its ``\\n`` (a ``\\r`` before it is harmless)."""
    return data[:-1] if data.endswith(b"\n") else data


def format_position_query() -> bytes:
    """The combined query the firmware recognises (``AZ EL`` as the first five bytes)."""
    return b"AZ EL\n"


def format_set_position(az_deg: float, el_deg: float) -> bytes:
    return f"AZ{az_deg:.1f} EL{el_deg:.1f}\n".encode()


def format_stop() -> bytes:
    return b"SA SE\n"


def format_status_query() -> bytes:
    return b"GS\n"


def format_error_query() -> bytes:
    return b"GE\n"


def format_reset() -> bytes:
    """Home both axes (answered with the position line, then silence while it homes)."""
    return b"RESET\n"


def format_reboot() -> bytes:
    """Reboot through the watchdog (nothing answered; it homes after the restart)."""
    return b"RB\n"


def parse_position_reply(data: bytes) -> tuple[float, float]:
    """``AZ<az> EL<el>``, one decimal each, as ``String(x, 1)`` prints them; nothing else."""
    m = _POSITION_RE.fullmatch(_line(data).rstrip(b"\r"))
    if m is None:
        raise SatnogsParseError("AZ<az.d> EL<el.d>", data)
    return float(m.group(1)), float(m.group(2))


def _parse_code(data: bytes, name: bytes) -> int:
    m = _CODE_RE.fullmatch(_line(data).rstrip(b"\r"))
    if m is None or m.group(1) != name:
        raise SatnogsParseError(f"{name.decode()}<decimal>", data)
    return int(m.group(2))


def parse_status_reply(data: bytes) -> int:
    return _parse_code(data, b"GS")


def parse_error_reply(data: bytes) -> int:
    return _parse_code(data, b"GE")


def describe_status(code: int) -> str:
    return STATUS_TEXT.get(code, f"unknown status {code}")


def describe_error(code: int) -> str:
    return ERROR_TEXT.get(code, f"unknown error {code}")
