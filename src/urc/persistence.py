"""State that survives a power cut (the FRAM of the Tartu controller).

One JSON record per rotator, written atomically (temp file, fsync, rename) with a
CRC-32 of its canonical payload. A truncated, corrupt or foreign file, or one whose
fields are not of the type and range urc writes, is detected and reported, never
trusted: the caller then treats incremental positions as unknown.

A *marker* file written at the first start tells a fresh state directory (a new
installation: the antenna is assumed at its park pose) from a used one whose state
file has gone missing (the position is then unknown).
"""

from __future__ import annotations

import json
import logging
import math
import os
import shutil
import stat
import time
import zlib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .errors import StateFileError

log = logging.getLogger(__name__)

FORMAT = "urc-state"
VERSION = 1
MARKER = "urc-initialised"


def _canonical(payload: dict[str, Any]) -> bytes:
    # allow_nan=False: a NaN or infinity is never written (ValueError instead)
    return json.dumps(payload, sort_keys=True, separators=(",", ":"), allow_nan=False).encode()


def nonfinite_field(value: Any, where: str = "payload") -> str | None:
    """Where the first NaN or infinite number in a decoded record is, None if there is
    none. Python's JSON reader accepts NaN and Infinity, and a checksum computed over
    such a value is valid, so a record must be checked for them before it is trusted."""
    if isinstance(value, float):
        return None if math.isfinite(value) else where
    if isinstance(value, dict):
        items: Any = value.items()
    elif isinstance(value, list):
        items = enumerate(value)
    else:
        return None
    for key, item in items:
        found = nonfinite_field(item, f"{where}.{key}")
        if found is not None:
            return found
    return None


def check_finite(payload: dict[str, Any], name: Any) -> None:
    """StateFileError if ``payload`` holds a NaN or an infinity (a damaged record)."""
    bad = nonfinite_field(payload)
    if bad is not None:
        raise StateFileError(f"{name}: {bad} is not a finite number; the record is damaged")


#: no angle in a record lies further from zero than this (the widest rotator turns a few
#: times); the rotator checks each axis against its own limits too (position_record)
MAX_RECORD_DEG = 3600.0


def _real(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _angle(v: Any) -> bool:
    return _real(v) and abs(v) <= MAX_RECORD_DEG


def _calibration_value(v: Any) -> bool:
    # numbers, flags (a bridged elevation's over_top), lists of numbers (a compass's matrices)
    return _real(v) or isinstance(v, bool) or (isinstance(v, list) and all(_real(x) for x in v))


#: an axis record's fields as urc writes them: (what it must be, the check)
AXIS_FIELDS: dict[str, tuple[str, Any]] = {
    "mech_deg": (f"a number within +-{MAX_RECORD_DEG:g}", _angle),
    "rate_deg_per_s": (f"a number within +-{MAX_RECORD_DEG:g}", _angle),
    "moving": ("true or false", lambda v: isinstance(v, bool)),
    "window_deg": ("[low, high] numbers, low <= high",
                   lambda v: isinstance(v, list) and len(v) == 2 and all(_angle(x) for x in v) and v[0] <= v[1]),
    "calibration": ("a table of numbers, flags and lists of numbers",
                    lambda v: isinstance(v, dict) and all(isinstance(k, str) and _calibration_value(x)
                                                          for k, x in v.items())),
    "coast_deg": ("a list of numbers >= 0",
                  lambda v: isinstance(v, list) and all(_real(x) and 0 <= x <= MAX_RECORD_DEG for x in v)),
    "uncertainty_deg": (f"a number in 0..{MAX_RECORD_DEG:g}", lambda v: _real(v) and 0 <= v <= MAX_RECORD_DEG),
    "procedure": ("text", lambda v: isinstance(v, str)),
}


def record_problem(payload: dict[str, Any]) -> str | None:
    """What in a decoded record is not what urc writes (a field of the wrong type or out
    of range: ``"mech_deg": "12.5"`` under a valid checksum was taken as a known position),
    None if nothing. Keys a record may lack are not required, except an axis' position."""
    if "profile" in payload and not isinstance(payload["profile"], str):
        return f"payload.profile: expected text, found {payload['profile']!r:.40}"
    axes = payload.get("axes", {})
    if not isinstance(axes, dict):
        return f"payload.axes: expected a table of axes, found {axes!r:.40}"
    for name, rec in axes.items():
        where = f"payload.axes.{name}"
        if not isinstance(rec, dict):
            return f"{where}: expected a table, found {rec!r:.40}"
        if "mech_deg" not in rec:
            return f"{where}.mech_deg: missing"
        for key, (expected, ok) in AXIS_FIELDS.items():
            if key in rec and not ok(rec[key]):
                return f"{where}.{key}: expected {expected}, found {rec[key]!r:.60}"
    return None


def check_record(payload: dict[str, Any], name: Any) -> None:
    """StateFileError if ``payload`` holds a NaN or an infinity, or a field that is not
    what urc writes (a damaged record)."""
    check_finite(payload, name)
    bad = record_problem(payload)
    if bad is not None:
        raise StateFileError(f"{name}: {bad}; the record is damaged")


@dataclass
class StateStore:
    path: Path
    #: fsync every write so a power cut cannot lose it (the real thing). Virtual-time
    #: tests and benchmarks that write thousands of records a second may turn it off.
    durable: bool = True

    def load(self) -> dict[str, Any] | None:
        """The saved payload, None if there is none; StateFileError if it is damaged."""
        try:
            raw = _read_regular(self.path)
        except FileNotFoundError:
            return None
        try:
            record = json.loads(raw)
        except (ValueError, UnicodeDecodeError) as exc:
            raise StateFileError(f"{self.path}: not valid JSON ({exc}); truncated or corrupt") from None
        if not isinstance(record, dict) or record.get("format") != FORMAT:
            raise StateFileError(f"{self.path}: not a urc state file")
        if record.get("version") != VERSION:
            raise StateFileError(f"{self.path}: state version {record.get('version')!r}, expected {VERSION}")
        payload = record.get("payload")
        if not isinstance(payload, dict):
            raise StateFileError(f"{self.path}: no payload")
        check_finite(payload, self.path)
        crc = zlib.crc32(_canonical(payload))
        if record.get("crc32") != crc:
            raise StateFileError(f"{self.path}: checksum mismatch (stored {record.get('crc32')}, "
                                 f"computed {crc}); the file is corrupt")
        check_record(payload, self.path)  # a valid checksum over a wrong field is still damage
        return payload

    def save(self, payload: dict[str, Any]) -> None:
        check_finite(payload, self.path)  # never write back what load would call damaged
        record = {"format": FORMAT, "version": VERSION, "saved_unix_s": time.time(),
                  "crc32": zlib.crc32(_canonical(payload)), "payload": payload}
        self.path.parent.mkdir(parents=True, exist_ok=True)
        tmp = self.path.with_name(self.path.name + ".tmp")
        with open(tmp, "wb") as fh:
            fh.write(json.dumps(record, sort_keys=True).encode())
            fh.flush()
            if self.durable:
                os.fsync(fh.fileno())
        os.replace(tmp, self.path)
        if self.durable:
            _fsync_dir(self.path.parent)  # the rename itself must survive a power cut

    @property
    def marker(self) -> Path:
        return self.path.with_name(MARKER)

    def fresh(self) -> bool:
        """A state directory never used: no state file, no marker, nothing set aside."""
        return not (self.path.exists() or self.marker.exists()
                    or any(self.path.parent.glob(f"{self.path.name}.corrupt-*")))

    def mark_initialised(self) -> None:
        """Record that this directory is in use (after the first state record is written)."""
        if not self.marker.exists():
            self.marker.write_text("urc has kept state here; a missing state file means the "
                                   "position is unknown\n", encoding="utf-8")
            if self.durable:
                _fsync_dir(self.path.parent)

    def quarantine(self) -> Path | None:
        """Keep a copy of a damaged file for inspection. The file itself stays until the
        next save replaces it, so there is never a moment without a record to read."""
        if not self.path.is_file():
            return None  # (nothing, or not a file: copying a FIFO would block)
        dest = self.path.with_name(f"{self.path.name}.corrupt-{time.time_ns()}")
        try:
            os.link(self.path, dest)
        except OSError:
            shutil.copyfile(self.path, dest)
        log.warning("damaged state file copied to %s", dest)
        return dest


def _read_regular(path: Path) -> bytes:
    """The bytes of a regular file; StateFileError for anything else. Opened without
    blocking, so a FIFO or a device in its place cannot hang the control process."""
    fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK)
    try:
        mode = os.fstat(fd).st_mode
        if not stat.S_ISREG(mode):
            raise StateFileError(f"{path}: not a regular file ({_kind(mode)})")
        with os.fdopen(fd, "rb", closefd=False) as fh:
            return fh.read()
    finally:
        os.close(fd)


def _kind(mode: int) -> str:
    for test, name in ((stat.S_ISFIFO, "a FIFO"), (stat.S_ISSOCK, "a socket"), (stat.S_ISCHR, "a character device"),
                       (stat.S_ISBLK, "a block device"), (stat.S_ISDIR, "a directory")):
        if test(mode):
            return name
    return "not a file"


def check_state_dir(state_dir: Path) -> None:
    """Before anything starts: StateFileError if an entry of the state directory is not
    a regular file or a directory (a FIFO in place of state.json would block every
    reader: the control process would hang holding the lock)."""
    try:
        entries = list(os.scandir(state_dir))
    except (FileNotFoundError, NotADirectoryError):
        return  # created later; a file in its place fails there with a clear OSError
    for entry in entries:
        try:
            mode = os.lstat(entry.path).st_mode
        except OSError:
            continue  # gone meanwhile
        # (a symlink is left alone: a pty endpoint's link to its /dev/pts device may live
        # here; a state file reached through one is still read without blocking)
        if not (stat.S_ISREG(mode) or stat.S_ISDIR(mode) or stat.S_ISLNK(mode)):
            raise StateFileError(f"{entry.path} is {_kind(mode)}, not a regular file: urc keeps its "
                                 "state in regular files; remove it or choose another --state-dir")


def _fsync_dir(path: Path) -> None:
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass  # not every filesystem syncs directories
    finally:
        os.close(fd)
