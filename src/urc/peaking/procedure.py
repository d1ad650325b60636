"""A calibration scan flown from the I/O process (issue 38): a cross scan around the Sun,
the Moon or a beacon, the power read at each point, the beam fitted, and the az/el
offset found (or the reason it was refused).

Like the web hub's other calibration procedures (urc.procedures.calibration) it is a state
machine: :meth:`ScanCalibration.poll` is called with each new status, issues gotos
through the rotator's public commands and never waits. A source that blocks on I/O
(rigctld, a TCP feed, a file) is read on a worker thread, one read at a time; the
simulator's source is computed from the status' ``sim_truth`` at once.

Offsets: a sample's offset is where the controller reported the antenna (the frame the
``[offsets]`` live in) minus the target; the fitted peak at (dx, dy) means the antenna
reads dx/cos(el), dy more than the target when the beam is on it, so the offsets that
put the report on the beam are the present ones minus that.
"""

from __future__ import annotations

import math
import os
import time
from concurrent.futures import Future, ThreadPoolExecutor
from typing import Any, Callable

from ..errors import CommandRejected, UrcError
from ..pointing.fit import ScanRefused, fit_cross
from ..procedures.hub import HubProcedure
from ..pointing.model import PointingModel
from ..pointing.scan import ScanPlan, cross_scan, offset_pose, pose_offset
from .simsource import SimulatedPower, SkySource, true_beam
from ..pointing.sources import Sample, SignalRefused, judge

TARGETS = ("sun", "moon", "beacon")


class ScanSetupError(UrcError):
    """The scan cannot start (no station for the Sun, a source not configured...)."""


# ----------------------------------------------------------------------- sources
class StatusPower:
    """The simulator's source read from a status: the true axes (``sim_truth``) through
    the configured pointing error model to the beam, then the source seen by the beam.
    ``az_zero_deg``: the compass bearing of the azimuth axis' zero ([rotator] zero: 180
    on a south-zero rotator, whose axis angles count from south)."""

    name = "simulated power"

    def __init__(self, sim: SimulatedPower, model: PointingModel | None, az_zero_deg: float = 0.0):
        self.sim, self.model, self.az_zero_deg = sim, model, float(az_zero_deg)

    def read_at(self, status: Any, unix_s: float) -> Sample:
        truth = status.sim_truth
        if not truth or "az" not in truth:
            raise SignalRefused("missing", 'no simulator truth in the status: source = "sim" needs the simulator')
        el_m = float(truth["el"]["deg"]) if truth.get("el") else 0.0
        az, el = true_beam(self.model, float(truth["az"]["deg"]), el_m, self.az_zero_deg)
        value = float(self.sim.measure(unix_s, az, el)[0])
        return judge(unix_s, value, "dB", now_s=unix_s, max_age_s=None, ceiling=self.sim.ceiling_db, what=self.name)


class RtlPowerFile:
    """rtl_power's CSV file as it grows: each read takes the lines appended since the last."""

    def __init__(self, path: str, *, ceiling_db: float | None = None):
        from ..pointing.rtl_power import RtlPowerLines

        self.path, self.lines, self._pos = path, RtlPowerLines(ceiling_db=ceiling_db), 0
        self.name = f"rtl_power {path}"

    def read(self) -> Sample:
        try:
            with open(self.path, "rb") as f:
                if os.fstat(f.fileno()).st_size < self._pos:
                    self._pos = 0  # rtl_power started again: a new file
                f.seek(self._pos)
                data = f.read(1 << 20)
                self._pos += len(data)
        except OSError as exc:
            raise SignalRefused("missing", f"{self.name}: {exc}") from None
        self.lines.feed(data.decode("utf-8", "replace"))
        return self.lines.read()

    def close(self) -> None:
        pass


def _host_port(address: str | None, what: str) -> tuple[str, int]:
    host, _, port = (address or "").rpartition(":")
    if not host or not port.isdigit():
        raise ScanSetupError(f"[pointing] source = {what!r} needs address = \"host:port\", found {address!r}")
    return host.strip("[]"), int(port)


def make_source(pointing: Any, sim_error: dict[str, float] | None, sky: SkySource, seed: int = 1, *,
                az_zero_deg: float) -> Any:
    """The power source ``[pointing]`` names (a :class:`StatusPower` for "sim", its
    axes' azimuth zero at ``az_zero_deg``: ``[rotator]``'s zero_offset_deg)."""
    kind = pointing.source
    if kind == "sim":
        sim = SimulatedPower(sky, fwhm_deg=pointing.beamwidth_deg, snr_db=pointing.snr_db,
                             ceiling_db=pointing.ceiling_db, seed=seed)
        return StatusPower(sim, PointingModel.from_dict(sim_error) if sim_error else None, az_zero_deg)
    if kind == "rigctld":
        from ..pointing.rigctld import RigctldStrength
        return RigctldStrength(*_host_port(pointing.address, kind), ceiling_db=pointing.ceiling_db)
    if kind == "tcp":
        from ..pointing.line_feed import LineFeed
        return LineFeed(*_host_port(pointing.address, kind), ceiling=pointing.ceiling_db)
    if kind == "rtl_power":
        if not pointing.file:
            raise ScanSetupError('[pointing] source = "rtl_power" needs file = "the CSV rtl_power writes"')
        return RtlPowerFile(pointing.file, ceiling_db=pointing.ceiling_db)
    raise ScanSetupError(f"[pointing] source {kind!r} unknown")


def make_sky(target: str, station: Any = None, az_deg: float | None = None, el_deg: float | None = None) -> SkySource:
    """The Sun or the Moon (``station``: a [station] section, configured) or a beacon."""
    if target == "beacon":
        if az_deg is None or el_deg is None:
            raise ScanSetupError("a beacon scan needs the beacon's az_deg and el_deg")
        return SkySource.beacon(az_deg, el_deg)
    if target not in ("sun", "moon"):
        raise ScanSetupError(f"target must be one of {', '.join(TARGETS)}, found {target!r}")
    if station is None or not station.configured:
        raise ScanSetupError(f"a {target} scan needs the station's position: set [station] lat_deg and lon_deg")
    from ..tracking.station import Station

    st = Station(station.lat_deg, station.lon_deg, station.alt_m, station.name)
    return SkySource.sun(st) if target == "sun" else SkySource.moon(st)


# ----------------------------------------------------------------------- the scan
class ScanCalibration(HubProcedure):
    """Fly a cross scan around ``sky`` reading ``source``; fit; report the offset."""

    kind = "scan"
    FAILS_ON = (CommandRejected, ScanSetupError)
    #: give up on one point after this long
    MOVE_TIMEOUT_S = 180.0
    #: still this long after a goto before the antenna counts as there (the command's
    #: motion may not have shown in the status yet)
    START_S = 0.3
    #: the lowest a scan point may go (the ground and what stands on it)
    MIN_EL_DEG = 0.0

    def __init__(self, rotator: Any, sky: SkySource, source: Any, *, fwhm_deg: float, dwell_s: float = 2.0,
                 samples_per_point: int = 3, plan: ScanPlan | None = None, target: str = "",
                 unix_at: Callable[[Any], float] | None = None,
                 record: Callable[[dict[str, Any]], Any] | None = None):
        """``record``: called with a finished scan's stored form (:meth:`stored_scan`),
        e.g. urc.pointing.store.append_scan into the state directory."""
        super().__init__(rotator, "az")   # (the hub's procedure shape: kind, axis, state...)
        self.sky, self.source = sky, source
        self.record = record
        #: the pointing model in force when the scan started (the status reports through it)
        self._pointing: tuple[float, ...] = ()
        self.fwhm_deg, self.samples_per_point = float(fwhm_deg), int(samples_per_point)
        self.plan = plan or cross_scan(fwhm_deg, dwell_s=dwell_s)
        self.target = target or sky.name
        self.unix_at = unix_at or (lambda _status: time.time())
        self.samples: list[dict[str, Any]] = []
        self.refused: dict[str, int] = {}
        self._phase, self._since_s, self._i, self._taken = "start", 0.0, 0, 0
        self._cmd: tuple[float, float] = (0.0, 0.0)
        self._offsets: dict[str, float] = {}
        self._pending: tuple[Future, dict[str, Any]] | None = None
        self._pool: ThreadPoolExecutor | None = None
        if not hasattr(source, "read_at"):  # blocking I/O: a thread of its own
            self._pool = ThreadPoolExecutor(1, thread_name_prefix="urc-power")

    # -------------------------------------------------------------- the hub's interface
    def _fail(self, reason: str) -> None:
        self._end("failed", reason)

    def _cancelled(self) -> None:
        self._end("cancelled", "")
        self.step = "cancelled: antenna stopped"

    def _summary(self) -> dict[str, Any]:
        """(in every live frame: the samples are left out)"""
        return {k: v for k, v in self.result.items() if k != "samples"}

    def report(self) -> dict[str, Any]:
        """Everything: the progress, the result and each sample (offset, power) to plot."""
        d = self.as_dict()
        d["target"] = self.target
        d["samples"] = list(self.samples)
        d["refused_samples"] = dict(self.refused)
        d["plan"] = {"kind": self.plan.kind, "beamwidth_deg": self.fwhm_deg,
                     "half_width_deg": self.plan.half_width_deg, "points": len(self.plan.points)}
        return d

    # -------------------------------------------------------------- the machine
    def _poll(self, status: Any) -> None:
        if status.faults:
            raise ScanSetupError("fault: " + status.faults[0].reason)
        if self._phase == "start":
            if status.el_deg is None:
                raise ScanSetupError("a scan needs an elevation axis")
            if getattr(status, "procedures", None):
                raise ScanSetupError("the position is unknown (a reference search runs)")
            if hasattr(self.source, "read_at") and not status.sim_truth:
                raise ScanSetupError('[pointing] source = "sim" needs the simulator backend')
            self._offsets = dict(status.offsets)
            self._pointing = tuple(getattr(getattr(self.rotator, "geometry", None), "pointing_deg", ()) or ())
            self._move(status)
        elif self._phase == "moving":
            if status.t_s - self._since_s > self.MOVE_TIMEOUT_S:
                raise ScanSetupError(f"scan point {self._i + 1} not reached in {self.MOVE_TIMEOUT_S:g} s")
            if status.t_s - self._since_s >= self.START_S and self._still(status):
                self._phase, self._since_s, self._taken = "dwell", status.t_s, 0
        elif self._phase == "dwell":
            self._dwell(status)

    def _move(self, status: Any) -> None:
        p = self.plan.points[self._i]
        taz, tel = self.sky.position(self.unix_at(status))
        az, el = offset_pose(taz, tel, p.dx_deg, p.dy_deg)
        if el < self.MIN_EL_DEG:
            raise ScanSetupError(f"{self.target} at el {tel:.1f} deg: the scan would go below the horizon "
                                 f"(point {self._i + 1} at el {el:.1f})")
        self.step = f"point {self._i + 1} of {len(self.plan.points)} ({p.leg} leg, {p.dx_deg:+.2f}, {p.dy_deg:+.2f} deg)"
        self.rotator.goto(az, el)
        self._cmd = (az, el)
        self._phase, self._since_s = "moving", status.t_s

    def _dwell(self, status: Any) -> None:
        n = self.samples_per_point
        if self._pending is not None:
            fut, pose = self._pending
            if not fut.done():
                return
            self._pending = None
            try:
                self._take(fut.result(), pose)
            except SignalRefused as exc:
                self._refuse(exc)
            except Exception as exc:  # noqa: BLE001 (a source's own bug: counted as bad, not fitted)
                self._refuse(SignalRefused("bad", f"{type(exc).__name__}: {exc}"))
        elif self._taken < n and status.t_s - self._since_s >= (self._taken + 1) * self.plan.dwell_s / n:
            u = self.unix_at(status)
            pose = {"t_unix_s": u, "az_deg": status.az_deg, "el_deg": status.el_deg}
            if self._pool is None:
                try:
                    self._take(self.source.read_at(status, u), pose)
                except SignalRefused as exc:
                    self._refuse(exc)
            else:
                self._pending = (self._pool.submit(self.source.read), pose)
                return
        if self._taken >= n and self._pending is None:
            self._i += 1
            self.progress = self._i / (len(self.plan.points) + 1)
            if self._i < len(self.plan.points):
                self._move(status)
            else:
                self._finish()

    def _take(self, sample: Sample, pose: dict[str, Any]) -> None:
        self._taken += 1
        taz, tel = self.sky.position(pose["t_unix_s"])
        dx, dy = pose_offset(pose["az_deg"], pose["el_deg"], taz, tel)
        self.samples.append({"leg": self.plan.points[self._i].leg, "dx_deg": float(dx), "dy_deg": float(dy),
                             "value": sample.value, "unit": sample.unit, "t_unix_s": pose["t_unix_s"],
                             "target_el_deg": float(tel)})

    def _refuse(self, exc: SignalRefused) -> None:
        self._taken += 1
        self.refused[exc.reason] = self.refused.get(exc.reason, 0) + 1

    def _finish(self) -> None:
        s = self.samples
        base = {"target": self.target, "samples_used": len(s), "refused_samples": dict(self.refused),
                "beamwidth_deg": self.fwhm_deg, "samples": s}
        try:
            if not s:
                raise ScanRefused("few", "the source gave no usable sample: " +
                                  (", ".join(f"{k} {v}" for k, v in self.refused.items()) or "none read"))
            units = {x["unit"] for x in s}
            if len(units) > 1:
                raise ScanRefused("few", f"the source changed its unit during the scan: {sorted(units)}")
            fit = fit_cross([x["dx_deg"] for x in s], [x["dy_deg"] for x in s], [x["value"] for x in s],
                            s[0]["unit"], [x["leg"] for x in s], fwhm_deg=self.fwhm_deg,
                            half_width_deg=self.plan.half_width_deg,
                            saturated=self.refused.get("saturated", 0))
        except ScanRefused as exc:
            self.result = {**base, "refused": exc.reason}
            self._end("failed", f"refused ({exc.reason}): {exc}")
            return
        el = sum(x["target_el_deg"] for x in s) / len(s)
        sec = 1.0 / max(math.cos(math.radians(el)), 1e-3)
        daz, de = fit.dx_deg * sec, fit.dy_deg
        suggested = {"az_deg": round(self._offsets.get("az", 0.0) - daz, 4),
                     "el_deg": round(self._offsets.get("el", 0.0) - de, 4)}
        self.result = {**base, "refused": None, "el_deg": el,
                       "dx_deg": fit.dx_deg, "dx_err_deg": fit.dx_err_deg,
                       "dy_deg": fit.dy_deg, "dy_err_deg": fit.dy_err_deg,
                       "az_offset_deg": daz, "az_offset_err_deg": fit.dx_err_deg * sec,
                       "el_offset_deg": de, "el_offset_err_deg": fit.dy_err_deg,
                       "fwhm_deg": [fit.az.fwhm_deg[0], fit.el.fwhm_deg[0]], "snr_db": [fit.az.snr_db, fit.el.snr_db],
                       "offsets_before": {"az_deg": self._offsets.get("az", 0.0), "el_deg": self._offsets.get("el", 0.0)},
                       "offsets_suggested": suggested, "applied": False}
        self.result["stored"] = self._store(fit)
        self._end("done", "")
        self.step = (f"done: the beam is {daz:+.3f} +- {fit.dx_err_deg * sec:.3f} deg in az, "
                     f"{de:+.3f} +- {fit.dy_err_deg:.3f} deg in el from where urc reports it")

    def stored_scan(self, fit: Any) -> dict[str, Any]:
        """The scan as urc.pointing.store keeps it: in the frame the pointing model maps
        from (the boresight's direction where the beam was on the source: the reported
        peak taken back through the model then in force), the boresight minus the beam."""
        t = sum(x["t_unix_s"] for x in self.samples) / len(self.samples)
        taz, tel = self.sky.position(t)
        peak = offset_pose(taz, tel, fit.dx_deg, fit.dy_deg)  # where urc reported the beam on it
        baz, bel = peak
        if self._pointing:
            baz, bel = (float(v) for v in PointingModel.from_vector(self._pointing).mech_from_beam(*peak))
        dx, dy = pose_offset(baz, bel, taz, tel)
        return {"t_unix_s": round(t, 3), "date": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime(t)),
                "target": self.target, "az_deg": float(baz), "el_deg": float(bel),
                "dx_deg": float(dx), "dy_deg": float(dy), "dx_err_deg": float(fit.dx_err_deg),
                "dy_err_deg": float(fit.dy_err_deg), "beamwidth_deg": self.fwhm_deg,
                "offsets": {"az_deg": self._offsets.get("az", 0.0), "el_deg": self._offsets.get("el", 0.0)},
                "model_then": list(self._pointing)}

    def _store(self, fit: Any) -> str:
        """Hand the scan to ``record``: what it said (where it went), or why not."""
        if self.record is None:
            return ""
        try:
            return str(self.record(self.stored_scan(fit)))
        except Exception as exc:  # noqa: BLE001 (a full disk must not lose the result shown)
            return f"not stored: {type(exc).__name__}: {exc}"

    def _end(self, state: str, error: str) -> None:
        self.state, self.error = state, error
        if state == "done":
            self.progress = 1.0
        elif error:
            self.step = f"failed: {error}"
        if self._pool is not None:
            self._pool.shutdown(wait=False, cancel_futures=True)
        close = getattr(self.source, "close", None)
        if close is not None and self._pool is None:
            close()
        elif close is not None and self._pool is not None:
            # (on the source's own thread: a read may still be under way)
            threading_close(close)


def threading_close(close: Callable[[], None]) -> None:
    import threading

    threading.Thread(target=close, name="urc-power-close", daemon=True).start()
