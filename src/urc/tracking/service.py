"""The tracking service inside ``urc run``: catalog + station + tracker + schedule."""

from __future__ import annotations

import asyncio
import logging
import threading
import time
from pathlib import Path
from typing import Any, Callable

from ..config import Config
from ..link.client import on_event_loop
from .catalog_process import read_catalog
from .elements import Catalog, ElementSet
from .errors import TrackingError
from .nmea_source import read_nmea
from .pass_process import find_passes_isolated
from .pass_process import shutdown as stop_pass_process
from .passes import Pass, find_passes
from .schedule import Request, build_schedule
from .station import NmeaStation, Station
from .targets import (FixedTarget, GeoPointTarget, MoonTarget, NmeaTarget, SatelliteTarget, SunTarget,
                      Target)
from .tracker import Tracker

log = logging.getLogger(__name__)

#: how often a running controller looks whether the element catalog changed on disk
#: (`urc tle import` / `urc tle update` write it while urc runs): a stat, nothing more
CATALOG_CHECK_S = 5.0


def realtime_unix_at(now_s: float) -> float:
    """UTC seconds for a RealClock (monotonic) time."""
    return time.time() - (time.monotonic() - now_s)


class TrackingService:
    """What the API and the loop talk to; None of it runs without a configured station.

    The tracker is synchronous code that calls the rotator port. In ``urc run``
    (``background``) it runs on a thread of its own, where a port call waits for the
    control process blocking that thread only, never the event loop: the awaitable
    :meth:`step`, :meth:`track`, :meth:`track_pass` and :meth:`stop` hand their tracker
    work to it, one at a time (a command never lands in the middle of a step). What
    costs seconds (a catalog read, a pass search and plan) runs on the worker as before,
    the caller awaiting it. Without ``background`` (tests, an in-process rotator) all of
    it runs on the caller's thread; ``*_sync`` are the same commands for a caller off
    the event loop."""

    def __init__(self, rotator, cfg: Config, unix_at: Callable[[float], float] = realtime_unix_at,
                 catalog_dir: Path | None = None, background: bool = False,
                 step_track: Callable[[Config, Station], Any] | None = None):
        """``background``: read the catalog, search and plan passes on a worker thread
        (``urc run``: the event loop must never go silent, issue 33), and import what the
        first requests need on another (:mod:`urc.tracking.warm_up`); else at once.
        ``step_track(cfg, station)`` makes the tracker's step-track once a station is
        known (urc.peaking.steptrack.from_config, handed in by the composition root: the
        peaking package sits above tracking); None: no step-track."""
        self.rot = rotator
        self.cfg = cfg
        self._make_step_track = step_track
        self.unix_at = unix_at
        self.catalog_dir = catalog_dir or cfg.tracking.resolve_catalog_dir()
        self._executor: Any = None
        #: the tracker's own thread (``background``): its steps and commands, in turn
        self._stepper: Any = None
        #: held while the catalog is read and installed: one reader at a time, whichever
        #: thread asked (the worker, a pass search's thread, the schedule's)
        self._catalog_lock = threading.RLock()
        if background:
            from concurrent.futures import ThreadPoolExecutor

            self._executor = ThreadPoolExecutor(max_workers=1, thread_name_prefix="urc-tracking")
            self._stepper = ThreadPoolExecutor(max_workers=1, thread_name_prefix="urc-tracker")
        st = cfg.station
        self.station: Station | None = None
        self.tracker: Tracker | None = None
        if st.configured:
            self._set_station(Station(st.lat_deg, st.lon_deg, st.alt_m, st.name))
        self.gps = NmeaStation() if st.gps else None
        self._catalog: Catalog | None = None
        self._catalog_sig: tuple | None = None
        self._next_catalog_check_s = -float("inf")
        self._reloading: Any = None      # a catalog being read in the background (a Future)
        self._scheduled = False          # run_schedule has run: a reload re-plans it
        self._schedule: list[Pass] = []
        self._tasks: list[asyncio.Task] = []
        self._target_reader: asyncio.Task | None = None
        if background and self.station is not None:
            from .warm_up import warm_up

            # the catalog read at once (the first `urc track` or pass list finds it), and
            # what the first requests import imported beside it
            self._executor.submit(self._preload_catalog)
            threading.Thread(target=warm_up, name="urc-warm-up", daemon=True).start()

    def _set_station(self, station: Station) -> None:
        self.station = station
        if self.tracker is None:
            self.tracker = Tracker(self.rot, station, self.unix_at, park_after_pass=self.cfg.tracking.park_after_pass,
                                   min_el_deg=self.cfg.tracking.min_el_deg)
            self.tracker.background = self._executor
            if self._make_step_track is not None:
                self.tracker.step_track = self._make_step_track(self.cfg, station)
        else:
            self.tracker.station = station

    # ---------------------------------------------------------------- NMEA sources
    def start(self) -> None:
        """Start the GPS reader (call from the running event loop)."""
        if self.gps is not None:
            self._tasks.append(asyncio.get_running_loop().create_task(
                read_nmea(self.cfg.station.gps, self._gps_feed, self.cfg.station.gps_baud), name="gps"))

    def close(self) -> None:
        stop_pass_process()
        for executor in (self._executor, self._stepper):
            if executor is not None:
                executor.shutdown(wait=False, cancel_futures=True)
        for task in self._tasks + ([self._target_reader] if self._target_reader else []):
            task.cancel()

    def _gps_feed(self, data: bytes, received_unix_s: float) -> None:
        fixes = self.gps.feed(data, received_unix_s)
        if fixes and not self.cfg.station.configured and self.gps.last_valid_fix is not None:
            station = self.gps.station()
            if self.station is None or abs(station.lat_deg - self.station.lat_deg) > 1e-4 \
                    or abs(station.lon_deg - self.station.lon_deg) > 1e-4:
                log.info("station from GPS: %.5f %.5f %.0f m", station.lat_deg, station.lon_deg, station.alt_m)
                self._set_station(station)

    def gps_status(self) -> dict[str, Any] | None:
        if self.gps is None:
            return None
        out = {"source": self.cfg.station.gps, "fix": self.gps.has_fix,
               "clock_offset_s": self.gps.clock_offset_s, "clock_trustworthy": self.gps.clock_trustworthy}
        if self.gps.last_valid_fix is not None:   # where the receiver is (`urc passes` asks)
            st = self.gps.station()
            out.update(lat_deg=st.lat_deg, lon_deg=st.lon_deg, alt_m=st.alt_m)
        return out

    # ---------------------------------------------------------------- helpers
    def _require_station(self) -> Station:
        if self.station is None:
            raise TrackingError("no station configured: set [station] lat_deg and lon_deg")
        return self.station

    def catalog(self, reload: bool = False) -> Catalog:
        """The element catalog, read again when the file changed since it was read: on
        the worker when asked on the event loop's thread (100 000 sets are seconds of
        CPU, and the loop's silence stops the axes)."""
        if self._catalog is not None and not reload and self._catalog_signature() == self._catalog_sig:
            return self._catalog
        return self._off_loop(self._load_catalog, reload)

    def _load_catalog(self, reload: bool) -> Catalog:
        """Read the catalog if it changed (or ``reload``), and install it; off the loop."""
        with self._catalog_lock:
            sig = self._catalog_signature()
            if self._catalog is None or reload or sig != self._catalog_sig:
                had = self._catalog is not None
                cat = read_catalog(self.catalog_dir)
                self._install_catalog(sig, cat, self._replanned_schedule(cat) if had else None, announce=had)
            assert self._catalog is not None
            return self._catalog

    def _preload_catalog(self) -> None:
        try:
            self._load_catalog(False)
        except Exception as exc:  # said again by whatever asks for it next
            log.warning("element catalog not read: %s", exc)

    def _catalog_signature(self) -> tuple | None:
        try:
            st = Catalog.path_in(self.catalog_dir).stat()
        except OSError:
            return None
        return st.st_mtime_ns, st.st_size, st.st_ino

    def _read_catalog(self) -> tuple[tuple | None, Catalog, list[Pass] | None]:
        """(signature, catalog, the schedule re-planned on it): may run on the worker."""
        with self._catalog_lock:
            sig = self._catalog_signature()
            cat = read_catalog(self.catalog_dir)
            return sig, cat, self._replanned_schedule(cat)

    def _replanned_schedule(self, cat: Catalog) -> list[Pass] | None:
        if not self._scheduled or self.station is None:
            return None
        try:
            return self._plan_schedule(cat)
        except Exception as exc:  # a satellite gone from the catalog: the old plan stays
            log.warning("schedule not re-planned on the new elements: %s", exc)
            return None

    def _install_catalog(self, sig: tuple | None, cat: Catalog, schedule: list[Pass] | None,
                         announce: bool) -> None:
        self._catalog, self._catalog_sig = cat, sig
        if not announce:
            return
        said = [f"element catalog changed on disk: {len(cat)} sets read again; new elements are "
                "used from the next pass (the pass being flown keeps its plan)"]
        t = self.tracker
        if t is not None and t.follow_satellite and t.target is not None:
            try:
                es = cat.get(t.target.elements.norad_id)
            except TrackingError:
                es = None
            if es is not None and es.epoch != t.target.elements.epoch and t.use_elements(es):
                said.append(f"{es.label}: elements of {es.epoch:%Y-%m-%d %H:%M}Z from its next pass")
        if schedule is not None:
            self._schedule = [p for p in schedule if p.los_unix_s > self.now_unix()]
            said.append(f"schedule re-planned: {len(self._schedule)} passes")
        text = "; ".join(said)
        log.info("%s", text)
        announce_fn = getattr(self.rot, "announce", None)
        if announce_fn is not None:
            try:
                announce_fn(text)  # in the status' events: the operator sees it
            except Exception:  # the control link busy or gone: the log line stands
                log.debug("catalog reload not announced", exc_info=True)

    def _watch_catalog(self, now_s: float) -> None:
        """In the loop: a stat every CATALOG_CHECK_S; a changed catalog is read (on the
        worker when there is one) and installed here."""
        if self._reloading is not None:
            if self._reloading.done():
                future, self._reloading = self._reloading, None
                try:
                    self._install_catalog(*future.result(), announce=True)
                except Exception as exc:  # a half-written or corrupt file: the old one stays
                    log.warning("element catalog not read again: %s", exc)
            return
        if self._catalog is None or now_s < self._next_catalog_check_s:
            return
        self._next_catalog_check_s = now_s + CATALOG_CHECK_S
        if self._catalog_signature() == self._catalog_sig:
            return
        if self._executor is None:
            try:
                self._install_catalog(*self._read_catalog(), announce=True)
            except Exception as exc:
                log.warning("element catalog not read again: %s", exc)
        else:
            self._reloading = self._executor.submit(self._read_catalog)

    def now_unix(self) -> float:
        return self.unix_at(self.rot.clock.now_s())

    # ---------------------------------------------------------------- queries
    def passes(self, hours: float, min_el_deg: float, sats: list[str] | None = None) -> list[dict[str, Any]]:
        """The web page's pass list (the schedule's satellites, else the whole catalog)."""
        return [{"norad": p.norad_id, "name": p.name, "aos": p.aos.isoformat(), "tca": p.tca.isoformat(),
                 "los": p.los.isoformat(), "max_el_deg": round(p.max_el_deg, 2),
                 "aos_az_deg": round(p.aos_az_deg, 2), "los_az_deg": round(p.los_az_deg, 2)}
                for p in self.find_passes(hours, min_el_deg, sats, isolated=True)]

    def find_passes(self, hours: float, min_el_deg: float, sats: list[str] | None = None, *,
                    isolated: bool = False) -> list[Pass]:
        """``isolated``: search in the worker process (a search asked for over the network
        while the control loop runs must not hold its interpreter)."""
        station = self._require_station()
        cat = self.catalog()
        chosen = [cat.get(s) for s in sats] if sats else [cat.get(e.sat) for e in self.cfg.tracking.schedule]
        if isolated:  # (a whole catalog goes as its records: its sets are not built here)
            return find_passes_isolated(chosen or cat, station, self.now_unix(), duration_s=hours * 3600.0,
                                        min_el_deg=min_el_deg)
        return find_passes(chosen or list(cat), station, self.now_unix(), duration_s=hours * 3600.0,
                           min_el_deg=min_el_deg)

    # ---------------------------------------------------------------- commands
    def make_target(self, spec: dict[str, Any]) -> Target:
        """The target ``spec`` names (a satellite's elements looked up here: off the
        event loop, or :meth:`track` looks them up on the worker first)."""
        if spec.get("kind") == "satellite":
            station = self._require_station()
            return SatelliteTarget(self._lookup(self._satellite_key(spec)), station)
        return self._plain_target(spec)

    @staticmethod
    def _satellite_key(spec: dict[str, Any]) -> str | int:
        key = spec.get("norad") if spec.get("norad") is not None else spec.get("name")
        if key is None:
            raise TrackingError("a satellite needs a name or a NORAD id")
        return key

    def _plain_target(self, spec: dict[str, Any]) -> Target:
        station = self._require_station()
        kind = spec.get("kind")
        if kind == "sun":
            return SunTarget(station)
        if kind == "moon":
            return MoonTarget(station)
        if kind == "azel":
            return FixedTarget(float(spec["az_deg"]), float(spec["el_deg"]))
        if kind == "point":
            return GeoPointTarget(station, float(spec["lat_deg"]), float(spec["lon_deg"]),
                                  float(spec.get("alt_m") or 0.0))
        if kind == "nmea":
            source = str(spec.get("source") or "")
            if not source:
                raise TrackingError("an NMEA target needs a source: a device path or tcp:HOST:PORT")
            target = NmeaTarget(station)
            target.name = f"NMEA {source}"
            # (on the event loop's thread: :meth:`track` makes it there)
            self._target_reader = asyncio.get_running_loop().create_task(
                read_nmea(source, target.feed), name="nmea-target")
            return target
        raise TrackingError(f"unknown target kind {kind!r}; expected sun, moon, azel, point or satellite")

    async def track(self, spec: dict[str, Any]) -> dict[str, Any]:
        """Follow the target ``spec`` names; the tracking status."""
        if self.tracker is None:
            self._require_station()
        assert self.tracker is not None  # (made with the station)
        self._stop_reader()
        if spec.get("kind") == "satellite":  # (looked for through the whole catalog: on the worker)
            es = await self._on_worker(self._lookup, self._satellite_key(spec))
            target: Target = SatelliteTarget(es, self._require_station())
        else:
            target = self._plain_target(spec)
        await self._on_tracker(self.tracker.track, target, self.rot.clock.now_s())
        return await self._status_async()

    def track_sync(self, spec: dict[str, Any]) -> dict[str, Any]:
        """:meth:`track` from a caller off the event loop (or an in-process rotator)."""
        if self.tracker is None:
            self._require_station()
        assert self.tracker is not None  # (made with the station)
        self._stop_reader()
        self.tracker.track(self.make_target(spec), self.rot.clock.now_s())
        return self.status() or {}

    async def track_pass(self, norad: int, aos: Any) -> dict[str, Any]:
        """Fly the pass of ``norad`` whose AOS is near ``aos`` (datetime or UTC seconds):
        searched and planned on the worker, the caller awaiting it."""
        station = self._require_station()
        aos_unix_s = aos.timestamp() if hasattr(aos, "timestamp") else float(aos)
        assert self.tracker is not None  # (made with the station)
        generation = self.tracker.generation
        job = await self._on_worker(self._find_and_plan_pass, norad, station, aos_unix_s,
                                    self.rot.clock.now_s())
        await self._on_tracker(self._fly_unless_superseded, job, generation)
        return await self._status_async()

    def track_pass_sync(self, norad: int, aos: Any) -> dict[str, Any]:
        """:meth:`track_pass` from a caller off the event loop (or an in-process rotator)."""
        station = self._require_station()
        aos_unix_s = aos.timestamp() if hasattr(aos, "timestamp") else float(aos)
        assert self.tracker is not None
        generation = self.tracker.generation
        job = self._find_and_plan_pass(norad, station, aos_unix_s, self.rot.clock.now_s())
        self._fly_unless_superseded(job, generation)
        return self.status() or {}

    def _fly_unless_superseded(self, job: Any, generation: int) -> None:
        assert self.tracker is not None
        if self.tracker.generation != generation:  # a stop or another target meanwhile: it wins
            raise TrackingError(f"the pass of {job.target.name} was not flown: another tracking command "
                                "came while it was being planned")
        self.tracker.fly(job)

    async def _status_async(self) -> dict[str, Any]:
        """The status a command answers with: computed in a thread in ``urc run`` (a
        ground track is tens of ms of skyfield), not on the worker (it may be planning
        the next pass for seconds) nor the tracker's thread (it steps)."""
        if self._executor is None:
            return self.status() or {}
        return await asyncio.get_running_loop().run_in_executor(None, self.status) or {}

    def _lookup(self, key: str | int) -> ElementSet:
        return self.catalog().get(key)

    def _find_and_plan_pass(self, norad: int, station: Station, aos_unix_s: float, now_s: float):
        """The pass of ``norad`` whose AOS is near ``aos_unix_s``, planned (pure: a worker may
        run it; the catalog is read there if it changed)."""
        es = self._lookup(norad)
        found = [p for p in find_passes(es, station, aos_unix_s - 600.0, duration_s=1800.0,
                                        min_el_deg=self.cfg.tracking.min_el_deg)
                 if abs(p.aos_unix_s - aos_unix_s) < 300.0]
        if not found:
            raise TrackingError(f"no pass of {es.label} with AOS near the time given")
        assert self.tracker is not None
        return self.tracker.plan_pass(es, found[0], now_s)

    async def _on_worker(self, fn: Callable[..., Any], *args: Any) -> Any:
        """``await``: ``fn(*args)`` on the worker (``urc run``), the caller suspended
        meanwhile, never the loop: a catalog read, a pass search and plan cost seconds
        of CPU under load, and the loop's silence stops the axes (issues 21, 33)."""
        if self._executor is None:
            return fn(*args)
        return await asyncio.wrap_future(self._executor.submit(fn, *args))

    async def _on_tracker(self, fn: Callable[..., Any], *args: Any) -> Any:
        """``await``: ``fn(*args)`` on the tracker's thread (``urc run``): it calls the
        rotator port, whose round trip to the control process blocks that thread only."""
        if self._stepper is None:
            return fn(*args)
        return await asyncio.wrap_future(self._stepper.submit(fn, *args))

    def _off_loop(self, fn: Callable[..., Any], *args: Any) -> Any:
        """``fn(*args)`` from synchronous code: here, off the event loop (the tracker's
        thread, the worker, a pass search's); on the loop's thread with a worker it runs
        there, but the loop waits (a bug: await :meth:`_on_worker`), said in the log."""
        if self._executor is None or not on_event_loop():
            return fn(*args)
        log.warning("%s called on the event loop: the loop waits for it", getattr(fn, "__name__", fn))
        return self._executor.submit(fn, *args).result()

    def _stop_reader(self) -> None:
        if self._target_reader is not None:
            self._target_reader.cancel()
            self._target_reader = None

    async def stop(self) -> None:
        self._stop_reader()
        if self.tracker is not None:
            await self._on_tracker(self.tracker.stop_tracking)

    def stop_sync(self) -> None:
        """:meth:`stop` from a caller off the event loop (or an in-process rotator)."""
        self._stop_reader()
        if self.tracker is not None:
            self.tracker.stop_tracking()

    def run_schedule(self, hours: float = 24.0) -> list[Pass]:
        """Plan the configured schedule's passes; the first is flown, then the next."""
        self._require_station()
        self._schedule = self._plan_schedule(self.catalog(), hours, log_dropped=True)
        self._scheduled = True
        return self._schedule

    def _plan_schedule(self, cat: Catalog, hours: float = 24.0, log_dropped: bool = False) -> list[Pass]:
        station = self._require_station()
        reqs = [Request(cat.get(e.sat).norad_id, e.priority) for e in self.cfg.tracking.schedule]
        passes = find_passes([cat.get(r.norad_id) for r in reqs], station, self.now_unix(),
                             duration_s=hours * 3600.0, min_el_deg=self.cfg.tracking.min_el_deg)
        schedule, dropped = build_schedule(passes, reqs)
        for lost, winner in dropped if log_dropped else ():
            log.info("schedule: %s pass at %s gives way to %s", lost.name, lost.aos, winner.name)
        return schedule

    # ---------------------------------------------------------------- the loop
    async def step(self, now_s: float) -> None:
        """One step of the tracker (``urc run``'s loop), on the tracker's thread."""
        if self.tracker is not None:
            await self._on_tracker(self.step_sync, now_s)

    def step_sync(self, now_s: float) -> None:
        """:meth:`step` here: off the event loop (or with an in-process rotator)."""
        if self.tracker is None:
            return
        self._watch_catalog(now_s)
        if self.tracker.target is None and self._schedule:
            nxt = self._schedule[0]
            if self.unix_at(now_s) < nxt.los_unix_s:
                # the catalog as installed (a changed file is read by _watch_catalog, on
                # the worker; none yet: read here, off the loop); the plan is made on
                # the worker too
                cat = self._catalog if self._catalog is not None else self.catalog()
                self.tracker.start_pass(cat.get(nxt.norad_id), nxt, now_s)
            self._schedule.pop(0)
        self.tracker.step(now_s)

    def status(self) -> dict[str, Any] | None:
        out = self.tracker.status(self.rot.clock.now_s()) if self.tracker is not None else None
        gps = self.gps_status()
        if gps is not None:
            out = dict(out or {}, gps=gps)
        return out
