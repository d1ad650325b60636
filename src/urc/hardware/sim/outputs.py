"""Simulated digital outputs (the heartbeat pin), observable from outside the process.

An external watchdog or charge pump sees only the pin's level changing; the simulated
pin counts its transitions and shows them in the simulator truth, and also writes them
to a small file (at most every ``file_interval_s``), so a test or an operator can watch
the square wave stop when the process is killed or stalls.
"""

from __future__ import annotations

import logging
import os
import time
from pathlib import Path
from typing import Any

log = logging.getLogger(__name__)


class SimDigitalOutput:
    def __init__(self, name: str, path: Path | None = None, file_interval_s: float = 0.1):
        self.name = name
        self.path = path
        self.file_interval_s = file_interval_s
        self.level = False
        self.toggles = 0
        self._last_file_s = -float("inf")

    def write(self, value: bool) -> None:
        value = bool(value)
        if value != self.level:
            self.level = value
            self.toggles += 1
        if self.path is not None and time.monotonic() - self._last_file_s >= self.file_interval_s:
            self._last_file_s = time.monotonic()
            self._write_file()

    def truth(self) -> dict[str, Any]:
        return {"level": self.level, "toggles": self.toggles}

    def _write_file(self) -> None:
        # one short line, replaced atomically (no fsync: it is only watched while running)
        tmp = self.path.with_name(self.path.name + ".tmp")
        try:
            tmp.write_text(f"{self.name} level {int(self.level)} toggles {self.toggles} "
                           f"at {time.time():.3f}\n")
            os.replace(tmp, self.path)
        except OSError as exc:
            log.debug("simulator: cannot write %s: %s", self.path, exc)


def read_output_file(path: Path) -> dict[str, float]:
    """Parse a file written by :class:`SimDigitalOutput` (tests, operators)."""
    words = path.read_text().split()
    return {"level": int(words[2]), "toggles": int(words[4]), "at_unix_s": float(words[6])}
