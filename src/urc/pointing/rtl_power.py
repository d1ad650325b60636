"""``rtl_power``'s CSV output (rtl-sdr's own sweep tool) as a power source.

Each line is one hop of a sweep: ``date, time, Hz low, Hz high, Hz step, samples, dB,
dB, ...`` (e.g. ``2024-01-01, 12:00:00, 144000000, 146000000, 7812.50, 20, -41.2, ...``),
the date and time the local time of the computer running rtl_power. The power of a line
is the mean of its bins on a linear scale, in dB again (a band's mean power, not the mean
of its dB). ``RtlPowerLines`` is sans-I/O: ``feed`` it text as it arrives (a pipe, a
file being written); ``read()`` gives the newest complete line's power.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from datetime import datetime

import numpy as np

from .sources import Clock, Sample, SignalRefused, judge


@dataclass(frozen=True)
class RtlPowerLine:
    t_s: float            # POSIX seconds of the line's date and time
    hz_low: float
    hz_high: float
    hz_step: float
    samples: int
    db: tuple[float, ...]

    @property
    def mean_db(self) -> float:
        return float(10.0 * np.log10(np.mean(10.0 ** (np.asarray(self.db) / 10.0))))


def parse_line(line: str, *, utc: bool = False) -> RtlPowerLine:
    """One CSV line, or SignalRefused("bad") saying what is wrong with it. ``utc``: the
    date and time are UTC (rtl_power writes local time: run it with TZ=UTC for that)."""
    fields = [f.strip() for f in line.strip().split(",")]
    if len(fields) < 7:
        raise SignalRefused("bad", f"rtl_power: expected date, time, Hz low, Hz high, Hz step, samples "
                            f"and at least one dB, found {len(fields)} fields in {line.strip()[:60]!r}")
    try:
        when = datetime.strptime(f"{fields[0]} {fields[1]}", "%Y-%m-%d %H:%M:%S")
    except ValueError:
        raise SignalRefused("bad", f"rtl_power: expected YYYY-MM-DD, HH:MM:SS, found "
                            f"{fields[0]!r}, {fields[1]!r}") from None
    if utc:
        from datetime import timezone
        when = when.replace(tzinfo=timezone.utc)
    try:
        hz_low, hz_high, hz_step = (float(f) for f in fields[2:5])
        samples = int(fields[5])
        db = tuple(float(f) for f in fields[6:])
    except ValueError as exc:
        raise SignalRefused("bad", f"rtl_power: a field is not a number ({exc})") from None
    nums = (hz_low, hz_high, hz_step, *db)
    if not all(math.isfinite(x) for x in nums):
        raise SignalRefused("bad", "rtl_power: a field is not finite (nan or inf)")
    if not (0 < hz_low < hz_high and hz_step > 0 and samples > 0):
        raise SignalRefused("bad", f"rtl_power: expected 0 < Hz low < Hz high, Hz step > 0, samples > 0, "
                            f"found {hz_low:g}, {hz_high:g}, {hz_step:g}, {samples}")
    return RtlPowerLine(when.timestamp(), hz_low, hz_high, hz_step, samples, db)


class RtlPowerLines:
    """The newest line fed, as a power. ``max_age_s``: older than this (by ``clock``,
    POSIX seconds) is stale; rtl_power's ``-i`` interval plus a margin. ``ceiling_db``:
    a bin at or above it (the dongle's ADC clipping) makes the line saturated."""

    def __init__(self, *, max_age_s: float | None = 30.0, ceiling_db: float | None = None,
                 utc: bool = False, clock: Clock = time.time, name: str = "rtl_power"):
        self.max_age_s, self.ceiling_db, self.utc = max_age_s, ceiling_db, utc
        self.clock, self.name = clock, name
        self._buf = ""
        self._last: RtlPowerLine | None = None
        #: the last line refused and why (a malformed line never replaces a good one)
        self.last_error: SignalRefused | None = None
        self.bad_lines = 0

    def feed(self, text: str) -> list[RtlPowerLine]:
        self._buf += text
        good = []
        while "\n" in self._buf:
            line, self._buf = self._buf.split("\n", 1)
            if not line.strip():
                continue
            try:
                parsed = parse_line(line, utc=self.utc)
            except SignalRefused as exc:
                self.bad_lines += 1
                self.last_error = exc
                continue
            self._last = parsed
            good.append(parsed)
        if len(self._buf) > 1 << 20:  # a megabyte without a line end is not rtl_power
            self._buf = ""
        return good

    def read(self) -> Sample:
        line = self._last
        if line is None:
            why = f" (last refused: {self.last_error})" if self.last_error else ""
            raise SignalRefused("missing", f"{self.name}: no line yet{why}")
        if self.ceiling_db is not None and max(line.db) >= self.ceiling_db:
            raise SignalRefused("saturated", f"{self.name}: a bin reads {max(line.db):g} dB, "
                                f"at the ceiling {self.ceiling_db:g} dB")
        return judge(line.t_s, line.mean_db, "dB", now_s=self.clock(), max_age_s=self.max_age_s,
                     what=self.name)
