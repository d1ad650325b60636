"""A status snapshot (the dict ``GET /api/status`` answers) as text for a terminal.

Standard library only, and not even ``typing`` (a Pi's interpreter need not have loaded
it): ``urc status`` prints through here without loading click or anything of the
controller (issue 19), and the click command does the same.
"""

from __future__ import annotations

import json


def tracking_something(trk: dict | None) -> bool:
    """Whether a status' ``tracking`` names a target (with only a GPS receiver's state
    in it, nothing is tracked)."""
    if not trk:
        return False
    return trk.get("target") is not None or "state" in trk


def position_unknown(s: dict, name: str) -> bool:
    """An axis whose uncertainty spans its whole travel (a reference search such as the
    BIG-RAS homing runs in a frame of its own; no record at start-up): its number says
    nothing about where the antenna points."""
    lo, hi = s.get("limits", {}).get(name, (0.0, 0.0))
    return s[name]["uncertainty_deg"] >= max(hi - lo, 1e-9) - 1e-6


def render(data: dict, as_json: bool) -> str:
    """What `urc status` prints (``--json``: the snapshot as it came)."""
    return json.dumps(data, indent=2) if as_json else format_status(data)


def format_status(s: dict) -> str:
    """A status as lines for a terminal."""
    def deg(name: str, value: float, width: int) -> str:
        return "unknown".rjust(width) if position_unknown(s, name) else f"{value:{width}.2f}"

    wrap = "?" if position_unknown(s, "az") else s["wrap_turns"]
    if s.get("el") is None:  # a single-axis rotator: azimuth only, no elevation shown
        lines = [f"profile   {s['profile']} (azimuth only)",
                 f"pointing  az {deg('az', s['az_deg'], 7)}",
                 f"axes      az {deg('az', s['az']['pos_deg'], 7)} ({s['az']['mode']})  wrap turn {wrap}"]
        if s["target_az_deg"] is not None:
            lines.append(f"target    az {s['target_az_deg']:7.2f}")
    else:
        lines = [f"profile   {s['profile']}",
                 f"pointing  az {deg('az', s['az_deg'], 7)}  el {deg('el', s['el_deg'], 6)}"
                 + ("   (flipped)" if s["flipped"] else ""),
                 f"axes      az {deg('az', s['az']['pos_deg'], 7)} ({s['az']['mode']})  "
                 f"el {deg('el', s['el']['pos_deg'], 6)} ({s['el']['mode']})  wrap turn {wrap}"]
        if s["target_az_deg"] is not None:
            lines.append(f"target    az {s['target_az_deg']:7.2f}  el {s['target_el_deg']:6.2f}")
    state = "moving" if s["moving"] else ("parked" if s["parked"] else "stopped")
    lines.append(f"state     {state}; position {'known' if s['position_known'] else 'UNCERTAIN'}")
    for name in s.get("axes", ("az", "el")):
        if position_unknown(s, name):
            lines.append(f"          {name} unknown: a reference search (homing) runs, or nothing "
                         "says where the axis is; set position or home it")
        elif s[name]["uncertainty_deg"]:
            lines.append(f"          {name} uncertain by ±{s[name]['uncertainty_deg']:.2f} deg")
    if s.get("cycle"):
        c = s["cycle"]
        lines.append(f"cycle     {c['document']} ({c['state']}): {c['why']}")
    for f in s["faults"]:
        lines.append(f"FAULT     {f['kind']}: {f['reason']}")
    if s.get("local_control"):
        lines.append(f"LOCAL     {', '.join(s['local_control'])} held at the rotator: "
                     "only stop is accepted from here")
    if s.get("state_error"):
        lines.append(f"STATE     not saved: {s['state_error']} (retrying; motion stops before the "
                     "saved position stops being true)")
    truth = s.get("simulator_truth")
    if truth:
        el = f"  el {truth['el']['deg']:6.2f}" if s.get("el") is not None else ""
        lines.append(f"sim truth az {truth['az']['deg']:7.2f}{el}  (simulator only)")
    for e in s["events"][-3:]:
        lines.append(f"event     {e}")
    if s.get("tracking"):
        lines.append(format_tracking(s["tracking"]))
    return "\n".join(lines)


def format_tracking(t: dict | None) -> str:
    """The tracker's part of a status (what `urc track` prints once it is tracking)."""
    gps = (t or {}).get("gps")
    gps_line = "" if not gps else (
        f"\ngps       {gps['source']}: " + (f"fix {gps['lat_deg']:.5f} {gps['lon_deg']:.5f} {gps['alt_m']:.0f} m"
                                           if gps.get("lat_deg") is not None else "no fix yet")
        + ("" if gps.get("clock_offset_s") is None else f", clock offset {gps['clock_offset_s']:+.3f} s"))
    if t is None or not tracking_something(t):
        return "not tracking" + gps_line
    lines = [f"tracking  {t.get('target')}" if not t.get("stopped") else
             f"NOT tracking {t.get('target')}: {t['stopped']}"]
    if t.get("az_deg") is not None:
        lines.append(f"target    az {t['az_deg']:7.2f}  el {t['el_deg']:6.2f}")
    plan = t.get("plan")
    if plan:
        lines.append(f"pass      AOS {plan['aos']}  LOS {plan['los']}  max el {plan['max_el_deg']:.1f}")
        lines.append(f"plan      {'flip (over the top)' if plan['flip'] else 'no flip'}, wrap turn "
                     f"{plan['wrap_turns']}, AOS pose az {plan['aos_pose'][0]:.1f} el {plan['aos_pose'][1]:.1f}, "
                     f"peak az rate {plan['peak_az_rate_deg_per_s']:.2f} deg/s; state {t.get('state')}")
        for note in plan.get("notes", []):
            lines.append(f"note      {note}")
    for text in ([t["error"]] if t.get("error") else []) + list(t.get("warnings") or []):
        lines.append(f"warning   {text}")
    return "\n".join(lines) + gps_line
