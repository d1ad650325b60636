"""Step-track (issue 38 part 5): follow a satellite whose elements are off by its signal.

The control process keeps flying a pass program (urc.model.program); this module, on
the I/O side, re-uploads the rest of the pass corrected by what the received power
shows. Each upload carries a small cross scan around the corrected prediction for the
next SCAN_AHEAD_S (five points, centre and +-r in each axis, DWELL_S each, phased on
the control clock), then the corrected prediction to LOS: an I/O process that goes
silent leaves the antenna on its best estimate, never on a scan. The poses are the
plan's (wrap turn and flip as planned) shifted in time, plus the sky offset in the
plan's frame, clamped to the limits; keep-out zones are marked blocked, and the control
process checks every pose on accept as for any program.

Estimation, once per scan cycle: the samples' reported poses are taken relative to the
prediction at the current time offset, the power (linear) fitted with the beam (a
Gaussian of the configured width over the noise floor measured before AOS) for the
satellite's offset (cx, cy) on the sky. Its component along the predicted sky motion v
is a time error (the satellite passes ``time_offset_s`` later than its elements say:
truth(t) = prediction(t - time_offset_s)); it updates a Kalman estimate of the time
offset, weighted by the fit's uncertainty over |v| (a slow satellite near the horizon
tells little). The component across is kept as a cross-track offset (bounded).

Refused, never fitted: saturated samples, no signal, a peak beyond a beamwidth, too few
samples. Signal loss falls back to the prediction: shifted by the time offset estimated
so far (the issue's "applied for the rest of the pass"), no cross-track offset, no scan;
an acquisition search is tried again after REACQUIRE_S.

Lock and loss are decided by a detection, not by the fit: is there power over the floor
in this cycle? z = (mean power - floor) / (sigma / sqrt(n)) over the cycle's n samples,
sigma the sample noise from successive differences (sqrt(mean(dp^2) / 2): a slow change
of the signal across the scan hardly enters). With noise alone z is about N(0, 1)
(independent samples; a source repeating its last reading would make sigma too small).
The fit's own amplitude test is the wrong judge of that: five points within 0.12
beamwidth of each other cannot tell a weak peak near the centre from a strong one
further out, so its amplitude uncertainty is large while the power plainly is there
(at 3 dB the ISS pass lost and found the signal 8 times, every loss a "no significant
peak" with the satellite in the beam). A detected cycle whose fit is refused or
uncertain is not a failure: the estimate is simply not moved (the fit's covariance
weighs what is fitted). Thresholds:
- DETECT_Z = 4: a false detection on noise about once in 10 000 cycles (Student's t
  tail, 50 samples a cycle, the noise estimated); a 3 dB satellite within the tracking
  scan gives z ~ 13 over a 10 s cycle.
- LOCK_CYCLES = 2 fitted detections in a row to lock (a search step, then the
  estimate it gave): a false lock needs two false detections in a row, ~1e-8 a cycle.
  While tracking, a detected cycle whose fit is refused neither counts toward a loss
  nor moves the estimate.
- FIT_SIGNIFICANCE = 3 for a detected cycle's fit (fit.MIN_SIGNIFICANCE = 5 where no
  detection is made): the detection has said the signal is there.
- LOSS_CYCLES = 3 failed cycles in a row (30 s) to drop: a miss while the signal is
  there is then one in ~1e-6 even where a single cycle misses one time in a hundred;
  the price is 30 s of small scans around the last estimate before the prediction
  alone, which is where the fallback points anyway (a saturated cycle drops at once:
  its power says nothing).
Without a floor (none read before AOS, none configured) there is no detection and the
fit's own significance decides, as before.

Acquisition: a satellite whose elements are 30 s off is 15 deg from its prediction in
mid-pass, beyond a narrow beam's reach, and nothing in the power says which way: one
acquisition cycle is flown at each time offset along the predicted track (0, +h, -h,
+2h, ... up to MAX_SEARCH_S), where a satellite late or early must be; the first cycle
whose fit holds locks. A search that finds nothing falls back to the prediction.
"""

from __future__ import annotations

import math
from concurrent.futures import Future, ThreadPoolExecutor
from typing import Any, Callable

import numpy as np

from ..angles import wrap180_deg
from ..model.program import PassProgram
from ..pointing.fit import FWHM_PER_SIGMA, MIN_SIGNIFICANCE, ScanRefused, _lm
from .prediction import Prediction, orbit_prediction
from ..pointing.sources import SignalRefused, to_linear

#: each scan point is held this long (the program's dense samples are DENSE_S apart)
DWELL_S = 2.0
DENSE_S = 0.5
#: the scan's points: the centre, then +-r across and in elevation
PATTERN = ((0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0))
CYCLE_S = DWELL_S * len(PATTERN)
#: scan radius in beamwidths: tracking (small: the beam stays within a quarter beamwidth
#: of the satellite) and acquiring (wider: the first offset may be half a beamwidth)
TRACK_RADIUS_FWHM = 0.12
ACQUIRE_RADIUS_FWHM = 0.3
#: how far ahead each upload carries the scan (then the corrected prediction to LOS)
SCAN_AHEAD_S = 3 * CYCLE_S
#: an offset pose stays this far inside the limits (the plan's own pose may be closer)
LIMIT_MARGIN_DEG = 1.0
#: a fitted peak further than this from the prediction is refused (off the scan)
MAX_FIT_FWHM = 1.0
#: bounds on what is applied
MAX_TIME_OFFSET_S = 300.0
MAX_CROSS_FWHM = 0.5
#: the time offset's prior (s) and random walk (s^2 per s); the cross-track's (deg^2 per s)
TIME_PRIOR_S = 60.0
TIME_WALK_S2_PER_S = 0.02
CROSS_WALK_DEG2_PER_S = 0.002
#: the noise floor is read before AOS - FLOOR_GUARD_S (a satellite this early is still below)
FLOOR_GUARD_S = 60.0
FLOOR_MIN_SAMPLES = 10
#: detection: the cycle's power over the floor in standard errors; detected cycles in a
#: row to lock; failed cycles in a row to drop (the module docstring says why); once
#: lost, the prediction alone this long before an acquisition search again
DETECT_Z = 4.0
LOCK_CYCLES = 2
LOSS_CYCLES = 3
#: a detected cycle's fit is used when its peak is this many standard uncertainties
#: (the detection already says the signal is there; this keeps the position's
#: linearised covariance meaningful); where no detection is made, fit.MIN_SIGNIFICANCE
FIT_SIGNIFICANCE = 3.0
REACQUIRE_S = 30.0
#: acquisition: one scan cycle at each time offset along the predicted track, 0, +h, -h,
#: +2h, ... (h: this many beamwidths of the sky motion), up to MAX_SEARCH_S either way
SEARCH_STEP_FWHM = 0.8
MAX_SEARCH_S = 90.0
#: samples a cycle's fit needs
MIN_SAMPLES = 12
#: slower than this on the sky (deg/s), no time offset is observable: all goes across
MIN_SKY_RATE_DEG_S = 0.01
#: a time offset change announced as an event when it moves this much (and 2 sigma)
ANNOUNCE_S = 1.0
ANNOUNCE_EVERY_S = 30.0
#: the Earth's rotation (rad/s, sidereal)
def fit_beam(dx: Any, dy: Any, power_lin: Any, *, fwhm_deg: float, floor: float | None,
             min_significance: float = MIN_SIGNIFICANCE) -> tuple[np.ndarray, np.ndarray, float, float]:
    """The satellite's (cx, cy) from samples at sky offsets (dx, dy) of linear power:
    a Gaussian beam of the known width over ``floor`` (None: fitted too). Returns
    (centre, its 2x2 covariance, peak, peak's uncertainty); ScanRefused if no peak of
    ``min_significance`` standard uncertainties or a peak off the scan."""
    x, y, p = (np.asarray(v, dtype=float) for v in (dx, dy, power_lin))
    if len(p) < MIN_SAMPLES or not np.all(np.isfinite(p)):
        raise ScanRefused("few", f"{len(p)} samples, at least {MIN_SAMPLES} needed")
    s2 = (fwhm_deg / FWHM_PER_SIGMA) ** 2
    base = floor if floor is not None else float(np.min(p))
    q = np.maximum(p - base, 0.0)
    w = q + 1e-12
    p0 = [max(float(np.max(p)) - base, 1e-9), float(np.sum(w * x) / np.sum(w)), float(np.sum(w * y) / np.sum(w))]
    if floor is None:
        p0.append(base)

    def fun(v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        a, cx, cy = v[:3]
        b = v[3] if floor is None else floor
        g = np.exp(-((x - cx) ** 2 + (y - cy) ** 2) / (2 * s2))
        cols = [g, a * g * (x - cx) / s2, a * g * (y - cy) / s2]
        if floor is None:
            cols.append(np.ones_like(x))
        return b + a * g - p, np.stack(cols, axis=1)
    v, cov, _ = _lm(fun, np.array(p0))
    a, cx, cy = (float(c) for c in v[:3])
    a_err = math.sqrt(abs(cov[0, 0]))
    if not (a > 0 and np.all(np.isfinite(cov[:3, :3])) and a >= min_significance * a_err):
        raise ScanRefused("noise", f"no significant peak: {a:.3g} +- {a_err:.2g} (at the noise floor)")
    if math.hypot(cx, cy) > MAX_FIT_FWHM * fwhm_deg:
        raise ScanRefused("off_scan", f"peak {math.hypot(cx, cy):.2f} deg from the prediction, more than "
                          f"{MAX_FIT_FWHM:g} beamwidth")
    return np.array([cx, cy]), np.asarray(cov[1:3, 1:3]), a, a_err


def detection_z(power_lin: Any, floor: float) -> float:
    """The samples' mean over ``floor`` in standard errors, the noise from successive
    differences (a slow change of the signal hardly enters); about N(0, 1) on noise."""
    p = np.asarray(power_lin, dtype=float)
    if len(p) < 3:
        return math.nan
    sigma = math.sqrt(float(np.mean(np.diff(p) ** 2)) / 2.0)
    if sigma <= 0.0:
        return math.nan  # (a source repeating one value: nothing to judge by)
    return float((np.mean(p) - floor) / (sigma / math.sqrt(len(p))))


class _Reader:
    """One power read per call, never blocking: a source with ``read_at(status, u)``
    (the simulator's) is read at once; any other on a worker thread, its sample taken
    with the pose of the status it was asked at."""

    def __init__(self, source: Any):
        self.source = source
        self._pool = None if hasattr(source, "read_at") else ThreadPoolExecutor(1, thread_name_prefix="urc-steptrack")
        self._pending: tuple[Future, tuple[float, float, float]] | None = None

    def poll(self, status: Any, u: float) -> list[tuple[tuple[float, float, float], Any]]:
        pose = (u, float(status.az_deg), float(status.el_deg))
        if self._pool is None:
            return [(pose, _call(lambda: self.source.read_at(status, u)))]
        out = []
        if self._pending is not None:
            fut, was = self._pending
            if not fut.done():
                return []
            out.append((was, _call(fut.result)))
        self._pending = (self._pool.submit(self.source.read), pose)
        return out

    def close(self) -> None:
        if self._pool is not None:
            self._pool.shutdown(wait=False, cancel_futures=True)


def _call(fn: Callable[[], Any]) -> Any:
    try:
        return fn()
    except SignalRefused as exc:
        return exc
    except Exception as exc:  # noqa: BLE001 (a source's own bug: a bad sample, never fitted)
        return SignalRefused("bad", f"{type(exc).__name__}: {exc}")


class StepTrack:
    """One pass's step-track: ``step`` with each tracker update; returns a program to
    upload (or None). ``geometry``: the rotator's (limits, zones); ``new_id``: program ids."""

    def __init__(self, plan: Any, name: str, source: Any, geometry: Any, *, fwhm_deg: float,
                 new_id: Callable[[], int], end: str = "park", floor_db: float | None = None,
                 ceiling_db: float | None = None, prediction: Prediction | None = None):
        self.plan, self.name, self.geometry = plan, name, geometry
        self.fwhm_deg, self.new_id, self.end = float(fwhm_deg), new_id, end
        self.ceiling_db = ceiling_db
        self.pred = prediction if prediction is not None else Prediction(plan)
        self.reader = _Reader(source)
        self.state = "floor"          # floor -> waiting -> searching <-> tracking / lost
        self.time_offset_s, self.time_var_s2 = 0.0, TIME_PRIOR_S ** 2
        self.cross_deg, self.cross_var_deg2 = 0.0, (MAX_CROSS_FWHM * fwhm_deg) ** 2
        self._floor: list[float] = []
        self.floor = 10.0 ** (floor_db / 10.0) if floor_db is not None else None
        self._samples: list[tuple[float, float, float, float]] = []   # (u, az, el, power linear)
        self._refused: dict[str, int] = {}
        self._cycle = -1
        self._fails = 0               # refused cycles in a row
        self._hits = 0                # detected cycles in a row
        self.detect_z = math.nan      # the last cycle's detection statistic
        self._retry_u = -math.inf     # lost: the prediction alone until then
        self._search_k = 0            # the acquisition search's step (0: the estimate itself)
        self._search_h_s = 0.0
        self._ref_s = 0.0             # the time offset the program flown this cycle used
        self._last_fit_u = -math.inf
        self.fits = 0
        self.last_refusal = ""
        self.events: list[str] = []
        self._announced = (math.nan, -math.inf)   # (time offset, when)

    # ------------------------------------------------------------------ the loop
    def step(self, status: Any, now_s: float, utc_minus_clock_s: float, program_state: str) -> PassProgram | None:
        u = now_s + utc_minus_clock_s
        aos_u = float(self.plan.t_s[0])
        if program_state != "tracking":
            if u < aos_u - FLOOR_GUARD_S and self.floor is None:
                self._read_floor(status, u)
            elif self.state == "floor":
                self.state = "waiting"
            return None
        if self.state in ("floor", "waiting"):
            self._set_floor()
            self._search(u)
            self._cycle = int(now_s // CYCLE_S)
            return self._program(now_s, utc_minus_clock_s)
        if self.state != "lost":
            for pose, got in self.reader.poll(status, u):
                self._take(pose, got)
        cycle = int(now_s // CYCLE_S)
        if cycle == self._cycle:
            return None
        self._cycle = cycle
        if self.state == "lost":
            if u < self._retry_u:
                return None
            self._search(u)
            self._samples.clear()
            self._refused.clear()
            return self._program(now_s, utc_minus_clock_s)
        self._estimate(u)
        return self._program(now_s, utc_minus_clock_s)

    def _search(self, u: float) -> None:
        """Start an acquisition search along the predicted track."""
        vx, vy = self.pred.rate(u - self.time_offset_s)
        self.state, self._fails, self._hits, self._search_k = "searching", 0, 0, 0
        # (at most a third of the search's reach: near the horizon the satellite crawls
        # across the sky and one step would end the search)
        self._search_h_s = min(SEARCH_STEP_FWHM * self.fwhm_deg / max(math.hypot(vx, vy), MIN_SKY_RATE_DEG_S),
                               MAX_SEARCH_S / 3.0)

    @property
    def search_offset_s(self) -> float:
        """The time offset tried on top of the estimate in this acquisition cycle."""
        if self.state != "searching" or self._search_k == 0:
            return 0.0
        n = (self._search_k + 1) // 2
        return n * self._search_h_s * (1.0 if self._search_k % 2 else -1.0)

    def _read_floor(self, status: Any, u: float) -> None:
        for _pose, got in self.reader.poll(status, u):
            if not isinstance(got, SignalRefused):
                self._floor.append(to_linear(got.value, got.unit))

    def _set_floor(self) -> None:
        if self.floor is None and len(self._floor) >= FLOOR_MIN_SAMPLES:
            self.floor = float(np.median(self._floor))
        self._floor = []

    def _take(self, pose: tuple[float, float, float], got: Any) -> None:
        if isinstance(got, SignalRefused):
            self._refused[got.reason] = self._refused.get(got.reason, 0) + 1
            return
        if self.ceiling_db is not None and got.value >= self.ceiling_db:
            self._refused["saturated"] = self._refused.get("saturated", 0) + 1
            return
        self._samples.append((*pose, to_linear(got.value, got.unit)))

    # ------------------------------------------------------------------ estimation
    def _estimate(self, u: float) -> None:
        samples, refused = self._samples, dict(self._refused)
        self._samples, self._refused = [], {}
        try:
            if refused.get("saturated"):
                raise ScanRefused("saturated", f"{refused['saturated']} saturated sample(s): the peak's power is "
                                  "unknown (add attenuation)")
            if len(samples) < MIN_SAMPLES:
                why = ", ".join(f"{k} {v}" for k, v in sorted(refused.items())) or "none read"
                raise ScanRefused("few", f"{len(samples)} usable samples ({why})")
            t, az, el, p = (np.array(c) for c in zip(*samples))
            if self.floor is not None:
                self.detect_z = detection_z(p, self.floor)
                if not self.detect_z >= DETECT_Z:
                    raise ScanRefused("noise", f"no signal: the power {self.detect_z:.1f} standard errors over the "
                                      f"floor, {DETECT_Z:g} needed")
            paz, pel = self.pred.seen(t, self._ref_s)
            dx = wrap180_deg(az - paz) * np.cos(np.radians(el))
            dy = el - pel
            try:
                centre, cov, _a, _a_err = fit_beam(dx, dy, p, fwhm_deg=self.fwhm_deg, floor=self.floor,
                                                   min_significance=MIN_SIGNIFICANCE if self.floor is None
                                                   else FIT_SIGNIFICANCE)
            except ScanRefused as exc:
                if self.floor is None or self.state != "tracking":
                    raise
                # tracking, the signal there but the fit cannot place it: no update, no failure
                self.last_refusal = f"signal detected, fit refused: {exc}"
                self._fails = 0
                return
        except ScanRefused as exc:
            self._refuse(exc, u)
            return
        self._detected(float(np.mean(t)), centre, cov, u)

    def _detected(self, t_mid: float, centre: np.ndarray, cov: np.ndarray, u: float) -> None:
        """A cycle with the signal, fitted: the estimate moved; locked after LOCK_CYCLES
        in a row."""
        self._fails = 0
        self._hits += 1
        if self.state == "searching" and self._search_k:
            # found at this step of the search: the estimate is where it was flown
            self.time_offset_s += self.search_offset_s
            self.time_var_s2 = min(self.time_var_s2, self._search_h_s ** 2)
            self._search_k = 0
        self._update(t_mid, centre, cov, u)
        if self.state == "searching" and self._hits >= LOCK_CYCLES:
            self.state = "tracking"
            self._say(f"step-track: {self.name} found by its signal: time offset {self.time_offset_s:+.1f} "
                      f"+- {self.time_err_s:.1f} s, cross-track {self.cross_deg:+.2f} deg", u)

    def _update(self, t_mid: float, centre: np.ndarray, cov: np.ndarray, u: float) -> None:
        vx, vy = self.pred.rate(t_mid - self._ref_s)
        speed = math.hypot(vx, vy)
        dt = max(0.0, u - self._last_fit_u) if math.isfinite(self._last_fit_u) else CYCLE_S
        self._last_fit_u = u
        self.time_var_s2 += TIME_WALK_S2_PER_S * dt
        self.cross_var_deg2 += CROSS_WALK_DEG2_PER_S * dt
        if speed >= MIN_SKY_RATE_DEG_S:
            along_hat = np.array([vx, vy]) / speed
            across_hat = np.array([-along_hat[1], along_hat[0]])
            along, across = float(centre @ along_hat), float(centre @ across_hat)
            # truth(t) = pred(t - T) + along v_hat = pred(t - (T - along / |v|))
            meas_s, meas_var = self._ref_s - along / speed, float(along_hat @ cov @ along_hat) / speed ** 2
            k = self.time_var_s2 / (self.time_var_s2 + meas_var)
            self.time_offset_s = float(np.clip(self.time_offset_s + k * (meas_s - self.time_offset_s),
                                               -MAX_TIME_OFFSET_S, MAX_TIME_OFFSET_S))
            self.time_var_s2 *= 1.0 - k
        else:
            across, across_hat = float(np.hypot(*centre)), np.zeros(2)
        across_var = float(across_hat @ cov @ across_hat) if speed >= MIN_SKY_RATE_DEG_S else float(np.trace(cov))
        k = self.cross_var_deg2 / (self.cross_var_deg2 + across_var)
        bound = MAX_CROSS_FWHM * self.fwhm_deg
        self.cross_deg = float(np.clip(self.cross_deg + k * (across - self.cross_deg), -bound, bound))
        self.cross_var_deg2 *= 1.0 - k
        self.fits += 1
        if self.state == "tracking":
            last, when = self._announced
            if (abs(self.time_offset_s - last) >= max(ANNOUNCE_S, 2 * self.time_err_s)
                    and u - when >= ANNOUNCE_EVERY_S):
                self._say(f"step-track: {self.name} time offset {self.time_offset_s:+.1f} +- "
                          f"{self.time_err_s:.1f} s", u)

    def _refuse(self, exc: ScanRefused, u: float) -> None:
        self.last_refusal = str(exc)
        self._fails += 1
        self._hits = 0
        if self.state == "searching" and exc.reason != "saturated":
            self._search_k += 1
            if abs(self.search_offset_s) <= MAX_SEARCH_S:
                return  # the next time offset along the track
        elif self.state == "tracking" and self._fails < LOSS_CYCLES and exc.reason != "saturated":
            return
        was = self.state
        self.state, self._retry_u, self.cross_deg = "lost", u + REACQUIRE_S, 0.0
        if was == "tracking" or exc.reason == "saturated":
            self._say(f"step-track: {self.name} signal lost ({exc}): flying the prediction, time offset "
                      f"{self.time_offset_s:+.1f} s kept", u)

    def upload_refused(self, why: str, u: float) -> None:
        """The control process refused a corrected program: the prediction then."""
        self.last_refusal = f"program refused: {why}"
        self.state, self._retry_u, self.cross_deg = "lost", u + REACQUIRE_S, 0.0

    def _say(self, text: str, u: float) -> None:
        self.events.append(text)
        self._announced = (self.time_offset_s, u)

    def take_events(self) -> list[str]:
        out, self.events = self.events, []
        return out

    @property
    def time_err_s(self) -> float:
        return math.sqrt(self.time_var_s2)

    # ------------------------------------------------------------------ the program
    @property
    def radius_deg(self) -> float:
        if self.state == "tracking":
            return TRACK_RADIUS_FWHM * self.fwhm_deg
        return ACQUIRE_RADIUS_FWHM * self.fwhm_deg if self.state == "searching" else 0.0

    def _program(self, now_s: float, utc_minus_clock_s: float) -> PassProgram:
        self._ref_s = self.time_offset_s + self.search_offset_s
        return build_program(self.plan, self.pred, self.geometry, program_id=self.new_id(), name=self.name,
                             end=self.end, now_s=now_s, utc_minus_clock_s=utc_minus_clock_s,
                             time_offset_s=self._ref_s,
                             cross_deg=self.cross_deg if self.state == "tracking" else 0.0,
                             radius_deg=self.radius_deg)

    def correction_at(self, u: float) -> tuple[float, float]:
        """(az, el) the corrected prediction differs from the elements' at UTC ``u``, deg."""
        cross = self.cross_deg if self.state == "tracking" else 0.0
        az0, el0 = self.pred.at(u)
        x, y = _centre(self.pred, u - self.time_offset_s, cross)
        az1, el1 = self.pred.seen(u, self.time_offset_s)
        az1 = az1 + x / max(math.cos(math.radians(el1 + y)), 1e-3)
        return float(wrap180_deg(az1 - az0)), float(el1 + y - el0)

    def status(self, u: float) -> dict[str, Any]:
        daz, de = self.correction_at(u)
        return {"state": self.state, "time_offset_s": round(self.time_offset_s, 2),
                "time_offset_err_s": round(self.time_err_s, 2), "cross_track_deg": round(self.cross_deg, 3),
                "az_offset_deg": round(daz, 3), "el_offset_deg": round(de, 3), "fits": self.fits,
                "beamwidth_deg": self.fwhm_deg, "scan_radius_deg": round(self.radius_deg, 3),
                "noise_floor_db": None if self.floor is None else round(10 * math.log10(self.floor), 2),
                "detection_z": None if not math.isfinite(self.detect_z) else round(self.detect_z, 1),
                "last_refusal": self.last_refusal or None}

    def close(self) -> None:
        self.reader.close()


def _centre(pred: Prediction, u_pred: Any, cross_deg: float) -> tuple[Any, Any]:
    """The cross-track offset as a sky (dx, dy) at prediction time ``u_pred``."""
    if cross_deg == 0.0:
        return np.zeros_like(np.asarray(u_pred, dtype=float)), np.zeros_like(np.asarray(u_pred, dtype=float))
    u = np.atleast_1d(np.asarray(u_pred, dtype=float))
    v = np.array([pred.rate(float(x)) for x in u])
    n = np.hypot(v[:, 0], v[:, 1])
    n = np.where(n > 0, n, 1.0)
    x, y = -v[:, 1] / n * cross_deg, v[:, 0] / n * cross_deg
    return (x, y) if np.ndim(u_pred) else (float(x[0]), float(y[0]))


def scan_offset(t_s: Any, radius_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """The scan's (dx, dy) at control-clock times ``t_s``: PATTERN, DWELL_S a point."""
    k = (np.floor(np.asarray(t_s, dtype=float) / DWELL_S).astype(int)) % len(PATTERN)
    pat = np.array(PATTERN)
    return pat[k, 0] * radius_deg, pat[k, 1] * radius_deg


def build_program(plan: Any, pred: Prediction, geometry: Any, *, program_id: int, name: str, end: str,
                  now_s: float, utc_minus_clock_s: float, time_offset_s: float, cross_deg: float,
                  radius_deg: float) -> PassProgram:
    """The rest of the pass from ``now_s`` (control clock): the plan at t - time_offset
    (UTC), the cross-track offset and, for SCAN_AHEAD_S, the scan added on the sky in the
    plan's frame; clamped to the limits, poses in keep-out zones blocked."""
    off = utc_minus_clock_s
    plan_t = np.asarray(plan.t_s, dtype=float)
    start = math.floor(now_s / DENSE_S) * DENSE_S - DENSE_S  # (in the past: flown at once, no pre-position)
    # (never before the predicted LOS: a search step back in time must not end the pass;
    # past the plan's end the LOS pose is held)
    los = float(plan_t[-1]) + max(time_offset_s, 0.0) - off
    if los <= start + DENSE_S:
        los = start + 2 * DENSE_S
    dense_end = min(start + DENSE_S + SCAN_AHEAD_S, los) if radius_deg > 0 else start + DENSE_S
    dense = np.arange(start, dense_end, DENSE_S)
    rest = np.append(plan_t + time_offset_s - off, los)
    rest = np.unique(rest[(rest > dense[-1] + 1e-3) & (rest <= los)])
    t = np.concatenate([dense, rest])
    if len(t) < 2:
        t = np.array([start, max(los, start + DENSE_S)])
    u_pred = t + off - time_offset_s
    sx, sy = scan_offset(t, radius_deg)
    sx = np.where(t < dense_end, sx, 0.0)
    sy = np.where(t < dense_end, sy, 0.0)
    cx, cy = _centre(pred, u_pred, cross_deg)
    ex, ey = pred.earth_turn(t + off, time_offset_s)
    ox, oy = sx + cx + ex, sy + cy + ey
    _, sky_el = pred.at(u_pred)
    g = geometry
    az = np.empty(len(t))
    el = np.empty(len(t))
    blocked = np.zeros(len(t), dtype=bool)
    plan_blocked = np.asarray(plan.blocked, dtype=float)
    flip = -1.0 if plan.flip else 1.0   # over the top the elevation axis runs the other way
    for i, ui in enumerate(u_pred):
        a, e, _, _ = plan.pose_at(float(ui))
        c = max(math.cos(math.radians(min(sky_el[i] + oy[i], 89.0))), 0.05)
        a = _within(a + ox[i] / c, a, g.az_min_deg, g.az_max_deg)
        e = _within(e + flip * oy[i], e, g.el_min_deg, g.el_max_deg)
        az[i], el[i] = a, e
        blocked[i] = bool(np.interp(ui, plan_t, plan_blocked) > 0) or \
            (bool(g.zones) and g.zone_at(a, e, margin_deg=0.0) is not None)
    return PassProgram(program_id=program_id, name=name, t_s=tuple(t.tolist()), az_deg=tuple(az.tolist()),
                       el_deg=tuple(el.tolist()), blocked=tuple(blocked.tolist()),
                       preposition_start_s=float(t[0]), end=end)


def _within(x: float, base: float, lo: float, hi: float) -> float:
    """``x`` kept LIMIT_MARGIN_DEG inside the limits (an offset must not drive an axis
    into its limit guard), or no further out than the plan's own ``base``."""
    return min(max(x, min(base, lo + LIMIT_MARGIN_DEG)), max(base, hi - LIMIT_MARGIN_DEG))


def factory(fwhm_deg: float, source_for: Callable[[Any], Any], *, floor_db: float | None = None,
            ceiling_db: float | None = None) -> Callable[[Any, Any], StepTrack]:
    """For ``Tracker.step_track``: a StepTrack per pass job; ``source_for(job)`` gives
    the power source for that pass (the simulator's needs the satellite)."""
    def make(job: Any, tracker: Any) -> StepTrack:
        return StepTrack(job.plan, job.target.name, source_for(job), tracker.rot.geometry, fwhm_deg=fwhm_deg,
                         new_id=tracker.new_program_id, end="park" if tracker.park_after_pass else "hold",
                         floor_db=floor_db, ceiling_db=ceiling_db, prediction=orbit_prediction(job, tracker.station))
    return make


def from_config(cfg: Any, station: Any) -> Callable[[Any, Any], StepTrack]:
    """``Tracker.step_track`` from ``[pointing]``: its source (the simulator's sees the
    pass's satellite through [hardware.sim] pointing_error), beamwidth and ceiling."""
    from .procedure import make_source
    from .simsource import SkySource

    pointing = cfg.pointing

    def source_for(job: Any) -> Any:
        sky = SkySource.satellite(job.target.elements, station)
        return make_source(pointing, cfg.hardware.sim.pointing_error, sky, seed=cfg.hardware.sim.seed,
                           az_zero_deg=cfg.rotator.zero_offset_deg)
    return factory(pointing.beamwidth_deg, source_for, ceiling_db=pointing.ceiling_db)
