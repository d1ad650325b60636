"""The tracking service inside ``urc run``: catalog + station + tracker + schedule."""

from __future__ import annotations

import asyncio
import logging
import time
from pathlib import Path
from typing import Any, Callable

from ..config import Config
from .elements import Catalog
from .errors import TrackingError
from .pass_process import find_passes_isolated
from .pass_process import shutdown as stop_pass_process
from .passes import Pass, find_passes
from .schedule import Request, build_schedule
from ..servers.nmea_source import read_nmea
from .station import NmeaStation, Station
from .targets import (FixedTarget, GeoPointTarget, MoonTarget, NmeaTarget, SatelliteTarget, SunTarget,
                      Target)
from .tracker import Tracker

log = logging.getLogger(__name__)


def realtime_unix_at(now_s: float) -> float:
    """UTC seconds for a RealClock (monotonic) time."""
    return time.time() - (time.monotonic() - now_s)


class TrackingService:
    """What the API and the loop talk to; None of it runs without a configured station."""

    def __init__(self, rotator, cfg: Config, unix_at: Callable[[float], float] = realtime_unix_at,
                 catalog_dir: Path | None = None):
        self.rot = rotator
        self.cfg = cfg
        self.unix_at = unix_at
        self.catalog_dir = catalog_dir or cfg.tracking.resolve_catalog_dir()
        st = cfg.station
        self.station: Station | None = None
        self.tracker: Tracker | None = None
        if st.configured:
            self._set_station(Station(st.lat_deg, st.lon_deg, st.alt_m, st.name))
        self.gps = NmeaStation() if st.gps else None
        self._catalog: Catalog | None = None
        self._schedule: list[Pass] = []
        self._tasks: list[asyncio.Task] = []
        self._target_reader: asyncio.Task | None = None

    def _set_station(self, station: Station) -> None:
        self.station = station
        if self.tracker is None:
            self.tracker = Tracker(self.rot, station, self.unix_at, park_after_pass=self.cfg.tracking.park_after_pass,
                                   min_el_deg=self.cfg.tracking.min_el_deg)
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
        if self._catalog is None or reload:
            self._catalog = Catalog.load(self.catalog_dir)
        return self._catalog

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
        chosen = [cat.get(s) for s in sats] if sats else [cat.get(e.sat) for e in self.cfg.tracking.schedule] \
            or list(cat)
        search = find_passes_isolated if isolated else find_passes
        return search(chosen, station, self.now_unix(), duration_s=hours * 3600.0, min_el_deg=min_el_deg)

    # ---------------------------------------------------------------- commands
    def make_target(self, spec: dict[str, Any]) -> Target:
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
            self._target_reader = asyncio.get_running_loop().create_task(
                read_nmea(source, target.feed), name="nmea-target")
            return target
        if kind == "satellite":
            key = spec.get("norad") if spec.get("norad") is not None else spec.get("name")
            if key is None:
                raise TrackingError("a satellite needs a name or a NORAD id")
            return SatelliteTarget(self.catalog().get(key), station)
        raise TrackingError(f"unknown target kind {kind!r}; expected sun, moon, azel, point or satellite")

    def track(self, spec: dict[str, Any]) -> dict[str, Any]:
        if self.tracker is None:
            self._require_station()
        self._stop_reader()
        target = self.make_target(spec)
        self.tracker.track(target, self.rot.clock.now_s())
        return self.status() or {}

    def track_pass(self, norad: int, aos: Any) -> dict[str, Any]:
        """Fly the pass of ``norad`` whose AOS is near ``aos`` (datetime or UTC seconds)."""
        station = self._require_station()
        aos_unix_s = aos.timestamp() if hasattr(aos, "timestamp") else float(aos)
        es = self.catalog().get(norad)
        found = [p for p in find_passes(es, station, aos_unix_s - 600.0, duration_s=1800.0,
                                        min_el_deg=self.cfg.tracking.min_el_deg)
                 if abs(p.aos_unix_s - aos_unix_s) < 300.0]
        if not found:
            raise TrackingError(f"no pass of {es.label} with AOS near the time given")
        self.tracker.track_pass(es, found[0], self.rot.clock.now_s())
        return self.status() or {}

    def _stop_reader(self) -> None:
        if self._target_reader is not None:
            self._target_reader.cancel()
            self._target_reader = None

    def stop(self) -> None:
        self._stop_reader()
        if self.tracker is not None:
            self.tracker.stop_tracking()

    def run_schedule(self, hours: float = 24.0) -> list[Pass]:
        """Plan the configured schedule's passes; the first is flown, then the next."""
        station = self._require_station()
        cat = self.catalog()
        reqs = [Request(cat.get(e.sat).norad_id, e.priority) for e in self.cfg.tracking.schedule]
        passes = find_passes([cat.get(r.norad_id) for r in reqs], station, self.now_unix(),
                             duration_s=hours * 3600.0, min_el_deg=self.cfg.tracking.min_el_deg)
        self._schedule, dropped = build_schedule(passes, reqs)
        for lost, winner in dropped:
            log.info("schedule: %s pass at %s gives way to %s", lost.name, lost.aos, winner.name)
        return self._schedule

    # ---------------------------------------------------------------- the loop
    def step(self, now_s: float) -> None:
        if self.tracker is None:
            return
        if self.tracker.target is None and self._schedule:
            nxt = self._schedule[0]
            if self.unix_at(now_s) < nxt.los_unix_s:
                self.tracker.track_pass(self.catalog().get(nxt.norad_id), nxt, now_s)
            self._schedule.pop(0)
        self.tracker.step(now_s)

    def status(self) -> dict[str, Any] | None:
        out = self.tracker.status(self.rot.clock.now_s()) if self.tracker is not None else None
        gps = self.gps_status()
        if gps is not None:
            out = dict(out or {}, gps=gps)
        return out
