"""Station position from values and from a GPS receiver's NMEA stream (sans-I/O)."""

from __future__ import annotations

from datetime import datetime, timezone

import pynmea2
import pytest

from urc.tracking.errors import StationError
from urc.tracking.station import NmeaStation, Station

from .conftest import FIXTURES

LOG = (FIXTURES / "gps.nmea").read_bytes()
#: the log's first sentence is stamped 11:59:50 UTC on 2024-01-01
LOG_START_UNIX_S = datetime(2024, 1, 1, 11, 59, 50, tzinfo=timezone.utc).timestamp()
#: ddmm.mmmm in the log -> degrees
LAT_DEG, LON_DEG, ALT_M = 58 + 22.68 / 60, 26 + 43.74 / 60, 70.0


def feed_log(gps: NmeaStation, clock_offset_s: float = 0.3, chunk: int | None = None):
    """Feed the log sentence by sentence as a receiver would send it, once a second,
    ``clock_offset_s`` after the GPS time (output latency, or a wrong system clock)."""
    fixes = []
    for line in LOG.split(b"\n"):
        if not line:
            continue
        data = line + b"\n"
        second = _sentence_second(line)
        rx = LOG_START_UNIX_S + second + clock_offset_s
        if chunk is None:
            fixes += gps.feed(data, rx)
        else:
            for i in range(0, len(data), chunk):
                fixes += gps.feed(data[i:i + chunk], rx)
    return fixes


def _sentence_second(line: bytes) -> int:
    try:
        hms = line.split(b",")[1]
        return (int(hms[:2]) - 11) * 3600 + (int(hms[2:4]) - 59) * 60 + int(hms[4:6]) - 50
    except (IndexError, ValueError):
        return 0


def test_station_from_values_and_checks():
    st = Station(58.378, 26.729, 70.0, "Tartu")
    assert st.skyfield.latitude.degrees == pytest.approx(58.378)
    for bad in (dict(lat_deg=91.0, lon_deg=0.0), dict(lat_deg=0.0, lon_deg=float("nan")),
                dict(lat_deg=0.0, lon_deg=0.0, alt_m=1e6), dict(lat_deg="58", lon_deg=0.0)):
        with pytest.raises(StationError, match="expected a number"):
            Station(**bad)


def test_fixture_log_gives_a_fix_and_a_trusted_clock():
    gps = NmeaStation(clock_tolerance_s=2.0)
    fixes = feed_log(gps)
    assert not fixes[0].valid and fixes[0].lat_deg is None  # cold start: no fix yet
    valid = [f for f in fixes if f.valid]
    assert len(valid) >= 20
    assert valid[0].gps_time == datetime(2024, 1, 1, 11, 59, 54, tzinfo=timezone.utc)
    st = gps.station("roof")
    assert (st.lat_deg, st.lon_deg, st.alt_m) == pytest.approx((LAT_DEG, LON_DEG, ALT_M))
    assert gps.has_fix
    assert gps.clock_offset_s == pytest.approx(0.3, abs=1e-6)
    assert gps.clock_trustworthy is True
    # one corrupted checksum and one line cut short in the log
    assert gps.stats.bad == 2
    assert "checksum" in " ".join(gps.stats.errors)
    assert gps.stats.ignored > 0  # GSA sentences


def test_wrong_system_clock_is_detected():
    gps = NmeaStation(clock_tolerance_s=2.0)
    feed_log(gps, clock_offset_s=-37.0)
    assert gps.clock_offset_s == pytest.approx(-37.0)
    assert gps.clock_trustworthy is False
    # a system clock a whole day off is not hidden by the date handling
    gps = NmeaStation()
    feed_log(gps, clock_offset_s=86400.0)
    assert gps.clock_offset_s == pytest.approx(86400.0)


def test_one_byte_at_a_time_gives_the_same_fixes():
    whole = feed_log(NmeaStation())
    bytewise = feed_log(NmeaStation(), chunk=1)
    assert bytewise == whole


def test_no_fix_no_station():
    gps = NmeaStation()
    with pytest.raises(StationError, match="no valid GPS fix yet"):
        gps.station()
    first_lines = b"\n".join(LOG.split(b"\n")[:8]) + b"\n"
    gps.feed(first_lines, LOG_START_UNIX_S)
    assert not gps.has_fix and gps.clock_trustworthy is None
    with pytest.raises(StationError):
        gps.station()


def _gga(hms: str, qual: str = "1") -> bytes:
    return (str(pynmea2.GGA("GP", "GGA", (hms, "5822.6800", "N", "02643.7400", "E", qual,
                                          "08", "0.9", "70.0", "M", "19.5", "M", "", "")))
            + "\r\n").encode()


def _rmc(hms: str, ddmmyy: str) -> bytes:
    return (str(pynmea2.RMC("GP", "RMC", (hms, "A", "5822.6800", "N", "02643.7400", "E",
                                          "0.0", "0.0", ddmmyy, "", "", "A"))) + "\r\n").encode()


def test_gga_dated_across_midnight_from_the_last_rmc():
    gps = NmeaStation()
    gps.feed(_rmc("235959.00", "311223"), None)
    (fix,) = gps.feed(_gga("000001.00"), None)
    assert fix.gps_time == datetime(2024, 1, 1, 0, 0, 1, tzinfo=timezone.utc)
    assert fix.clock_offset_s is None  # no receive time given: nothing to compare


def test_rmc_only_has_no_altitude():
    gps = NmeaStation()
    gps.feed(_rmc("120000.00", "010124"), LOG_START_UNIX_S + 10)
    assert gps.last_fix.valid and gps.last_fix.alt_m is None
    with pytest.raises(StationError, match="no altitude"):
        gps.station()


def test_garbage_is_counted_not_raised():
    gps = NmeaStation()
    out = gps.feed(b"\x00\xffnoise\r\n$GPGGA,bad*00\r\n" + b"x" * 500, 0.0)
    assert out == [] and gps.stats.bad >= 3
