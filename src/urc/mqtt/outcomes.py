"""What became of a motion command MQTT accepted (issue 33: an accepted command never
vanishes). A ``goto`` or ``park`` is answered on ``<base>/cmd/result`` when it is accepted
(``"ok": true, "state": "accepted"``); one more result with the same id follows when it
ends, from the statuses urc publishes anyway:

* ``"state": "done"`` (``ok`` true): at rest at its target, or parked;
* ``"state": "stopped"`` (``ok`` false): stopped before it got there — by urc's health
  rules, a fault, the rotator or a person — with ``kind`` and ``reason`` as in status'
  ``last_stop``; a stop that ``resumes`` (a late tick) says so and is followed by the
  final result once the command ends after all;
* ``"state": "replaced"`` (``ok`` false): another motion command (from any client) took
  over first.

Pure logic on status dicts (``urc.model.snapshot.Status.as_dict``), so it is tested
without a broker; urc.mqtt.service feeds it every telemetry sample.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from ..angles import great_circle_1_deg, wrap180_deg

#: at most this many commands are watched (the oldest let go first, said as "unknown")
WATCH_MAX = 64
#: a command still under way this long after it was accepted is let go ("unknown")
WATCH_S = 1800.0
#: at rest this close to its target (deg): done
AT_TARGET_DEG = 1.0
#: a status target this far from the command's (deg): another command took over
OTHER_TARGET_DEG = 0.05
#: target and motion are judged only on statuses this much newer than the one seen when
#: the command was accepted (that one may be of the tick before it took effect)
FRESH_S = 0.2


@dataclass
class _Watched:
    cmd_id: Any
    command: str
    #: sky target (az, el); el None: azimuth only; None: park
    target: tuple[float, float | None] | None
    accepted_unix_s: float
    #: status t_s when accepted (the control clock: last_stop's t_s is on it)
    accepted_t_s: float
    stops_seen: set[float] = field(default_factory=set)


class MotionOutcomes:
    def __init__(self) -> None:
        self._watched: list[_Watched] = []
        self._pending: list[dict[str, Any]] = []

    def accepted(self, cmd_id: Any, command: str, target: tuple[float, float | None] | None,
                 status: dict[str, Any], now_unix_s: float) -> None:
        """A motion command was accepted: commands watched before it are replaced."""
        for w in self._watched:
            self._pending.append(_result(w, "replaced", reason=f"replaced by {command} {cmd_id!r}"))
        self._watched = [_Watched(cmd_id, command, target, now_unix_s, float(status.get("t_s") or 0.0))]

    def __len__(self) -> int:
        return len(self._watched)

    def update(self, status: dict[str, Any], now_unix_s: float) -> list[dict[str, Any]]:
        """The results due now (each command's end, once)."""
        out, self._pending = self._pending, []
        still: list[_Watched] = []
        for w in self._watched:
            result = self._judge(w, status, now_unix_s)
            if result is None:
                still.append(w)
            else:
                out.append(result)
                if result["state"] == "stopped" and result.get("resumes"):
                    still.append(w)   # (its end follows)
        while len(still) > WATCH_MAX:
            out.append(_result(still.pop(0), "unknown", reason="too many commands watched at once"))
        self._watched = still
        return out

    def _judge(self, w: _Watched, s: dict[str, Any], now_unix_s: float) -> dict[str, Any] | None:
        stop = s.get("last_stop")
        if stop and float(stop.get("t_s") or 0.0) > w.accepted_t_s and stop["t_s"] not in w.stops_seen:
            w.stops_seen.add(stop["t_s"])
            return _result(w, "stopped", kind=stop.get("kind"), reason=stop.get("reason"),
                           resumes=bool(stop.get("resumes")))
        if float(s.get("t_s") or 0.0) < w.accepted_t_s + FRESH_S:
            return None
        faults = s.get("faults") or []
        if faults:
            f = faults[0]
            return _result(w, "stopped", kind="fault", reason=f.get("reason") if isinstance(f, dict) else str(f),
                           resumes=False)
        moving = bool(s.get("moving"))
        if w.target is None:  # park
            if s.get("parked"):
                return _result(w, "done")
        else:
            t_az, t_el = s.get("target_az_deg"), s.get("target_el_deg")
            if t_az is None and not moving:
                return _result(w, "stopped", kind="person", reason="stopped by a stop command", resumes=False)
            if t_az is not None and _other(w.target, t_az, t_el):
                return _result(w, "replaced", reason="another command changed the target")
            if not moving and _near(w.target, s.get("az_deg"), s.get("el_deg")):
                return _result(w, "done")
        if now_unix_s - w.accepted_unix_s > WATCH_S:
            return _result(w, "unknown", reason=f"still under way after {WATCH_S:.0f} s")
        return None


def _other(target: tuple[float, float | None], t_az: float, t_el: Any) -> bool:
    az, el = target
    d_az = abs(wrap180_deg(t_az - az))
    return d_az > OTHER_TARGET_DEG or (el is not None and t_el is not None and abs(t_el - el) > OTHER_TARGET_DEG)


def _near(target: tuple[float, float | None], az: Any, el: Any) -> bool:
    if az is None or not math.isfinite(az):
        return False
    t_az, t_el = target
    if t_el is None or el is None:
        return abs(wrap180_deg(az - t_az)) <= AT_TARGET_DEG
    return great_circle_1_deg(az, el, t_az, t_el) <= AT_TARGET_DEG


def _result(w: _Watched, state: str, **more: Any) -> dict[str, Any]:
    return {"id": w.cmd_id, "ok": state == "done", "command": w.command, "state": state,
            **{k: v for k, v in more.items() if v is not None}}
