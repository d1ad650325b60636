"""An optional log of the simulated iron over time: what the antenna truly did, for a
benchmark that must see it while urc froze or died (``bench/failsafe_bench.py``).

The truth file holds only the latest state; this log keeps the history, one JSON object
per line, appended by every world that opens the same rotator (the control process's,
then the I/O process's after it takes the outputs over, then the next start's):

* ``{"t": "s", "wall_s", "pid", "axes": {"az": {"deg", "rate", "drive", "powered"}, ...}}``
  a sample, written when a motor's drive or power changes, else at most every
  ``SAMPLE_S`` of wall time while the antenna moves;
* ``{"t": "cut", "wall_s", "pid"}`` the safety relay dropped out (wall time of the cut,
  also when it is found late, after a freeze);
* ``{"t": "restore", "wall_s", "pid", "record_wall_s", "run_on_s", "off_wall_s", "axes":
  {"az": {"from_deg", "drive", "to_deg"}, ...}}`` a world opened on a record of moving
  iron: the motors kept ``drive`` for ``run_on_s`` after the record (until ``off_wall_s``),
  then coasted from ``from_deg`` to ``to_deg``.

Switched on by the sim option ``truth_log`` (a path) or the environment variable
``URC_SIM_TRUTH_LOG`` (so a bench reaches both processes of a ``urc run``). Lines are
written by a thread of its own (the control tick never waits for the disk), each with
one ``write`` to a file opened for appending, so several processes can share the file.
"""

from __future__ import annotations

import json
import os
import queue
import threading
from pathlib import Path
from typing import Any

#: the environment variable that names the log file
ENV = "URC_SIM_TRUTH_LOG"
#: least wall time between two samples of a moving antenna whose drive did not change
SAMPLE_S = 0.01


class TruthLog:
    def __init__(self, path: Path | str):
        self.path = Path(path)
        self._fd = os.open(self.path, os.O_WRONLY | os.O_CREAT | os.O_APPEND, 0o644)
        self._pid = os.getpid()
        self._q: queue.SimpleQueue[bytes | None] = queue.SimpleQueue()
        self._last_key: tuple | None = None
        self._last_wall_s = -1.0
        self._thread = threading.Thread(target=self._run, name="sim-truth-log", daemon=True)
        self._thread.start()

    def sample(self, wall_s: float, axes: dict[str, dict[str, Any]]) -> None:
        """Log the axes' state if a drive or power changed, or the antenna moved and
        ``SAMPLE_S`` has passed."""
        power = tuple((a["drive"], a["powered"]) for a in axes.values())
        where = tuple(a["deg"] for a in axes.values())
        last = self._last_key
        if last is not None:
            if power == last[0] and (where == last[1] or wall_s - self._last_wall_s < SAMPLE_S):
                return
        self._last_key, self._last_wall_s = (power, where), wall_s
        self.event("s", wall_s, axes=axes)

    def event(self, kind: str, wall_s: float, **fields: Any) -> None:
        line = json.dumps({"t": kind, "wall_s": wall_s, "pid": self._pid, **fields}, separators=(",", ":"))
        self._q.put(line.encode() + b"\n")

    def close(self) -> None:
        """Write what is queued, then close the file."""
        self._q.put(None)
        self._thread.join(timeout=5.0)
        try:
            os.close(self._fd)
        except OSError:
            pass

    def _run(self) -> None:
        while True:
            line = self._q.get()
            if line is None:
                return
            try:
                os.write(self._fd, line)
            except OSError:
                return


def read_log(path: Path | str) -> list[dict[str, Any]]:
    """Every entry of a log, in wall-time order (a line cut short by a kill is skipped)."""
    out = []
    for raw in Path(path).read_text(encoding="utf-8").splitlines():
        try:
            out.append(json.loads(raw))
        except ValueError:
            continue
    return sorted(out, key=lambda e: e["wall_s"])
