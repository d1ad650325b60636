"""NMEA streams from real transports: a GPS on a pseudo-terminal sets the station; a
balloon's GGA reports over TCP become a target the rotator follows."""

from __future__ import annotations

import asyncio
import os
import time
import tty

import pytest

from urc.config import Config
from urc.tracking.service import TrackingService

from .conftest import FIXTURES
from .test_targets import _balloon_gga


def service(bench, tmp_path, **station):
    b = bench("berkeley")
    cfg = Config.from_dict({"station": station, "tracking": {"catalog_dir": str(tmp_path / "cat")},
                            "rotator": {"profile": "berkeley"}})
    return b, TrackingService(b.rot, cfg, unix_at=lambda now_s: time.time())


async def wait_for(pred, timeout_s: float = 10.0) -> None:
    deadline = time.monotonic() + timeout_s
    while not pred():
        assert time.monotonic() < deadline, "timed out"
        await asyncio.sleep(0.05)


def test_gps_on_a_pty_sets_the_station(bench, tmp_path):
    master, slave = os.openpty()
    tty.setraw(slave)
    path = os.ttyname(slave)
    b, svc = service(bench, tmp_path, gps=path)
    assert svc.station is None and svc.gps is not None

    async def scenario():
        svc.start()
        await asyncio.sleep(0.3)  # opening a port flushes what was waiting: talk after
        os.write(master, (FIXTURES / "gps.nmea").read_bytes())
        await wait_for(lambda: svc.station is not None)
        svc.close()
    asyncio.run(scenario())
    assert svc.tracker is not None
    gps = svc.gps_status()
    assert gps["clock_trustworthy"] in (True, False, None)
    assert -90 <= svc.station.lat_deg <= 90
    # the fix is in the status (`urc passes` with [station] gps takes the station from it)
    assert (gps["lat_deg"], gps["lon_deg"]) == pytest.approx((svc.station.lat_deg, svc.station.lon_deg))
    os.close(master)
    os.close(slave)


def test_balloon_over_tcp_is_followed(bench, tmp_path):
    b, svc = service(bench, tmp_path, lat_deg=58.378, lon_deg=26.729, alt_m=70.0)

    async def scenario():
        async def balloon(reader, writer):
            t = time.time()
            for i in range(6):  # a balloon 20 km north-east, climbing
                writer.write(_balloon_gga(t + i, 58.50 + 0.001 * i, 26.95, 12000.0 + 5 * i))
                await writer.drain()
                await asyncio.sleep(0.05)
            await asyncio.sleep(5)
        server = await asyncio.start_server(balloon, "127.0.0.1", 0)
        port = server.sockets[0].getsockname()[1]
        await svc.track({"kind": "nmea", "source": f"tcp:127.0.0.1:{port}"})
        await wait_for(lambda: svc.tracker.target is not None and _has_position(svc))
        await svc.step(b.clock.now_s())
        b.run(0.1)
        st = svc.status()
        await svc.stop()
        server.close()
        return st
    st = asyncio.run(scenario())
    assert st["target"].startswith("NMEA tcp:")
    assert 20.0 < st["az_deg"] < 70.0 and 5.0 < st["el_deg"] < 60.0  # up to the north-east
    assert b.rot.status().target_az_deg == pytest.approx(st["az_deg"], abs=1.0)


def _has_position(svc) -> bool:
    try:
        svc.tracker.target.position(time.time())
        return True
    except Exception:
        return False
