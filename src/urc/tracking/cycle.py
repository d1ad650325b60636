"""The Berkeley rotor's state machine (seed 004), read off urc's own state.

The Berkeley controller runs setup (GPS fix, encoder zero) and then loops
PROCESS_TLE -> PREDICT -> TRACK_MOTOR -> UPDATE_SERVER once a second. urc has no such
loop (it plans whole passes and steps every tick), so the document's names are a view
of what urc is doing now, for users who know that machine:

=============  ===============  ========================================================
state          document         urc now
=============  ===============  ========================================================
setup          setup            the position is not referenced (the encoder zero of
                                ``calibrate_encoders``), or a fault stops everything
                                until it is cleared
process_tle    PROCESS_TLE      nothing tracked: waiting for elements / a target
predict        PREDICT          tracking, but the target is not up yet (waiting for
                                the pass or moving to where it will rise)
track          TRACK_MOTOR      following the target, still more than
                                ``ON_TARGET_DEG`` off it
report         UPDATE_SERVER    on the target (the document reports the encoder
                                readings once they are "within an acceptable range")
=============  ===============  ========================================================
"""

from __future__ import annotations

from typing import Any

# (beside the status text: `urc status` prints it without loading the tracking package)
from ..status_text import tracking_something

STATES = ("setup", "process_tle", "predict", "track", "report")
DOCUMENT_NAMES = {"setup": "setup", "process_tle": "PROCESS_TLE", "predict": "PREDICT",
                  "track": "TRACK_MOTOR", "report": "UPDATE_SERVER"}
#: "within an acceptable range": the document's band was 4 deg (bang-bang); urc's
#: pointing is judged at 0.5 deg (docs/ARCHITECTURE.md, measures)
ON_TARGET_DEG = 0.5


def cycle_state(status: dict[str, Any], error_deg: float | None) -> dict[str, str]:
    """``{"state", "document", "why"}`` for a status dict (with its ``tracking``) and
    the pointing error between where the antenna points and where it is told to."""
    trk = status.get("tracking") or {}  # (none and empty alike: nothing tracked)
    if status.get("faults"):
        state, why = "setup", "a fault stops everything until it is cleared"
    elif not status.get("position_known", True):
        state, why = "setup", "the position is not referenced yet (zero it)"
    elif not tracking_something(trk):
        state, why = "process_tle", "nothing tracked: waiting for elements or a target"
    elif trk.get("state") in ("planning", "waiting", "prepositioning") or trk.get("error") or \
            status.get("target_az_deg") is None:
        state = "predict"
        why = trk.get("error") or {"prepositioning": "moving to where the pass rises",
                                   "planning": "searching and planning the next pass"}.get(
                                       str(trk.get("state")), "waiting for the pass")
    elif error_deg is None or error_deg > ON_TARGET_DEG:
        state, why = "track", "following the target" + ("" if error_deg is None else f", {error_deg:.2f} deg off")
    else:
        state, why = "report", f"on the target ({error_deg:.2f} deg)"
    return {"state": state, "document": DOCUMENT_NAMES[state], "why": why}


# (here, not in the tracker: the dashboard extrapolates without the tracking maths, numpy)
#: a tracking status older than this is not extrapolated (its rates no longer hold)
EXTRAPOLATE_MAX_S = 5.0


def tracking_now(t: dict[str, Any] | None, unix_s: float) -> dict[str, Any] | None:
    """A tracking status (``Tracker.status``) with the target's az/el moved on to
    ``unix_s`` by its rates: the status costs tens of ms and is refreshed about once a
    second, while a satellite near culmination moves a degree a second."""
    if not t or t.get("az_rate_deg_per_s") is None or t.get("az_deg") is None or t.get("t_unix_s") is None:
        return t
    dt = unix_s - t["t_unix_s"]
    if not 0.0 < dt <= EXTRAPOLATE_MAX_S:
        return t
    return {**t, "t_unix_s": unix_s, "az_deg": (t["az_deg"] + t["az_rate_deg_per_s"] * dt) % 360.0,
            "el_deg": t["el_deg"] + t["el_rate_deg_per_s"] * dt}
