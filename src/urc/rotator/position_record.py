"""What a state record promises about an axis, and what a restart may conclude from it.

Every record gives each axis a *window*: the range of positions (mechanical frame) the
axis keeps to until a newer record is on disk, coasting after a power cut included. The
rotator enforces the promise (an axis whose next tick could leave the window of the last
record known to be on disk gets no drive), so a restart after a crash or a power cut
finds the antenna inside the window of the newest record it can read, whenever the
crash came. Windows are small while standing (the hold band: the position is *known*
after a restart) and reach ahead of the motion while moving (the position is then
uncertain by half the window), so writes are needed only when motion starts, every
``save_interval_s`` or so of travel, and when the axis comes to rest: a few per move
instead of one per tick (SD cards wear out).

Only axes whose position a restart cannot read back need this: incremental sensors
(encoders, pulse counters), absolute sensors that repeat within the range (a compass
or AS5600 on a rotator with an overlap: the record tells which turn) and readings that
fold at the zenith (a bridged controller reporting sky directions: the record tells
which side).
"""

from __future__ import annotations

import math
from typing import Any

from ..control.profile import stopping_distance_deg

#: a power cut lets the axis run on up to ~1.1x its controlled stopping distance
#: (measured per profile in the simulator with the motor unpowered); kept with margin
POWER_CUT_COAST_FACTOR = 1.5
#: how far outside its mechanical range an axis' recorded position may lie and still be
#: believed (over-travel to an end stop, a power cut's coast, a reference moved since):
#: further out, the record is damaged
RECORD_RANGE_SLACK_DEG = 90.0


def hold_band_deg(ax: Any) -> float:
    """How far a standing axis may wander (settle band, a flickering count, noise) and
    still be "at" the position of its record: the error a known position may have."""
    s = ax.caps.sensor
    return max(ax.tuning.tolerance_deg, 1.5 * s.resolution_deg + 3.0 * s.noise_deg)


def estimate_slack_deg(ax: Any) -> float:
    """How far the truth may lie from the position estimate (counts, noise, gear play)."""
    s = ax.caps.sensor
    return 2.0 * s.resolution_deg + 4.0 * s.noise_deg + ax.tuning.backlash_deg


def needs_record(ax: Any) -> bool:
    s = ax.caps.sensor
    if not s.absolute:
        return True
    lo, hi = ax.limits
    return (s.modulo_deg is not None and hi - lo > s.modulo_deg) or \
        (s.fold_deg is not None and lo < s.fold_deg < hi)


def coast_deg(ax: Any, rate_deg_per_s: float) -> float:
    """How far the axis can run on from this speed when the power goes (motor off, a
    brake that closes late, a relay's coast, the gear play)."""
    v = min(abs(rate_deg_per_s), ax.tuning.max_rate_deg_per_s)
    relay = max(ax.law.coast_deg, default=0.0) * v / ax.tuning.max_rate_deg_per_s
    return (POWER_CUT_COAST_FACTOR * stopping_distance_deg(v, ax.tuning.accel_deg_per_s2) + relay
            + v * ax.caps.brake_engage_s + ax.tuning.backlash_deg)


def standing(ax: Any, tracking: bool) -> bool:
    """At rest with nothing asking it to move: a record can call the position known."""
    if tracking or ax.out.duty != 0.0 or abs(ax.rate_deg_per_s) > ax.still_rate_deg_per_s:
        return False
    if ax.law.mode not in ("idle", "holding"):
        return False
    sp = ax.sp
    return sp is None or (sp.rate_deg_per_s == 0.0 and abs(sp.target_deg - ax.meas_deg) <= hold_band_deg(ax))


def reach(ax: Any, now_s: float, horizon_s: float, with_target: bool) -> tuple[float, float]:
    """Where the axis can be within ``horizon_s`` (plus a power-cut coast from the speed
    it can reach by then); with_target: also towards where its setpoint is heading, as
    far as top speed takes it in that time (a far goal would make the window huge)."""
    p, v = ax.meas_deg, ax.rate_deg_per_s
    points = [p, p + v * horizon_s]
    if with_target and ax.sp is not None:
        far_deg = ax.tuning.max_rate_deg_per_s * horizon_s
        points.append(min(max(ax.sp.target_at(now_s + horizon_s), p - far_deg), p + far_deg))
    c = coast_deg(ax, abs(v) + ax.tuning.accel_deg_per_s2 * horizon_s)
    return min(points) - c, max(points) + c


def window(ax: Any, now_s: float, horizon_s: float, is_standing: bool) -> tuple[float, float]:
    """The window a new record promises for this axis."""
    p, band = ax.meas_deg, hold_band_deg(ax)
    if is_standing or not needs_record(ax):
        return p - band, p + band
    lo, hi = reach(ax, now_s, horizon_s, with_target=True)
    # reach on by what the axis covers in horizon_s at top speed, so slow motion
    # (tracking) needs a new record only every so many degrees, not every horizon_s
    extra = ax.tuning.max_rate_deg_per_s * horizon_s
    if hi > p + band:
        hi += extra
    if lo < p - band:
        lo -= extra
    return min(lo, p - band), max(hi, p + band)


def covers(outer: tuple[float, float] | None, inner: tuple[float, float]) -> bool:
    return outer is not None and outer[0] <= inner[0] and inner[1] <= outer[1]


def known_window(ax: Any, win: tuple[float, float]) -> bool:
    """A window no wider than the hold band: a restart may call the position known."""
    return (win[1] - win[0]) / 2.0 <= hold_band_deg(ax) + 1e-9


def saved_window(saved: dict[str, Any]) -> tuple[float, float] | None:
    """The window of a saved axis record, None if it has none (older records)."""
    w = saved.get("window_deg")
    if isinstance(w, (list, tuple)) and len(w) == 2:
        lo, hi = float(w[0]), float(w[1])
        if math.isfinite(lo) and math.isfinite(hi) and lo <= hi:
            return lo, hi
    return None


def record_out_of_range(ax: Any, saved: Any) -> str | None:
    """What makes an axis record (types checked already: persistence.record_problem)
    impossible for this axis, None if nothing: a position no end stop lets it reach."""
    if not isinstance(saved, dict) or not isinstance(saved.get("mech_deg"), (int, float)):
        return None
    lo, hi = ax.caps.min_deg - RECORD_RANGE_SLACK_DEG, ax.caps.max_deg + RECORD_RANGE_SLACK_DEG
    if not lo <= saved["mech_deg"] <= hi:
        return (f"axes.{ax.name}.mech_deg {saved['mech_deg']:g} outside the {ax.name} axis' "
                f"reach {lo:g}..{hi:g}")
    return None
