"""Import at start, on a thread of its own, what the first requests of a tracking
controller would otherwise import on the event loop (issue 33: in 25 of 43 starts the
control process stopped the axes for the I/O process's silence within 8 s of the start,
around the first API requests: skyfield and its data files are ~1 s of CPU on a loaded
Raspberry Pi, and the loop answers nobody while a request imports them).

A thread holds Python's global lock while it imports, but hands it to the event loop's
thread every few milliseconds (sys.getswitchinterval), so the loop stays live. A request
that needs a module the thread is importing waits for that one module only.
"""

from __future__ import annotations

import importlib
import logging
import time

log = logging.getLogger(__name__)

#: what a first request of each kind imports: a satellite's or the Sun's position and
#: ground track (status), a pass search and plan (track, passes), the tracker's targets
MODULES = (
    "numpy", "sgp4.api", "sgp4.omm", "skyfield.api", "skyfield.sgp4lib", "skyfield.earthlib",
    "urc.tracking.propagate", "urc.tracking.passes", "urc.tracking.planner", "urc.tracking.targets",
    "urc.tracking.tracker", "urc.tracking.cycle",
)


def warm_up() -> float:
    """Import MODULES and load skyfield's timescale and ephemeris (cached for everyone);
    returns the seconds it took. Never raises: a failure is the first request's to report."""
    t0 = time.monotonic()
    try:
        for name in MODULES:
            importlib.import_module(name)
        from . import sky

        sky.timescale()
        sky.ephemeris()
    except Exception:
        log.warning("warming up the tracking imports failed", exc_info=True)
    took_s = time.monotonic() - t0
    log.debug("tracking imports warmed up in %.2f s", took_s)
    return took_s


__all__ = ["MODULES", "warm_up"]
