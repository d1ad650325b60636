"""What a station tells the broker: the status payload, when it is due, and events.

Pure functions and small state machines, no I/O: ``urc.mqtt.service`` feeds them the
dashboard's status snapshot (the rotator's plus the tracker's) and publishes what they
return. A status goes out when something other than position changed, when a position
moved by more than the deadband, and at least every ``refresh_s`` — never more often
than ``max_rate_hz``. Angles are rounded to 0.01 deg: payloads stay small (docs/mqtt.md).
"""

from __future__ import annotations

import math
from typing import Any

#: states a station reports (the Home Assistant enum sensor lists these)
STATES = ("fault", "uncertain", "local", "tracking", "moving", "parked", "idle")
#: fields compared with the deadband; every other field must match exactly
_DEADBAND_FIELDS = ("az_deg", "el_deg", "target_az_deg", "target_el_deg")
#: fields that change with every sample and do not make a status new
_VOLATILE = ("t_unix_s",) + _DEADBAND_FIELDS


def _r(x: float | None) -> float | None:
    return None if x is None else round(float(x), 2)


def station_state(s: dict[str, Any], tracking: dict[str, Any] | None) -> str:
    """One word for the fleet view and Home Assistant (first match of STATES)."""
    if s.get("faults"):
        return "fault"
    if not s.get("position_known", True):
        return "uncertain"
    if s.get("local_control"):
        return "local"
    if tracking and tracking.get("target") and not tracking.get("stopped"):
        return "tracking"
    if s.get("moving"):
        return "moving"
    if s.get("parked"):
        return "parked"
    return "idle"


def next_pass(tracking: dict[str, Any] | None) -> dict[str, Any] | None:
    """The pass being waited for or flown (the tracker's plan), or None."""
    tracking = tracking or {}
    plan = tracking.get("plan")
    if not plan or tracking.get("state") == "done":
        return None
    return {"aos": plan.get("aos"), "los": plan.get("los"), "max_el_deg": _r(plan.get("max_el_deg"))}


def status_payload(s: dict[str, Any], station: str, now_unix_s: float) -> dict[str, Any]:
    """The ``<base>/status`` JSON from the dashboard's status dict (``Hub.status_dict``)."""
    tracking = s.get("tracking") or None
    uncertainty = max((s.get(a) or {}).get("uncertainty_deg", 0.0) or 0.0 for a in ("az", "el"))
    trk = None
    if tracking and tracking.get("target"):
        trk = {"target": tracking["target"], "state": tracking.get("state"),
               "az_deg": _r(tracking.get("az_deg")), "el_deg": _r(tracking.get("el_deg")),
               "error": tracking.get("error") or tracking.get("stopped") or None}
    return {
        "station": station,
        "t_unix_s": round(now_unix_s, 2),
        "az_deg": _r(s.get("az_deg")), "el_deg": _r(s.get("el_deg")),
        "target_az_deg": _r(s.get("target_az_deg")), "target_el_deg": _r(s.get("target_el_deg")),
        "state": station_state(s, tracking),
        "moving": bool(s.get("moving")), "parked": bool(s.get("parked")),
        "position_known": bool(s.get("position_known", True)),
        "uncertainty_deg": _r(uncertainty),
        "faults": [{"kind": f.get("kind"), "axis": f.get("axis"), "reason": f.get("reason")}
                   for f in s.get("faults") or ()],
        "local_control": list(s.get("local_control") or ()),
        "tracking": trk,
        "next_pass": next_pass(tracking),
    }


def _angle_moved_deg(a: float | None, b: float | None) -> float:
    if a is None or b is None:
        return 0.0 if a is b else math.inf
    d = abs(a - b) % 360.0
    return min(d, 360.0 - d)


class StatusGate:
    """Decides when a status is published: on change (positions with a deadband), at
    most ``max_rate_hz``, at least every ``refresh_s``."""

    def __init__(self, deadband_deg: float, max_rate_hz: float, refresh_s: float):
        self.deadband_deg = deadband_deg
        self.min_interval_s = 1.0 / max_rate_hz
        self.refresh_s = refresh_s
        self._last: dict[str, Any] | None = None
        self._last_s = -math.inf

    def forget(self) -> None:
        """A new connection: the next status goes out whatever it says."""
        self._last, self._last_s = None, -math.inf

    def changed(self, p: dict[str, Any]) -> bool:
        last = self._last
        if last is None:
            return True
        if any(p.get(k) != last.get(k) for k in p if k not in _VOLATILE and k != "tracking"):
            return True
        t, lt = p.get("tracking") or {}, last.get("tracking") or {}
        if {k: v for k, v in t.items() if k not in ("az_deg", "el_deg")} != \
                {k: v for k, v in lt.items() if k not in ("az_deg", "el_deg")}:
            return True
        pairs = [(p.get(k), last.get(k)) for k in _DEADBAND_FIELDS]
        return any(_angle_moved_deg(a, b) > self.deadband_deg for a, b in pairs)

    def due(self, p: dict[str, Any], now_s: float) -> bool:
        since = now_s - self._last_s
        if since < self.min_interval_s:
            return False
        return since >= self.refresh_s or self.changed(p)

    def sent(self, p: dict[str, Any], now_s: float) -> None:
        self._last, self._last_s = p, now_s


class EventWatcher:
    """Turns successive statuses into ``<base>/event`` messages: faults raised and
    cleared, tracking started/stopped, passes started/ended, calibration procedures,
    and the rotator's own notices (guard stops, state-file trouble)."""

    def __init__(self) -> None:
        self._primed = False
        self._faults: set[tuple] = set()
        self._target: str | None = None
        self._pass_state: str | None = None
        self._procedure: tuple | None = None
        self._notices: tuple[str, ...] = ()
        self._stop_t_s: float | None = None

    def events(self, s: dict[str, Any], p: dict[str, Any], procedure: dict[str, Any] | None) -> list[dict]:
        """Events since the last call (none on the first: that is the starting point)."""
        out: list[dict] = []
        faults = {(f["kind"], f["axis"], f["reason"]) for f in p["faults"]}
        trk = p.get("tracking") or {}
        target, pass_state = trk.get("target"), trk.get("state")
        proc = None if procedure is None else (procedure.get("kind"), procedure.get("state"))
        notices = tuple(s.get("events") or ())
        if self._primed:
            for kind, axis, reason in sorted(faults - self._faults, key=str):
                out.append({"type": "fault", "kind": kind, "axis": axis, "reason": reason})
            if self._faults and not faults:
                out.append({"type": "faults_cleared"})
            if target != self._target:
                if self._target is not None:
                    out.append({"type": "tracking_stopped", "target": self._target})
                if target is not None:
                    out.append({"type": "tracking_started", "target": target})
            if pass_state != self._pass_state or target != self._target:
                if self._pass_state == "tracking" and self._target is not None:
                    out.append({"type": "pass_ended", "target": self._target})
                if pass_state == "tracking" and target is not None:
                    out.append({"type": "pass_started", "target": target, **(p.get("next_pass") or {})})
            if proc != self._procedure and proc is not None:
                out.append({"type": "procedure", "kind": proc[0], "state": proc[1],
                            "error": (procedure or {}).get("error")})
            stop = s.get("last_stop")
            if stop is not None and stop["t_s"] != self._stop_t_s:
                out.append({"type": "stopped", **stop})   # (what urc stopped by itself, and why)
            seen = set(self._notices)
            out += [{"type": "notice", "text": n} for n in notices if n not in seen]
        self._primed = True
        self._faults, self._target, self._pass_state = faults, target, pass_state
        self._procedure, self._notices = proc, notices
        self._stop_t_s = (s.get("last_stop") or {}).get("t_s")
        return out
