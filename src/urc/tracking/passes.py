"""Pass search: AOS, TCA, LOS for one satellite or a whole catalog.

(Over 600 lines on purpose: the scan, its step bound and the root refinement share one
set of grids and one proof of why no pass is missed; split, each half would need the
other to be read.)

How (vectorised over the catalog):

1. **Coarse scan.** ``SatrecArray`` propagates every satellite on one time grid, step
   ``h`` = 1200 s for near-Earth orbits (never more than a quarter period) and 600 s for
   deep-space ones (period >= 225 min), whose motion over the rotating Earth is slow but
   may loop. At each sample: the satellite's height above the station's horizon plane
   ``z = (r - s).up`` (km) and its rate ``z'`` (exact, from SGP4's velocity),
   ``f = z - range*sin(min_el)`` (>= 0 exactly when el >= min_el) and
   ``q = z'*range - z*range'`` (the sign of d(el)/dt, smooth even through the zenith).
2. **The bound that sets the step.** Sampling alone would need a 10 s step to be sure of
   catching every pass of 10 s or more (8640 samples a day per satellite). Instead: in
   the Earth-fixed frame the satellite's acceleration is at most
   ``K = 1.2*mu/r_perigee^2 + 2*w*v_max + w^2*r_apogee`` (gravity, Coriolis and
   centrifugal terms, with margins; ~0.012 km/s^2 for the ISS), and since
   ``range'' >= -|a|``, ``f'' <= K*(1 + sin(min_el))``. With ``f`` and ``f'`` known at
   both ends of a step, ``f`` lies under two parabolas; where their lower envelope stays
   below 0 the step holds no visibility at all and is dropped, however short a pass.
   (Below a negative ``min_el`` the same is done with ``z``.)
3. **Classification** of the steps left by the signs at their ends: ``f`` - to + holds
   an AOS, + to - a LOS, ``q`` + to - a culmination (solved even with both ends below:
   a short pass or a near miss). A step with both ends below and no culmination sign is
   cut in four, the bound applied again to each part, until dropped or shorter than
   ``min_pass_s`` (10 s): a pass hidden there needs two elevation extrema in one step,
   so only passes shorter than 10 s can be missed that way. Elevation extrema come about
   half an orbit apart (the closest and farthest points of the orbit from the station),
   so a step of at most a quarter period holds at most one, and the signs tell the rest.
4. **Refinement**: safeguarded Newton iteration (bisection whenever a step would leave
   the bracket) on ``f`` for AOS/LOS and on ``q`` for TCA, analytic derivatives, first
   guess from the cubic through the bracket's end values and slopes; it stops when the
   Newton step is under ``tolerance_s`` (0.05 s), which leaves an error of order
   step^2 (well under a millisecond). All brackets of a chunk iterate together: one
   ``sgp4`` call per satellite per iteration.

About 135-145 SGP4 evaluations per satellite-day in all (bench/passes_bench.py).
Elevations are geometric (no refraction) above the WGS84 horizon, as skyfield's
``EarthSatellite.find_events`` computes them; the tests (hypothesis over random stations
and orbits, LEO to Molniya and GEO) and the benchmark check both give the same passes,
and that an event only one side finds is a real crossing. Everything here trusts SGP4's
velocity to be the derivative of its position, which fails only for elements outside
SGP4's domain (e.g. e = 0.5 with a one-day period, where its resonance terms jump).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from datetime import datetime
from typing import Any, Callable, Iterable, NamedTuple, Sequence

import numpy as np
from sgp4.api import SGP4_ERRORS, SatrecArray

from . import sky
from .elements import ElementSet
from .station import Station

__all__ = ["Pass", "PassSearch", "find_passes", "search_passes"]

#: Earth's rotation rate (rad/s), for the bound only (the frame uses skyfield's GMST rate).
_W_EARTH = 7.2921159e-5
_DEG = 180.0 / math.pi
DEFAULT_STEP_S = 1200.0
#: SGP4's own near-Earth / deep-space boundary (orbital period, s).
DEEP_SPACE_PERIOD_S = 225.0 * 60.0
#: Seen from the rotating Earth a high orbit can loop (its elevation turning every few
#: minutes for an eccentric, near-synchronous one), so it gets a finer step.
DEEP_SPACE_STEP_S = 600.0
#: the coarse step is at most this fraction of the shortest period (one extremum a step).
_PERIOD_FRACTION = 4.0


class Pass(NamedTuple):
    """One pass above ``min_el``; times are POSIX UTC seconds (``aos`` etc. as datetimes).

    A named tuple: immutable and cheap to make by the thousand.

    A pass already under way when the search starts has AOS = the start and
    ``aos_clipped``; one still up at the end has LOS = the end and ``los_clipped``.
    ``culminates`` is False when the highest point is such a clipped end rather than a
    true culmination. A pass with two culminations (a high-eccentricity orbit hovering)
    reports the higher one.
    """

    norad_id: int
    name: str
    aos_unix_s: float
    tca_unix_s: float
    los_unix_s: float
    max_el_deg: float
    aos_az_deg: float
    tca_az_deg: float
    los_az_deg: float
    aos_clipped: bool = False
    los_clipped: bool = False
    culminates: bool = True

    @property
    def aos(self) -> datetime:
        return sky.utc_datetime(self.aos_unix_s)

    @property
    def tca(self) -> datetime:
        return sky.utc_datetime(self.tca_unix_s)

    @property
    def los(self) -> datetime:
        return sky.utc_datetime(self.los_unix_s)

    @property
    def duration_s(self) -> float:
        return self.los_unix_s - self.aos_unix_s

    @property
    def always_up(self) -> bool:
        """Above the mask for the whole search window (a geostationary satellite): not a
        pass with a rise and a set, one clipped at both ends."""
        return self.aos_clipped and self.los_clipped

    def to_dict(self) -> dict[str, Any]:
        return {"norad_id": self.norad_id, "name": self.name,
                "aos": self.aos.isoformat(), "tca": self.tca.isoformat(),
                "los": self.los.isoformat(), "duration_s": round(self.duration_s, 3),
                "max_el_deg": round(self.max_el_deg, 4),
                "aos_az_deg": round(self.aos_az_deg, 4), "tca_az_deg": round(self.tca_az_deg, 4),
                "los_az_deg": round(self.los_az_deg, 4), "aos_clipped": self.aos_clipped,
                "los_clipped": self.los_clipped, "culminates": self.culminates,
                "always_up": self.always_up}


@dataclass
class PassSearch:
    """The result of :func:`search_passes`."""

    passes: list[Pass]
    start: datetime
    end: datetime
    min_el_deg: float
    #: NORAD id -> why sgp4 could not propagate it over (part of) the window.
    errors: dict[int, str] = field(default_factory=dict)
    #: counters: sgp4 evaluations, step, intervals refined ...
    stats: dict[str, float] = field(default_factory=dict)


# --------------------------------------------------------------------------- kinematics


class _Engine:
    """Per-chunk constants and the (satellite, time) -> state evaluator."""

    def __init__(self, sats: Sequence[ElementSet], station: Station, t0_unix_s: float,
                 duration_s: float, min_el_deg: float, step_s: float):
        self.sats = sats
        self.satrecs = [es.satrec for es in sats]
        self.n = len(sats)
        self.t0 = t0_unix_s
        self.duration_s = duration_s
        m = max(1, int(math.ceil(duration_s / step_s - 1e-9)))
        self.grid = np.linspace(0.0, duration_s, m + 1)
        days = math.floor(t0_unix_s / sky.DAY_S)
        self.jd0 = sky.JD_UNIX_EPOCH + days
        self.fr0 = (t0_unix_s - days * sky.DAY_S) / sky.DAY_S
        # UT1-UTC on the grid; refinement interpolates (it drifts ~1 ms/day).
        self.dut1_grid = np.asarray(sky.dut1_s(t0_unix_s + self.grid), dtype=float)
        self.s = station.itrs_km
        self.east, self.north, self.up = station.enu
        self.sin_e = math.sin(math.radians(min_el_deg))
        self.mu = self.satrecs[0].mu if self.satrecs else 398600.8
        self.evaluations = 0
        self._bounds_constants(station)

    def _bounds_constants(self, station: Station) -> None:
        re_km = np.array([s.radiusearthkm for s in self.satrecs])
        mu = np.array([s.mu for s in self.satrecs])
        a_km = np.array([s.a for s in self.satrecs]) * re_km
        deep = np.array([2 * math.pi / max(s.no_kozai, 1e-9) >= 225.0 for s in self.satrecs])
        # SGP4's osculating radius strays from the mean perigee/apogee by short-period and
        # (deep space) lunisolar terms, and a low orbit decays: generous margins.
        margin_km = np.where(deep, 500.0, 50.0)
        rp = np.maximum((np.array([s.altp for s in self.satrecs]) + 1.0) * re_km - margin_km,
                        re_km * 0.9)
        ra = (np.array([s.alta for s in self.satrecs]) + 1.0) * re_km + margin_km
        a_km = np.clip(a_km, rp, ra)
        v_in = 1.05 * np.sqrt(mu * np.maximum(2.0 / rp - 1.0 / a_km, 0.0))
        self.v_max = v_in + _W_EARTH * ra
        self.k_z = 1.2 * mu / rp ** 2 + 2.0 * _W_EARTH * self.v_max + _W_EARTH ** 2 * ra
        # below a negative min_el, visibility needs z >= range * sin(e) >= this
        self.z_thresh = self.sin_e * (ra + float(np.linalg.norm(self.s)))

    # -- states ------------------------------------------------------------------------

    def _theta(self, t_rel: np.ndarray):
        dut1 = np.interp(t_rel, self.grid, self.dut1_grid)
        from skyfield.sgp4lib import theta_GMST1982

        theta, theta_dot_per_day = theta_GMST1982(self.jd0, self.fr0 + (t_rel + dut1) / sky.DAY_S)
        return theta, theta_dot_per_day / sky.DAY_S

    def _state(self, r, v, theta, w, full: bool) -> dict[str, np.ndarray]:
        c, s = np.cos(theta), np.sin(theta)
        x = c * r[..., 0] + s * r[..., 1]
        y = -s * r[..., 0] + c * r[..., 1]
        zc = r[..., 2]
        vx = c * v[..., 0] + s * v[..., 1] + w * y
        vy = -s * v[..., 0] + c * v[..., 1] - w * x
        vz = v[..., 2]
        dx, dy, dz = x - self.s[0], y - self.s[1], zc - self.s[2]
        up = self.up
        z = dx * up[0] + dy * up[1] + dz * up[2]
        zd = vx * up[0] + vy * up[1] + vz * up[2]
        rho = np.sqrt(dx * dx + dy * dy + dz * dz)
        rhod = (dx * vx + dy * vy + dz * vz) / rho
        # two-body acceleration in the rotating frame (Coriolis + centrifugal): only the
        # slope of q uses it (Newton and the first guess), so J2 and drag can be left out
        r3 = (x * x + y * y + zc * zc) ** 1.5
        acc_x = -self.mu * x / r3 + 2 * w * vy + w * w * x
        acc_y = -self.mu * y / r3 - 2 * w * vx + w * w * y
        acc_z = -self.mu * zc / r3
        zdd = acc_x * up[0] + acc_y * up[1] + acc_z * up[2]
        v2 = vx * vx + vy * vy + vz * vz
        rhodd = (v2 + dx * acc_x + dy * acc_y + dz * acc_z - rhod * rhod) / rho
        st = {"z": z, "zd": zd, "rho": rho, "f": z - self.sin_e * rho,
              "fd": zd - self.sin_e * rhod, "q": zd * rho - z * rhod,
              "qd": zdd * rho - z * rhodd}
        if full:
            e = dx * self.east[0] + dy * self.east[1] + dz * self.east[2]
            n = dx * self.north[0] + dy * self.north[1] + dz * self.north[2]
            ed = vx * self.east[0] + vy * self.east[1] + vz * self.east[2]
            nd = vx * self.north[0] + vy * self.north[1] + vz * self.north[2]
            hor2 = e * e + n * n
            hor = np.sqrt(hor2)
            st["el_deg"] = np.arctan2(z, hor) * _DEG
            st["az_deg"] = np.mod(np.arctan2(e, n) * _DEG, 360.0)
            with np.errstate(divide="ignore", invalid="ignore"):
                st["el_rate_deg_per_s"] = st["q"] / (rho * hor) * _DEG
                st["az_rate_deg_per_s"] = (ed * n - nd * e) / hor2 * _DEG
        return st

    def grid_states(self):
        jd = np.full(self.grid.shape, self.jd0)
        fr = self.fr0 + self.grid / sky.DAY_S
        err, r, v = SatrecArray(self.satrecs).sgp4(jd, fr)
        self.evaluations += err.size
        theta, w = self._theta(self.grid)
        return err, self._state(r, v, theta, w, full=False)

    def at(self, k: np.ndarray, t_rel: np.ndarray) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        """Full states for (satellite index, time) pairs: one sgp4 call per satellite."""
        n = len(k)
        r = np.empty((n, 3))
        v = np.empty((n, 3))
        err = np.zeros(n, dtype=np.uint8)
        if n:
            # callers mostly pass k sorted already; sorting 25k keys costs more than sgp4
            order = None if np.all(k[1:] >= k[:-1]) else np.argsort(k, kind="stable")
            ks = k if order is None else k[order]
            ts = t_rel if order is None else t_rel[order]
            cuts = np.flatnonzero(np.diff(ks)) + 1
            starts = np.concatenate(([0], cuts)).tolist()
            ends = np.concatenate((cuts, [n])).tolist()
            fr = self.fr0 + ts / sky.DAY_S
            jd = np.full(n, self.jd0)
            rs, vs, es = (r, v, err) if order is None else \
                (np.empty((n, 3)), np.empty((n, 3)), np.empty(n, dtype=np.uint8))
            sats = self.satrecs
            for a, b, kk in zip(starts, ends, ks[starts].tolist()):
                _sgp4_into(sats[kk], jd[a:b], fr[a:b], es[a:b], rs[a:b], vs[a:b])
            if order is not None:
                r[order], v[order], err[order] = rs, vs, es
            self.evaluations += n
        theta, w = self._theta(t_rel)
        return err, self._state(r, v, theta, w, full=True)


def _sgp4_into(sat, jd, fr, e, r, v) -> None:
    """``sat.sgp4_array`` writing into slices of preallocated arrays.

    The refinement makes thousands of small calls; the public wrapper's allocations cost
    a third of each, so use the buffer-filling method it wraps when it is there.
    """
    fill = getattr(sat, "_sgp4", None)
    if fill is not None:
        fill(jd, fr, e, r, v)
    else:  # pure-Python sgp4
        e[:], r[:], v[:] = sat.sgp4_array(jd, fr)


def _z_bound(za, zb, dza, dzb, h, k):
    """Upper bound of z on [0, h] given ends, end slopes and |z''| <= k."""
    # p1(t) = za + dza t + k t^2/2 and p2(t) = zb - dzb (h - t) + k (h - t)^2/2 both lie above
    # z; max over [0, h] of min(p1, p2) is at an end or where they cross (p1 - p2 is linear).
    a_ = za - zb + dzb * h - 0.5 * k * h * h
    b_ = dza - dzb + k * h
    with np.errstate(divide="ignore", invalid="ignore"):
        tc = np.where(b_ > 0, -a_ / b_, 0.5 * h)
    tc = np.clip(np.nan_to_num(tc, nan=0.5 * h), 0.0, h)
    p1 = za + dza * tc + 0.5 * k * tc * tc
    p2 = zb - dzb * (h - tc) + 0.5 * k * (h - tc) ** 2
    at_a = np.minimum(za, zb - dzb * h + 0.5 * k * h * h)
    at_b = np.minimum(za + dza * h + 0.5 * k * h * h, zb)
    return np.maximum(np.maximum(at_a, at_b), np.minimum(p1, p2))


# --------------------------------------------------------------------------- the search


class _Intervals:
    """A flat set of (satellite, [ta, tb]) steps with the states at both ends."""

    KEYS = ("z", "zd", "f", "fd", "q", "qd", "rho")

    def __init__(self, k, ta, tb, a: dict, b: dict):
        self.k, self.ta, self.tb = k, ta, tb
        self.a = {key: a[key] for key in self.KEYS}
        self.b = {key: b[key] for key in self.KEYS}

    def take(self, mask) -> _Intervals:
        return _Intervals(self.k[mask], self.ta[mask], self.tb[mask],
                          {x: y[mask] for x, y in self.a.items()},
                          {x: y[mask] for x, y in self.b.items()})

    def __len__(self) -> int:
        return len(self.k)


def _cat(parts: list[_Intervals]) -> _Intervals:
    keys = _Intervals.KEYS
    return _Intervals(np.concatenate([p.k for p in parts]),
                      np.concatenate([p.ta for p in parts]),
                      np.concatenate([p.tb for p in parts]),
                      {x: np.concatenate([p.a[x] for p in parts]) for x in keys},
                      {x: np.concatenate([p.b[x] for p in parts]) for x in keys})


def _could_be_visible(eng: _Engine, iv: _Intervals) -> np.ndarray:
    """False where the bound proves the step holds no elevation >= min_el."""
    h = iv.tb - iv.ta
    kz = eng.k_z[iv.k]
    if eng.sin_e >= 0:
        # f = z - sin(e) range: z'' <= |a| and range'' >= -|a| (the rest of range'' is a
        # square), so f'' <= K (1 + sin e) and f must reach 0 somewhere to be visible
        return _z_bound(iv.a["f"], iv.b["f"], iv.a["fd"], iv.b["fd"], h,
                        kz * (1.0 + eng.sin_e)) >= 0.0
    return _z_bound(iv.a["z"], iv.b["z"], iv.a["zd"], iv.b["zd"], h, kz) >= eng.z_thresh[iv.k]


def _classify(eng: _Engine, iv: _Intervals, min_pass_s: float):
    """Split steps into AOS, LOS, TCA brackets and steps to bisect."""
    fa, fb = iv.a["f"], iv.b["f"]
    up_a, up_b = fa >= 0, fb >= 0  # False for NaN (sgp4 failed): such steps are dropped
    down = (fa < 0) & (fb < 0)
    peak = (iv.a["q"] > 0) & (iv.b["q"] <= 0)
    aos = (fa < 0) & up_b
    los = up_a & (fb < 0)
    maybe = down & _could_be_visible(eng, iv)
    # a culmination with both ends below that the bound cannot drop is solved at once:
    # cheaper than bisecting it first, for near misses and short passes alike
    tca_up = peak & ~down & np.isfinite(fa) & np.isfinite(fb)
    tca_down = peak & maybe
    split = maybe & ~peak & (iv.tb - iv.ta > min_pass_s)
    return aos, los, tca_up, tca_down, split


def _hermite_root(a, b, ga, gb, da, db):
    """Root in [a, b] of the cubic through the end values and slopes: the first guess.

    A few Newton steps on the cubic itself (no sgp4), kept inside the bracket; falls back
    to regula falsi where the cubic misbehaves.
    """
    h = b - a
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.clip(ga / (ga - gb), 0.0, 1.0)
        s = np.where(np.isfinite(s), s, 0.5)
        s_rf = s
        ma, mb = da * h, db * h
        for _ in range(4):
            s2, s3 = s * s, s * s * s
            p = (2 * s3 - 3 * s2 + 1) * ga + (s3 - 2 * s2 + s) * ma + (-2 * s3 + 3 * s2) * gb \
                + (s3 - s2) * mb
            dp = (6 * s2 - 6 * s) * ga + (3 * s2 - 4 * s + 1) * ma + (-6 * s2 + 6 * s) * gb \
                + (3 * s2 - 2 * s) * mb
            s = np.clip(s - p / dp, 0.0, 1.0)
        s = np.where(np.isfinite(s) & np.isfinite(da) & np.isfinite(db), s, s_rf)
    return a + s * h


def _solve(eng: _Engine, k, a, b, ga, gb, da, db, is_q, tol_s: float, max_iter: int = 60):
    """Roots of f (AOS/LOS) or q (TCA, where ``is_q``) in brackets [a, b] where they
    change sign: safeguarded Newton from a cubic-Hermite first guess, all brackets of the
    chunk iterated together.

    Returns the root times (NaN where sgp4 failed) and elevation, azimuth (carried to
    the root with their rates) and f at the last evaluation.
    """
    n = len(k)
    a, b, ga = a.copy(), b.copy(), ga.copy()
    x = _hermite_root(a, b, ga, gb, da, db)
    x = np.clip(x, a + 0.25 * tol_s, b - 0.25 * tol_s)
    x = np.where(b - a < tol_s, 0.5 * (a + b), x)
    out_t = np.full(n, np.nan)
    out = {key: np.full(n, np.nan) for key in ("el_deg", "az_deg", "f")}
    act = np.arange(n)
    for _ in range(max_iter):
        if not len(act):
            break
        err, st = eng.at(k[act], x[act])
        q_ = is_q[act]
        g = np.where(q_, st["q"], st["f"])
        gd = np.where(q_, st["qd"], st["fd"])
        xa, lo, hi = x[act], a[act], b[act]
        same = np.sign(g) == np.sign(ga[act])
        lo = np.where(same, xa, lo)
        hi = np.where(same, hi, xa)
        a[act], b[act] = lo, hi
        ga[act] = np.where(same, g, ga[act])
        with np.errstate(divide="ignore", invalid="ignore"):
            xn = xa - g / gd
        bad = ~np.isfinite(xn) | (xn <= lo) | (xn >= hi)
        xn = np.where(bad, 0.5 * (lo + hi), xn)
        # a Newton step shorter than tol_s leaves an error of order step^2 (microseconds):
        # take the stepped time and carry the azimuth along with its rate
        done = (~bad & (np.abs(xn - xa) < tol_s)) | (hi - lo < tol_s) | (g == 0) | (err != 0)
        idx = act[done]
        dt = np.where(err[done] != 0, np.nan, xn[done] - xa[done])  # sgp4 failed: no root
        out_t[idx] = xa[done] + dt
        out["f"][idx] = st["f"][done]
        out["el_deg"][idx] = st["el_deg"][done] + st["el_rate_deg_per_s"][done] * dt
        out["az_deg"][idx] = np.mod(st["az_deg"][done] + st["az_rate_deg_per_s"][done] * dt, 360.0)
        x[act] = xn
        act = act[~done]
    if len(act):  # not converged in max_iter (never seen): the bracket's middle
        out_t[act] = 0.5 * (a[act] + b[act])
    return out_t, out


def search_passes(sats: ElementSet | Iterable[ElementSet], station: Station, start: Any, *,
                  duration_s: float = 86400.0, min_el_deg: float = 0.0,
                  step_s: float | None = None, min_pass_s: float = 10.0,
                  tolerance_s: float = 0.05, chunk_size: int = 500,
                  progress: Callable[[int, int], None] | None = None) -> PassSearch:
    """Every pass of ``sats`` above ``min_el_deg`` from ``start`` for ``duration_s``.

    ``start`` is an aware datetime, POSIX seconds or a skyfield Time. ``progress(done,
    total)`` is called after each chunk of satellites.
    """
    if isinstance(sats, ElementSet):
        sats = [sats]
    sats = list(sats)
    if not duration_s > 0:
        raise ValueError(f"duration_s must be > 0, found {duration_s!r}")
    if not -90.0 < min_el_deg < 90.0:
        raise ValueError(f"min_el_deg must be in -90..90, found {min_el_deg!r}")
    t0 = float(sky.unix_s(start))
    result = PassSearch([], sky.utc_datetime(t0), sky.utc_datetime(t0 + duration_s),
                        float(min_el_deg))
    # sets sgp4 cannot propagate even at their epoch (decayed) give no passes, only the reason
    for es in sats:
        if es.sgp4_error:
            result.errors[es.norad_id] = f"{es.sgp4_error} at its epoch {es.epoch:%Y-%m-%d}: no passes"
    sats = [es for es in sats if not es.sgp4_error]
    stats: dict[str, float] = {"satellites": len(sats), "evaluations": 0, "bisected": 0, "roots": 0}
    # Near-Earth and deep-space orbits in separate chunks: each gets its own step.
    near = [es for es in sats if es.period_s < DEEP_SPACE_PERIOD_S]
    deep = [es for es in sats if es.period_s >= DEEP_SPACE_PERIOD_S]
    done = 0
    for group, default_step_s in ((near, DEFAULT_STEP_S), (deep, DEEP_SPACE_STEP_S)):
        step = float(step_s) if step_s else default_step_s
        for i in range(0, len(group), max(1, chunk_size)):
            chunk = group[i:i + chunk_size]
            p_min_s = min(es.period_s for es in chunk)
            eng = _Engine(chunk, station, t0, duration_s, min_el_deg,
                          min(step, p_min_s / _PERIOD_FRACTION))
            key = "step_s" if group is near else "deep_space_step_s"
            stats[key] = float(eng.grid[1] - eng.grid[0])
            _search_chunk(eng, result, stats, min_pass_s, tolerance_s)
            stats["evaluations"] += eng.evaluations
            done += len(chunk)
            if progress is not None:
                progress(done, len(sats))
    result.passes.sort(key=lambda p: (p.aos_unix_s, p.norad_id))
    result.stats = stats
    return result


def find_passes(sats: ElementSet | Iterable[ElementSet], station: Station, start: Any, *,
                duration_s: float = 86400.0, min_el_deg: float = 0.0, **kw) -> list[Pass]:
    """The passes of :func:`search_passes`, sorted by AOS."""
    return search_passes(sats, station, start, duration_s=duration_s, min_el_deg=min_el_deg,
                         **kw).passes


_SPLIT = 4  # parts a step is cut into per round: fewer rounds of per-satellite calls


def _search_chunk(eng: _Engine, result: PassSearch, stats: dict, min_pass_s: float,
                  tol_s: float) -> None:
    err, g = eng.grid_states()
    n, m1 = err.shape
    for j in np.flatnonzero(err.any(axis=1)):
        code = int(err[j][err[j] != 0][0])
        result.errors[eng.sats[int(j)].norad_id] = SGP4_ERRORS.get(code, f"error {code}")
    bad = err != 0
    for key in g:
        g[key][bad] = np.nan
    iv = _Intervals(np.repeat(np.arange(n), m1 - 1), np.tile(eng.grid[:-1], n),
                    np.tile(eng.grid[1:], n), {x: g[x][:, :-1].ravel() for x in _Intervals.KEYS},
                    {x: g[x][:, 1:].ravel() for x in _Intervals.KEYS})
    found: list[tuple[_Intervals, np.ndarray]] = []  # brackets and their kind (0 AOS 1 TCA 2 LOS)
    short: list[_Intervals] = []  # TCA brackets with both ends below: short passes or misses
    while len(iv):
        aos, los, tca_up, tca_down, split = _classify(eng, iv, min_pass_s)
        for mask, kind in ((aos, 0), (los, 2), (tca_up, 1)):
            if mask.any():
                found.append((iv.take(mask), np.full(int(mask.sum()), kind)))
        if tca_down.any():
            short.append(iv.take(tca_down))
        if not split.any():
            break
        sp = iv.take(split)
        stats["bisected"] += len(sp)
        frac = np.arange(1, _SPLIT) / _SPLIT
        tm = sp.ta[:, None] + (sp.tb - sp.ta)[:, None] * frac  # (n, _SPLIT - 1)
        e_mid, st = eng.at(np.repeat(sp.k, _SPLIT - 1), tm.ravel())
        mid = {x: np.where(e_mid != 0, np.nan, st[x]).reshape(tm.shape) for x in _Intervals.KEYS}
        edges_t = np.column_stack((sp.ta, tm, sp.tb))
        edges = {x: np.column_stack((sp.a[x], mid[x], sp.b[x])) for x in _Intervals.KEYS}
        iv = _Intervals(np.repeat(sp.k, _SPLIT), edges_t[:, :-1].ravel(), edges_t[:, 1:].ravel(),
                        {x: edges[x][:, :-1].ravel() for x in _Intervals.KEYS},
                        {x: edges[x][:, 1:].ravel() for x in _Intervals.KEYS})

    # one batch of root finding for every AOS, LOS and TCA of the chunk
    parts = [b for b, _ in found] + short
    events = []  # (k, t, kind, el, az)
    if parts:
        br = _cat(parts)
        kinds = np.concatenate([kd for _, kd in found] +
                               [np.full(len(s), 3) for s in short])  # 3: TCA of a short one
        by_sat = np.argsort(br.k, kind="stable")  # so every evaluation batch is sorted
        br, kinds = br.take(by_sat), kinds[by_sat]
        is_q = (kinds == 1) | (kinds == 3)
        pick = {key: (np.where(is_q, br.a["q" + key], br.a["f" + key]),
                      np.where(is_q, br.b["q" + key], br.b["f" + key])) for key in ("", "d")}
        t, st = _solve(eng, br.k, br.ta, br.tb, *pick[""], *pick["d"], is_q, tol_s)
        stats["roots"] += len(br)
        keep = (kinds != 3) | (st["f"] >= 0)  # short TCA below min_el: a near miss
        as_event = np.where(kinds == 3, 1, kinds)
        events.append((br.k[keep], t[keep], as_event[keep], st["el_deg"][keep],
                       st["az_deg"][keep]))
        up = (kinds == 3) & (st["f"] >= 0)
        if up.any():
            # a pass inside one step: its AOS and LOS lie either side of the TCA
            bu = br.take(up)
            tt = t[up]
            _, sta = eng.at(bu.k, tt)
            ok = sta["f"] >= 0  # (a peak grazing min_el within rounding: not a pass)
            bu, tt, sta = bu.take(ok), tt[ok], {x: y[ok] for x, y in sta.items()}
            sub = _cat([_Intervals(bu.k, bu.ta, tt, bu.a, sta),
                        _Intervals(bu.k, tt, bu.tb, sta, bu.b)])
            kinds2 = np.concatenate((np.zeros(len(bu), dtype=int), np.full(len(bu), 2)))
            by_sat = np.argsort(sub.k, kind="stable")
            sub, kinds2 = sub.take(by_sat), kinds2[by_sat]
            ts_, sts = _solve(eng, sub.k, sub.ta, sub.tb, sub.a["f"], sub.b["f"], sub.a["fd"],
                              sub.b["fd"], np.zeros(len(sub), dtype=bool), tol_s)
            stats["roots"] += len(sub)
            events.append((sub.k, ts_, kinds2, sts["el_deg"], sts["az_deg"]))
    _assemble(eng, g, events, result)


def _assemble(eng: _Engine, g: dict, events: list, result: PassSearch) -> None:
    """Walk each satellite's events in time order into passes."""
    n = eng.n
    end = float(eng.grid[-1])
    up0 = np.nan_to_num(g["f"][:, 0], nan=-1.0) >= 0
    up1 = np.nan_to_num(g["f"][:, -1], nan=-1.0) >= 0
    edge_k = np.concatenate((np.flatnonzero(up0), np.flatnonzero(up1)))
    edge_t = np.concatenate((np.zeros(int(up0.sum())), np.full(int(up1.sum()), end)))
    edge: dict[tuple[int, float], tuple[float, float]] = {}
    if len(edge_k):
        _, st = eng.at(edge_k, edge_t)
        for k, t, el, az in zip(edge_k.tolist(), edge_t.tolist(), st["el_deg"].tolist(),
                                st["az_deg"].tolist()):
            edge[(k, t)] = (el, az)
    if events:
        cols = [np.concatenate([e[i] for e in events]) for i in range(5)]
        order = np.lexsort((cols[2], cols[1], cols[0]))
        ks, ts, kinds, els, azs = (c[order] for c in cols)
    else:
        ks = np.zeros(0, dtype=int)
        ts = kinds = els = azs = np.zeros(0)
    cuts = np.searchsorted(ks, np.arange(n + 1))
    ts_l, kinds_l, els_l, azs_l = ts.tolist(), kinds.tolist(), els.tolist(), azs.tolist()
    t0 = eng.t0
    min_el_deg = math.degrees(math.asin(eng.sin_e))
    for k in np.flatnonzero((np.diff(cuts) > 0) | up0).tolist():
        es = eng.sats[k]
        cur: list[Any] | None = None  # [aos t, aos az, aos el, clipped, tca (t, az, el) or None]
        if up0[k]:
            el0, az0 = edge[(k, 0.0)]
            cur = [0.0, az0, el0, True, None]
        for i in range(int(cuts[k]), int(cuts[k + 1])):
            kind, t = kinds_l[i], ts_l[i]
            if t != t:  # NaN: sgp4 failed there
                continue
            if kind == 0:
                if cur is None:
                    cur = [t, azs_l[i], min_el_deg, False, None]
            elif kind == 1:
                if cur is not None and (cur[4] is None or els_l[i] > cur[4][2]):
                    cur[4] = (t, azs_l[i], els_l[i])
            elif cur is not None:
                result.passes.append(_make_pass(es, t0, cur, (t, azs_l[i], min_el_deg), False))
                cur = None
        if cur is not None and up1[k]:
            el1, az1 = edge[(k, end)]
            result.passes.append(_make_pass(es, t0, cur, (end, az1, el1), True))


def _make_pass(es: ElementSet, t0: float, cur: list, los: tuple, los_clip: bool) -> Pass:
    aos_t, aos_az, aos_el, aos_clip, tca = cur
    # the highest point: the best culmination, unless a clipped end is higher still
    top = tca
    if top is None or aos_el > top[2]:
        top = (aos_t, aos_az, aos_el)
    if los[2] > top[2]:
        top = los
    return Pass(es.norad_id, es.label, t0 + aos_t, t0 + top[0], t0 + los[0], top[2], aos_az,
                top[1], los[1], aos_clip, los_clip, top is tca)
