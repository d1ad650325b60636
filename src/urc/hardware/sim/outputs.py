"""Simulated digital outputs (the heartbeat pin), observable from outside the process.

An external watchdog or charge pump sees only the pin's level changing; the simulated
pin counts its transitions and shows them in the simulator truth, and a thread of its
own writes them to a small file (at most every ``file_interval_s``, only when they
changed), so a test or an operator can watch the square wave stop when the process is
killed or stalls.
"""

from __future__ import annotations

import logging
import os
import threading
import time
from pathlib import Path
from typing import Any

log = logging.getLogger(__name__)


class SimDigitalOutput:
    def __init__(self, name: str, path: Path | None = None, file_interval_s: float = 0.1,
                 on_write: Any = None):
        self.name = name
        #: what the pin is wired to (the safety chain's monostable): told every level
        self.on_write = on_write
        self.path = path
        self.file_interval_s = file_interval_s
        self.level = False
        self.toggles = 0
        self._closed = threading.Event()
        self._writer: threading.Thread | None = None
        if path is not None:
            # the file is written by a thread of its own: a write (or a rename waiting for
            # the filesystem's journal) can take hundreds of ms, never on the control tick
            self._writer = threading.Thread(target=self._file_writer, name=f"sim-{name}-file", daemon=True)
            self._writer.start()

    def write(self, value: bool) -> None:
        value = bool(value)
        if value != self.level:
            self.level = value
            self.toggles += 1
        if self.on_write is not None:
            self.on_write(value)

    def truth(self) -> dict[str, Any]:
        return {"level": self.level, "toggles": self.toggles}

    def close(self) -> None:
        """Stop the file writer after a last write of the final level."""
        self._closed.set()
        if self._writer is not None:
            self._writer.join(timeout=2.0)

    def _file_writer(self) -> None:
        written = None
        while True:
            state = (self.level, self.toggles)
            if state != written:  # a pin that stopped toggling leaves the file as it was
                self._write_file(*state)
                written = state
            if self._closed.wait(self.file_interval_s):
                self._write_file(self.level, self.toggles)
                return

    def _write_file(self, level: bool, toggles: int) -> None:
        # one short line, replaced atomically (no fsync: it is only watched while running)
        tmp = self.path.with_name(self.path.name + ".tmp")
        try:
            tmp.write_text(f"{self.name} level {int(level)} toggles {toggles} at {time.time():.3f}\n")
            os.replace(tmp, self.path)
        except OSError as exc:
            log.debug("simulator: cannot write %s: %s", self.path, exc)


def read_output_file(path: Path) -> dict[str, float]:
    """Parse a file written by :class:`SimDigitalOutput` (tests, operators)."""
    words = path.read_text().split()
    return {"level": int(words[2]), "toggles": int(words[4]), "at_unix_s": float(words[6])}
