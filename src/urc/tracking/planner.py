"""Plan a whole pass before it starts: wrap side, flip, rate-feasible trajectory, pre-position.

Input: the target's sky track (az 0..360, el) sampled over the pass. Output: one
mechanical trajectory (the wrap turn and flip chosen once, so the pass never crosses an
end stop or swings 180 degrees at the zenith mid-pass), checked against the rotator's
limits, speeds, accelerations and keep-out zones, plus when to start pre-positioning.

Where the sky track needs more azimuth speed than the axis has (the keyhole of a
near-zenith pass), the plan is the minimax over the azimuth's speed: the azimuth turns
with the target as closely as its speed allows, swinging early and finishing late with the
elevation making up for the lag (``_follow_minimax``), or, on a rotator that can flip,
holds still over the top while the elevation sweeps past the zenith (``_keyhole_holds``),
whichever misses the target by less at worst.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..angles import great_circle_deg, wrap180_deg
from ..control.geometry import Geometry, route_time_s
from .errors import TrackingError

#: start pre-positioning this long before it is strictly needed
PREPOSITION_MARGIN_S = 10.0
#: elevation this far outside the limits is clipped to them rather than ruling a pose out
EL_SLACK_DEG = 0.5
#: share of the speed and acceleration the plan may use: headroom for the servo to correct errors
RATE_BUDGET = 0.9


@dataclass(frozen=True)
class AxisLimits:
    max_rate_deg_per_s: float
    accel_deg_per_s2: float


@dataclass(frozen=True)
class Plan:
    t_s: np.ndarray                 # sample times (seconds on the caller's time base)
    sky_az_deg: np.ndarray
    sky_el_deg: np.ndarray
    az_deg: np.ndarray              # mechanical trajectory to fly (wrap range, flip applied)
    el_deg: np.ndarray
    flip: bool
    wrap_turns: int                 # whole turns past the first of the mechanical azimuth at AOS
    peak_az_rate_deg_per_s: float
    peak_el_rate_deg_per_s: float
    rate_limited: bool              # the sky track was faster than the axes: smoothed
    blocked: np.ndarray             # samples inside a keep-out zone (the antenna waits there)
    preposition_start_s: float      # leave for the AOS pose at this time
    notes: tuple[str, ...] = field(default_factory=tuple)
    peak_az_accel_deg_per_s2: float = 0.0
    peak_el_accel_deg_per_s2: float = 0.0

    @property
    def aos_pose(self) -> tuple[float, float]:
        return float(self.az_deg[0]), float(self.el_deg[0])

    def pose_at(self, t_s: float) -> tuple[float, float, float, float]:
        """Mechanical (az, el, az_rate, el_rate) at t_s, interpolated."""
        # (min/max, not np.clip: this runs every tracker update, and np.clip on one
        # number costs several microseconds)
        t = min(max(float(t_s), float(self.t_s[0])), float(self.t_s[-1]))
        i = min(max(int(np.searchsorted(self.t_s, t)) - 1, 0), len(self.t_s) - 2)
        t0, t1 = self.t_s[i], self.t_s[i + 1]
        f = (t - t0) / (t1 - t0)
        az = self.az_deg[i] + f * (self.az_deg[i + 1] - self.az_deg[i])
        el = self.el_deg[i] + f * (self.el_deg[i + 1] - self.el_deg[i])
        inside = self.t_s[0] <= t_s <= self.t_s[-1]
        az_rate = (self.az_deg[i + 1] - self.az_deg[i]) / (t1 - t0) if inside else 0.0
        el_rate = (self.el_deg[i + 1] - self.el_deg[i]) / (t1 - t0) if inside else 0.0
        return float(az), float(el), float(az_rate), float(el_rate)

    def summary(self) -> dict:
        return {"flip": self.flip, "wrap_turns": self.wrap_turns, "aos_pose": self.aos_pose,
                "peak_az_rate_deg_per_s": round(self.peak_az_rate_deg_per_s, 3),
                "peak_el_rate_deg_per_s": round(self.peak_el_rate_deg_per_s, 3),
                "peak_az_accel_deg_per_s2": round(self.peak_az_accel_deg_per_s2, 3),
                "peak_el_accel_deg_per_s2": round(self.peak_el_accel_deg_per_s2, 3),
                "rate_limited": self.rate_limited, "blocked_fraction": float(self.blocked.mean()),
                "preposition_start_s": self.preposition_start_s, "notes": list(self.notes)}


#: how finely the way between two plan samples is checked against keep-out zones
ZONE_CHECK_STEP_DEG = 0.05


def _blocked(a: np.ndarray, e: np.ndarray, g: Geometry) -> np.ndarray:
    """Samples in a keep-out zone, and both ends of a step whose straight way between
    them cuts through one (a track passing a zone's corner)."""
    blocked = np.zeros(len(a), dtype=bool)
    if not g.zones:
        return blocked
    for i in range(len(a)):
        blocked[i] |= g.zone_at(a[i], e[i], margin_deg=0.0) is not None
        if i + 1 == len(a) or blocked[i]:
            continue
        n = int(math.ceil(max(abs(a[i + 1] - a[i]), abs(e[i + 1] - e[i])) / ZONE_CHECK_STEP_DEG))
        for f in np.arange(1, n) / n:
            if g.zone_at(a[i] + f * (a[i + 1] - a[i]), e[i] + f * (e[i + 1] - e[i]), margin_deg=0.0):
                blocked[i] = blocked[i + 1] = True
                break
    return blocked


def _budget(limits: AxisLimits) -> AxisLimits:
    """What the plan may use of an axis: headroom for the servo to correct errors."""
    return AxisLimits(RATE_BUDGET * limits.max_rate_deg_per_s, RATE_BUDGET * limits.accel_deg_per_s2)


class PlanError(TrackingError, ValueError):
    """No legal way to fly this pass (entirely outside the limits)."""


def _rate_limit(x: np.ndarray, t: np.ndarray, max_rate: float) -> np.ndarray:
    """The average of a forward and a backward rate-limited pass: centred on the fast
    segment, never faster than max_rate (the mean of two limited steps is limited)."""
    dt = np.diff(t)
    fwd = x.copy()
    for i in range(1, len(x)):
        step = max_rate * dt[i - 1]
        fwd[i] = fwd[i - 1] + np.clip(x[i] - fwd[i - 1], -step, step)
    bwd = x.copy()
    for i in range(len(x) - 2, -1, -1):
        step = max_rate * dt[i]
        bwd[i] = bwd[i + 1] + np.clip(x[i] - bwd[i + 1], -step, step)
    return 0.5 * (fwd + bwd)


def pointing_error_deg(az_m, el_m, sky_az, sky_el, g: Geometry) -> np.ndarray:
    """Great-circle angle between where mechanical poses point and the sky track."""
    return _sky_pose_error_deg(az_m + g.az_offset_deg, el_m + g.el_offset_deg, sky_az, sky_el)


def _sky_pose_error_deg(az, el, sky_az, sky_el) -> np.ndarray:
    """The same for poses in the sky frame (elevation past 90 is over the top)."""
    over = el > 90.0
    az = np.where(over, az + 180.0, az)
    el = np.where(over, 180.0 - el, el)
    return great_circle_deg(az, el, sky_az, sky_el)


#: plan steps are judged at this many points each (the keyhole's peak error falls between
#: 1 s samples: a satellite near the zenith crosses a degree of sky a second)
ERROR_SUBSTEPS = 8


def _error_between_samples_deg(az_m: np.ndarray, el_m: np.ndarray, s_az: np.ndarray, s_el: np.ndarray,
                               g: Geometry) -> np.ndarray:
    """Pointing error at the samples and between them, poses interpolated linearly as
    the tracker flies them (Plan.pose_at), the sky track along the great circle between
    its samples (interpolating its azimuth would cut corners round the zenith)."""
    f = np.arange(ERROR_SUBSTEPS) / ERROR_SUBSTEPS
    a, e = np.radians(s_az), np.radians(s_el)
    v = np.stack([np.cos(e) * np.sin(a), np.cos(e) * np.cos(a), np.sin(e)], axis=-1)
    vf = v[:-1, None, :] * (1 - f)[None, :, None] + v[1:, None, :] * f[None, :, None]
    vf = np.concatenate([vf.reshape(-1, 3), v[-1:]])
    sky_az = np.degrees(np.arctan2(vf[:, 0], vf[:, 1])) % 360.0
    sky_el = np.degrees(np.arcsin(np.clip(vf[:, 2] / np.linalg.norm(vf, axis=1), -1.0, 1.0)))

    def between(x: np.ndarray) -> np.ndarray:
        return np.concatenate([(x[:-1, None] * (1 - f) + x[1:, None] * f).ravel(), x[-1:]])
    return pointing_error_deg(between(az_m), between(el_m), sky_az, sky_el, g)


def _peak_rate(x: np.ndarray, t: np.ndarray) -> float:
    return float(np.max(np.abs(np.diff(x) / np.diff(t)))) if len(x) > 1 else 0.0


def _peak_accel(x: np.ndarray, t: np.ndarray) -> float:
    if len(x) < 3:
        return 0.0
    rate = np.diff(x) / np.diff(t)
    return float(np.max(np.abs(np.diff(rate) / np.diff(t)[1:])))


def _accel_limit(x: np.ndarray, t: np.ndarray, max_rate: float, max_accel: float) -> np.ndarray:
    """A moving average over 2 max_rate / max_accel seconds: the corners of a rate-limited
    track become ramps the axis can follow (a mean of rate-limited samples is itself
    rate-limited, and stays within the limits the samples are within)."""
    dt = float(np.median(np.diff(t)))
    w = int(math.ceil(2.0 * max_rate / max_accel / dt)) | 1  # odd: centred
    if w < 3:
        return x
    padded = np.concatenate([np.full(w // 2, x[0]), x, np.full(w // 2, x[-1])])
    return np.convolve(padded, np.ones(w) / w, mode="valid")


def _flyable(x: np.ndarray, t: np.ndarray, lo: float, hi: float, budget: AxisLimits) -> np.ndarray:
    """What an axis can really fly of track ``x``: rate-limited where it is too fast,
    acceleration-limited where it turns too sharply, within lo..hi. The same array when
    the track needs neither."""
    out = x
    if _peak_rate(out, t) > budget.max_rate_deg_per_s:
        out = np.clip(_rate_limit(out, t, budget.max_rate_deg_per_s), lo, hi)
    if _peak_accel(out, t) > budget.accel_deg_per_s2:
        out = np.clip(_accel_limit(out, t, budget.max_rate_deg_per_s, budget.accel_deg_per_s2), lo, hi)
    return out


def _projected_el_deg(az_deg: np.ndarray, s_az: np.ndarray, s_el: np.ndarray) -> np.ndarray:
    """Sky-frame elevation 0..180 along the vertical circle at ``az_deg`` (past 90 on the
    far side of the zenith) nearest the sky track (s_az, s_el); a track a hair below the
    horizon counts as on it."""
    a, e = np.radians(s_az), np.radians(np.clip(s_el, 0.0, 90.0))
    return np.degrees(np.arctan2(np.sin(e), np.cos(e) * np.cos(a - np.radians(az_deg))))


def _el_given_az(az_m: np.ndarray, s_az: np.ndarray, s_el: np.ndarray, g: Geometry) -> np.ndarray:
    """The mechanical elevation that points closest to the sky track (s_az, s_el) when the
    azimuth axis stands at ``az_m``: the sky direction projected onto the vertical circle
    through that azimuth, elevation 0..180 along it (past 90 is over the top), within the
    limits. Where the azimuth cannot keep up (the keyhole), sweeping the elevation over
    the top under a lagging azimuth bounds the error by the pass's distance from the
    zenith, instead of the elevation following its own track while the azimuth lags."""
    theta = _projected_el_deg(az_m + g.az_offset_deg, s_az, s_el)
    top = g.el_max_deg if g.can_fly_passes_flipped else min(g.el_max_deg, 90.0 - g.el_offset_deg)
    return np.clip(theta - g.el_offset_deg, g.el_min_deg, top)


def _base_trajectories(s_az: np.ndarray, s_el: np.ndarray, can_flip: bool):
    """(flip, (az, el)) before wrap offsets: the plain track, and on rotators whose
    elevation reaches 180, the all-flipped track and the two over-the-top tracks, which switch to the other pose
    (az+180, 180-el) at the culmination: a pass through the zenith is then flown by
    sweeping elevation past 90 while the azimuth stays put, instead of a 180 degree
    azimuth swing (the keyhole)."""
    def unwrap(a: np.ndarray) -> np.ndarray:
        return np.degrees(np.unwrap(np.radians(a)))  # continuous: no jump at north
    yield False, (unwrap(s_az), s_el)
    if not can_flip:
        return
    tca = int(np.argmax(s_el))
    after = np.arange(len(s_az)) > tca
    # flipped after, before, or all the way (the last uses the far side of the azimuth
    # range, e.g. a pass across north on a rotator with little overlap)
    for flipped_part in (after, ~after, np.ones_like(after)):
        az = np.where(flipped_part, (s_az + 180.0) % 360.0, s_az)
        el = np.where(flipped_part, 180.0 - s_el, s_el)
        yield True, (unwrap(az), el)


#: hold windows tried around the culmination of a keyhole pass (seconds either side of
#: it) and the ramps from the held azimuth back onto the track (seconds)
HOLD_HALF_WIDTHS_S = (0.0, 1.0, 2.0, 3.0, 5.0, 8.0, 12.0, 18.0, 25.0, 35.0, 50.0, 70.0, 100.0, 150.0)
HOLD_RAMPS_S = (2.0, 4.0, 7.0, 10.0, 15.0, 22.0, 32.0, 45.0, 65.0, 90.0)


def _keyhole_holds(t: np.ndarray, s_az: np.ndarray, s_el: np.ndarray, az_budget: AxisLimits,
                   el_budget: AxisLimits, peak_rate_deg_per_s: float):
    """The minimax plans of a keyhole pass on a rotator that can flip: (az, el, note) in
    the sky frame (azimuth continuous, elevation past 90 over the top).

    Why this is the minimax: with the elevation free, the error of a pose is the sky
    point's distance from the vertical circle the azimuth axis stands on. A pass flown
    over the top turns that circle by no net half turn while the target's azimuth turns
    half a turn, so the target crosses the perpendicular of the circle once, where the
    error is its whole zenith distance: at least the pass's distance from the zenith
    (90 - max el), reached only when the crossing is at culmination. Holding the azimuth
    on the direction of flight at culmination and sweeping the elevation over the top
    reaches exactly that bound and never exceeds it (a straight flight seen from the
    ground stays within its closest zenith distance of that circle). The alternative,
    turning the azimuth the half turn with the target (``_follow_minimax``), beats the
    bound only where the azimuth is fast enough for the pass; the planner compares both.

    Within the bound, the rest of the pass is flown as close to the track as the axes
    allow: the azimuth leaves the track for the held value only for a window around
    culmination, blended in and out (a weight between the two never adds error at any
    instant, as the pose always stands between the track and the hold). The narrowest
    window within the axes' speed and acceleration budget that loses the least (RMS)
    is chosen. Two variants: over the top after culmination, or before it."""
    n = len(t)
    tca = int(np.argmax(s_el))
    if n < 3 or not 0 < tca < n - 1:
        return
    # the direction of flight at culmination: seen through a gnomonic projection of the
    # sky (a straight flight stays straight), the chord across the culmination sample
    a, e = np.radians(s_az[tca - 1:tca + 2:2]), np.radians(np.clip(s_el[tca - 1:tca + 2:2], 1.0, 90.0))
    x, y = np.sin(a) / np.tan(e), np.cos(a) / np.tan(e)
    heading_deg = math.degrees(math.atan2(x[1] - x[0], y[1] - y[0]))
    d_s = np.abs(t - t[tca])
    before = np.arange(n) <= tca
    for hold_az, over_top in ((heading_deg + 180.0, ~before), (heading_deg, before)):
        pose_az = np.where(over_top, s_az + 180.0, s_az)
        rel = wrap180_deg(pose_az - hold_az)  # within +-90 of the hold: the blend's way

        def blended(w: np.ndarray, hold_az: float = hold_az, rel: np.ndarray = rel):
            az = hold_az + w * rel
            return az, _projected_el_deg(az, s_az, s_el)

        options = [(np.inf, np.inf, np.inf)]  # the azimuth held all the way: always an option
        for half_s in HOLD_HALF_WIDTHS_S:
            for ramp_s in HOLD_RAMPS_S:
                w = np.clip((d_s - half_s) / ramp_s, 0.0, 1.0)
                w = 0.5 - 0.5 * np.cos(np.pi * w)
                az, el = blended(w)
                if (_peak_rate(az, t) > az_budget.max_rate_deg_per_s
                        or _peak_accel(az, t) > az_budget.accel_deg_per_s2
                        or _peak_rate(el, t) > el_budget.max_rate_deg_per_s
                        or _peak_accel(el, t) > el_budget.accel_deg_per_s2):
                    continue
                err = _sky_pose_error_deg(az, el, s_az, s_el)
                options.append((float(np.sqrt(np.mean(err ** 2))), half_s, ramp_s))
                break  # a longer ramp for the same window only stays longer off the track
        _, half_s, ramp_s = min(options)
        w = np.zeros(n) if not math.isfinite(half_s) else \
            0.5 - 0.5 * np.cos(np.pi * np.clip((d_s - half_s) / ramp_s, 0.0, 1.0))
        az, el = blended(w)
        off_s = float(np.ptp(t[w < 1.0])) if (w < 1.0).any() else 0.0
        note = (f"keyhole: the sky track needs {peak_rate_deg_per_s:.1f} deg/s in azimuth at "
                f"culmination; the azimuth holds {hold_az % 360.0:.1f} deg there, "
                f"off the track for {off_s:.0f} s, while the elevation sweeps over the top (no plan over "
                "the top misses the pass by less than its distance from the zenith)")
        yield az, el, note


#: bisection steps of the follow minimax (90 deg / 2**20: far below any sensor's count)
MINIMAX_STEPS = 20


def _follow_minimax(t: np.ndarray, s_az: np.ndarray, s_el: np.ndarray, budget: AxisLimits):
    """The keyhole flown the other way, the azimuth turning the half turn with the
    target (no flip), as the minimax over the azimuth's speed: the least error E for
    which some azimuth path within the speed budget stays within E of the target at
    every sample. With the elevation free (on the vertical circle the azimuth stands on,
    ``_el_given_az``), a pose misses by asin(cos(el) |sin(az - az_m)|), so E allows the
    azimuth a band round the target's, wide where the target is near the zenith. A
    rate-limited path through a band exists iff the forward sweep of reachable intervals
    never empties; bisection finds the least E, and the backward sweep picks, within the
    band, the path nearest the track. Returns (az, el) in the sky frame."""
    u = np.degrees(np.unwrap(np.radians(s_az)))
    cos_el = np.cos(np.radians(np.clip(s_el, 0.0, 90.0)))
    step = budget.max_rate_deg_per_s * (1.0 - 1e-9) * np.diff(t)

    def sweep(err_deg: float):
        ratio = np.sin(np.radians(err_deg)) / np.maximum(cos_el, 1e-12)
        half = np.degrees(np.arcsin(np.clip(ratio, 0.0, 1.0)))
        lo, hi = u - half, u + half
        for i in range(1, len(u)):
            lo[i], hi[i] = max(lo[i], lo[i - 1] - step[i - 1]), min(hi[i], hi[i - 1] + step[i - 1])
            if lo[i] > hi[i]:
                return None
        return lo, hi

    if sweep(90.0) is None:
        return None
    bad, good = 0.0, 90.0
    for _ in range(MINIMAX_STEPS):
        mid = 0.5 * (bad + good)
        bad, good = (bad, mid) if sweep(mid) is not None else (mid, good)
    lo, hi = sweep(good)
    az = np.clip(u, lo, hi)
    for i in range(len(u) - 2, -1, -1):
        az[i] = min(max(u[i], lo[i], az[i + 1] - step[i]), hi[i], az[i + 1] + step[i])
    return az, _projected_el_deg(az, s_az, s_el)


#: candidate unwind moments per pass (every n-th sample)
UNWIND_CANDIDATES = 120


def _best_partial(t, s_az, s_el, g: Geometry, az_budget: AxisLimits, el_budget: AxisLimits):
    """No wrap turn holds the whole pass (it spans more azimuth than the range has around
    it, e.g. a pass across north on a 0..360 rotator). Two ways out, whichever loses
    less pointing (RMS over the pass): fly the turn that holds most of it and wait at
    the limit for the rest, or unwind once mid-pass (a 360 degree swing to the other
    turn) at the moment that costs least."""
    lo, hi = g.az_min_deg, g.az_max_deg
    options = []  # (rms, flip, az, el, note)

    def flown(a, e):
        fa = _flyable(a, t, lo, hi, az_budget)
        fe = _flyable(e, t, g.el_min_deg, g.el_max_deg, el_budget)
        err = pointing_error_deg(fa, fe, s_az, s_el, g)
        return float(np.sqrt(np.mean(err ** 2))), a, e

    for flip, (a, e) in _base_trajectories(s_az, s_el, g.can_fly_passes_flipped):
        a, e = a - g.az_offset_deg, np.clip(e - g.el_offset_deg, g.el_min_deg, g.el_max_deg)
        if (s_el - g.el_offset_deg).min() < g.el_min_deg - EL_SLACK_DEG and not flip:
            continue
        ks = range(int(np.floor((lo - a.max()) / 360.0)), int(np.ceil((hi - a.min()) / 360.0)) + 1)
        for k in ks:
            inside = float(np.mean((a + 360.0 * k >= lo) & (a + 360.0 * k <= hi)))
            if inside > 0:
                rms, fa, fe = flown(np.clip(a + 360.0 * k, lo, hi), e)
                options.append((rms, flip, fa, fe, f"no wrap turn holds the whole pass: {100 * (1 - inside):.0f}% "
                                "of it lies beyond the azimuth limits; the antenna waits at the limit there"))
        step = max(1, len(a) // UNWIND_CANDIDATES)
        for i in range(step, len(a) - 1, step):
            for k1 in ks:
                first = a[:i] + 360.0 * k1
                if first.min() < lo or first.max() > hi:
                    continue
                for k2 in (k1 - 1, k1 + 1):
                    second = a[i:] + 360.0 * k2
                    if second.min() >= lo and second.max() <= hi:
                        rms, fa, fe = flown(np.concatenate([first, second]), e)
                        options.append((rms, flip, fa, fe, f"no wrap turn holds the whole pass: the antenna "
                                        f"unwinds once, {t[i] - t[0]:.0f} s after AOS"))
    if not options:
        raise PlanError("the pass does not fit inside the azimuth/elevation limits on any wrap or flip")
    rms, flip, a, e, note = min(options, key=lambda o: (o[0], o[1]))
    return flip, a, e, note


def plan_pass(t_s: np.ndarray, sky_az_deg: np.ndarray, sky_el_deg: np.ndarray, geometry: Geometry,
              az: AxisLimits, el: AxisLimits, start_pose: tuple[float, float], now_s: float,
              continuing: bool = False) -> Plan:
    """Choose wrap turn and flip for the pass and return the trajectory to fly.
    Of equally good plans the one whose first pose is reached sooner wins, flipped or
    not, where the sensors read a flipped pose as such (``geometry.flip_sensed``);
    elsewhere the unflipped one (a compass on the boom reads a flipped pose 180 deg
    off). ``continuing``: the antenna is on the target already (a long arc planned
    anew): the pose nearest it wins, so that it does not swing to the other side
    mid-track.

    With a pointing model in force (``geometry.pointing_deg``, issue 38) the track is
    first taken to the boresight's directions that put the beam on it: the plan, its
    errors and its ``sky_*`` are in that frame, as the offsets are subtracted after."""
    t = np.asarray(t_s, dtype=float)
    s_az = np.asarray(sky_az_deg, dtype=float) % 360.0
    s_el = np.asarray(sky_el_deg, dtype=float)
    if geometry.pointing_deg:
        from ..pointing.model import PointingModel

        s_az, s_el = PointingModel.from_vector(geometry.pointing_deg).mech_from_beam(s_az, s_el)
    if len(t) < 2:
        raise PlanError("a pass needs at least two samples")
    g = geometry
    az_budget, el_budget = _budget(az), _budget(el)
    base = [(flip, a, e, None) for flip, (a, e) in _base_trajectories(s_az, s_el, g.can_fly_passes_flipped)]
    peak_rate = _peak_rate(base[0][1], t)
    if peak_rate > az_budget.max_rate_deg_per_s:
        follow = _follow_minimax(t, s_az, s_el, az_budget)
        if follow is not None:
            base.append((False, *follow, f"keyhole: the sky track needs {peak_rate:.1f} deg/s in azimuth; "
                         "the azimuth turns with it as fast as it can, the elevation making up for its lag"))
        if g.can_fly_passes_flipped:
            base += [(True, a, e, note) for a, e, note in
                     _keyhole_holds(t, s_az, s_el, az_budget, el_budget, peak_rate)]
    candidates = []
    for flip, a, e, keyhole in base:
        a = a - g.az_offset_deg
        e = e - g.el_offset_deg
        # AOS/LOS sit on the horizon mask to within a millidegree or so: a hair below the
        # elevation limit is the limit, not a reason to give up the pass
        if e.min() < g.el_min_deg - EL_SLACK_DEG or e.max() > g.el_max_deg + EL_SLACK_DEG:
            continue
        k_lo = int(np.ceil((g.az_min_deg - a.min()) / 360.0 - 1e-9))
        k_hi = int(np.floor((g.az_max_deg - a.max()) / 360.0 + 1e-9))
        for k in range(k_lo, k_hi + 1):
            candidates.append((flip, a + 360.0 * k, np.clip(e, g.el_min_deg, g.el_max_deg), keyhole))
    notes = []
    if not candidates:
        flip, a_best, e_best, note = _best_partial(t, s_az, s_el, g, az_budget, el_budget)
        candidates = [(flip, a_best, e_best, None)]
        notes.append(note)

    rates = (az.max_rate_deg_per_s, el.max_rate_deg_per_s)
    sooner_first = continuing or g.flip_sensed
    best = None
    for flip, a, e, keyhole in candidates:
        fa = _flyable(a, t, g.az_min_deg, g.az_max_deg, az_budget)
        if fa is not a:
            # the azimuth lags its track somewhere: the elevation makes up for it there
            lag = np.abs(fa - a) > 1e-6
            e = np.where(lag, _el_given_az(fa, s_az, s_el, g), e)
        fe = _flyable(e, t, g.el_min_deg, g.el_max_deg, el_budget)
        travel_s = route_time_s([start_pose, (fa[0], fe[0])], rates)
        if g.zones and g.segment_clear(start_pose, (fa[0], fe[0]), rates) is not None:
            # the way to the AOS pose goes round a keep-out zone: time that route
            route = g.plan(start_pose, *g.to_sky(fa[0], fe[0]), rates)
            if route is not None:
                travel_s = route_time_s([start_pose] + route, rates)
        # the smallest worst-case pointing error wins (to 0.05 deg: below that the
        # servo decides); then, where the flip is sensed (or the arc continues), the
        # pose reached sooner, to a second (issue 36.21: an unflipped start 314 deg
        # away was chosen over a flipped one 135 deg away); then no flip; then the
        # smaller worst case, to a millidegree (a keyhole's minimax against a near
        # miss); then the shorter pre-positioning move
        worst = float(_error_between_samples_deg(fa, fe, s_az, s_el, g).max())
        sooner = round(travel_s) if sooner_first else 0
        cost = (round(worst / 0.05), sooner, flip, round(worst / 0.001), travel_s)
        if best is None or cost < best[0]:
            best = (cost, flip, fa, fe, travel_s, a, e, worst, not (fa is a and fe is e), keyhole)
    assert best is not None  # (candidates is never empty)
    _, flip, a_fly, e_fly, travel_s, a, e, worst, rate_limited, keyhole = best
    if keyhole and not rate_limited:
        rate_limited = True  # the sky track was faster than the axes: a keyhole plan is the smoothing
        notes.append(f"{keyhole}; worst pointing error {worst:.2f} deg")
    elif rate_limited:
        notes.append(f"the sky track needs {_peak_rate(a, t):.1f} deg/s in azimuth at the fastest (keyhole); "
                     f"flown within the axes' speed and acceleration, worst pointing error {worst:.2f} deg")
    a, e = a_fly, e_fly
    blocked = _blocked(a, e, g)
    if blocked.any():
        notes.append(f"{blocked.mean() * 100:.0f}% of the pass lies in a keep-out zone; "
                     "the antenna waits at its edge")
    accel_s = az.max_rate_deg_per_s / az.accel_deg_per_s2 + el.max_rate_deg_per_s / el.accel_deg_per_s2
    start = float(t[0] - travel_s - accel_s - PREPOSITION_MARGIN_S)
    wrap = int(np.floor((a[0] + g.az_offset_deg) / 360.0))
    return Plan(t_s=t, sky_az_deg=s_az, sky_el_deg=s_el, az_deg=a, el_deg=e, flip=flip, wrap_turns=wrap,
                peak_az_rate_deg_per_s=_peak_rate(a, t), peak_el_rate_deg_per_s=_peak_rate(e, t),
                peak_az_accel_deg_per_s2=_peak_accel(a, t), peak_el_accel_deg_per_s2=_peak_accel(e, t),
                rate_limited=rate_limited, blocked=blocked, preposition_start_s=max(start, now_s),
                notes=tuple(notes))
