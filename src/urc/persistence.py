"""State that survives a power cut (the FRAM of the Tartu controller).

One JSON record per rotator, written atomically (temp file, fsync, rename) with a
CRC-32 of its canonical payload. A truncated, corrupt or foreign file is detected and
reported, never trusted: the caller then treats incremental positions as unknown.
"""

from __future__ import annotations

import json
import logging
import os
import time
import zlib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .errors import StateFileError

log = logging.getLogger(__name__)

FORMAT = "urc-state"
VERSION = 1


def _canonical(payload: dict[str, Any]) -> bytes:
    return json.dumps(payload, sort_keys=True, separators=(",", ":")).encode()


@dataclass
class StateStore:
    path: Path
    #: fsync every write so a power cut cannot lose it (the real thing). Virtual-time
    #: tests and benchmarks that write thousands of records a second may turn it off.
    durable: bool = True

    def load(self) -> dict[str, Any] | None:
        """The saved payload, None if there is none; StateFileError if it is damaged."""
        try:
            raw = self.path.read_bytes()
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
        crc = zlib.crc32(_canonical(payload))
        if record.get("crc32") != crc:
            raise StateFileError(f"{self.path}: checksum mismatch (stored {record.get('crc32')}, "
                                 f"computed {crc}); the file is corrupt")
        return payload

    def save(self, payload: dict[str, Any]) -> None:
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

    def quarantine(self) -> Path | None:
        """Move a damaged file aside (kept for inspection) so the next save starts clean."""
        if not self.path.exists():
            return None
        dest = self.path.with_name(f"{self.path.name}.corrupt-{int(time.time())}")
        os.replace(self.path, dest)
        log.warning("damaged state file moved to %s", dest)
        return dest
