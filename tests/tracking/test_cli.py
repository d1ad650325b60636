"""``urc passes`` and ``urc tle`` through click's test runner."""

from __future__ import annotations

import json

import click
import pytest
from click.testing import CliRunner

from urc.tracking import download
from urc.tracking.cli import passes_command, tle_command
from urc.tracking.elements import load_elements
from urc.tracking.errors import OfflineError
from urc.tracking.passes import find_passes

from .conftest import FIXTURES, T0, TARTU, synthetic_tle

STATION_ARGS = ["--lat", "58.378", "--lon", "26.729", "--alt", "70"]
START = ["--start", "2024-01-01T12:00:00Z"]


@click.group()
def cli() -> None:
    """Stands in for urc's main group, which registers the two commands."""


cli.add_command(passes_command)
cli.add_command(tle_command)


def run(*args, ok=True):
    result = CliRunner().invoke(cli, [str(a) for a in args])
    if ok:
        assert result.exit_code == 0, result.output
    return result


def test_import_list_and_passes(tmp_path):
    cat = ["--catalog-dir", tmp_path]
    out = run("tle", "import", FIXTURES / "leo.tle", FIXTURES / "omm.csv", *cat).output
    assert "leo.tle: 7 element sets: 7 new" in out
    assert "omm.csv: 4 element sets: 0 new, 0 newer, 4 not newer" in out
    listing = run("tle", "list", *cat).output
    assert "25544  ISS (ZARYA)" in listing and "7 of 7 satellites" in listing
    assert json.loads(run("tle", "list", "noaa", "--json", *cat).stdout)[0]["name"] == "NOAA 18"

    table = run("passes", "iss", "metop", *STATION_ARGS, *START, *cat).output
    assert "above 0 deg, 2024-01-01 12:00:00 to 2024-01-02 12:00:00 UTC" in table
    assert "ISS (ZARYA)" in table and "METOP-B" in table

    data = json.loads(run("passes", "25544", "--json", "--hours", "12", "--min-el", "5",
                          *STATION_ARGS, *START, *cat).stdout)
    ref = find_passes(load_elements(FIXTURES / "leo.tle")[0], TARTU, T0,
                      duration_s=12 * 3600.0, min_el_deg=5.0)
    assert [p["aos"] for p in data["passes"]] == [p.aos.isoformat() for p in ref]
    assert data["passes"][0]["max_el_deg"] == pytest.approx(ref[0].max_el_deg, abs=1e-4)


def test_passes_have_one_minimum_elevation_default(tmp_path):
    """Issue 36.13: 10 deg without --config, 0 with any configuration lacking [tracking]
    (its help said 10). One default now: [tracking] min_el_deg, 0 when unset."""
    leo = ["passes", "--tle", FIXTURES / "leo.tle", "--json", *START, "--hours", "6"]
    bare = tmp_path / "bare.toml"
    bare.write_text('[station]\nlat_deg = 58.378\nlon_deg = 26.729\nalt_m = 70\n')
    high = tmp_path / "high.toml"
    high.write_text(bare.read_text() + "[tracking]\nmin_el_deg = 15\n")
    without = json.loads(run(*leo, *STATION_ARGS).stdout)
    with_config = json.loads(run(*leo, "--config", bare).stdout)
    assert without["min_el_deg"] == with_config["min_el_deg"] == 0.0
    assert without["passes"] == with_config["passes"]
    assert json.loads(run(*leo, "--config", high).stdout)["min_el_deg"] == 15.0
    assert json.loads(run(*leo, *STATION_ARGS, "--min-el", "5").stdout)["min_el_deg"] == 5.0


def test_passes_take_the_station_from_a_running_urc_by_port(tmp_path):
    """Issue 36.13: `urc passes` had no --port like the other client commands. With one
    (or --url), a running urc's [station] and [tracking] min_el_deg are the defaults."""
    import threading
    from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

    info = {"station": {"lat_deg": 58.378, "lon_deg": 26.729, "alt_m": 70.0, "name": ""},
            "tracking_min_el_deg": 12.5}

    class Api(BaseHTTPRequestHandler):
        def do_GET(self):  # noqa: N802 - http.server's name
            body = json.dumps(info if self.path == "/api/info" else {}).encode()
            self.send_response(200 if self.path == "/api/info" else 404)
            self.send_header("Content-Length", str(len(body)))
            self.end_headers()
            self.wfile.write(body)

        def log_message(self, *args):
            pass

    server = ThreadingHTTPServer(("127.0.0.1", 0), Api)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    port = str(server.server_address[1])
    leo = ["passes", "--tle", FIXTURES / "leo.tle", "--json", *START, "--hours", "6"]
    try:
        data = json.loads(run(*leo, "--port", port).stdout)
        assert data["station"] == {"lat_deg": 58.378, "lon_deg": 26.729, "alt_m": 70.0}
        assert data["min_el_deg"] == 12.5
        assert json.loads(run(*leo, "--url", f"http://127.0.0.1:{port}", "--min-el", "3").stdout)["min_el_deg"] == 3
        info["station"] = None
        res = run(*leo, "--port", port, ok=False)
        assert res.exit_code == 2 and "has none" in res.output and "--lat" in res.output
        res = run(*leo, "--port", port, "--url", "http://127.0.0.1:1", ok=False)
        assert res.exit_code == 2 and "not both" in res.output
    finally:
        server.shutdown()
        server.server_close()


def test_passes_from_a_file_with_progress(tmp_path):
    big = tmp_path / "big.tle"
    big.write_text(synthetic_tle(150))
    res = run("passes", "--tle", big, "--hours", "6", "--json", *STATION_ARGS, *START)
    assert res.stdout.lstrip().startswith("{")
    assert "Searching passes" in res.output  # progress bar on stderr
    assert json.loads(res.stdout)["satellites"] == 150


def test_passes_errors(tmp_path):
    cat = ["--catalog-dir", tmp_path]
    res = run("passes", "iss", *START, *cat, ok=False)
    assert res.exit_code == 2 and "no station position" in res.output
    res = run("passes", "iss", *STATION_ARGS, *cat, ok=False)
    assert res.exit_code == 1 and "is empty: run `urc tle update`" in res.output
    run("tle", "import", FIXTURES / "leo.tle", *cat)
    res = run("passes", "noaa", *STATION_ARGS, *cat, ok=False)
    assert res.exit_code == 1 and "2 satellites start with 'noaa'" in res.output
    res = run("passes", *STATION_ARGS, *cat, ok=False)
    assert res.exit_code == 2 and "--all" in res.output
    res = run("passes", "--all", *STATION_ARGS, "--start", "yesterday", *cat, ok=False)
    assert res.exit_code == 2 and "ISO 8601" in res.output
    bad = tmp_path / "bad.tle"
    bad.write_text((FIXTURES / "leo.tle").read_text().replace("51.6416", "5x.6416"))
    res = run("passes", "--tle", bad, *STATION_ARGS, ok=False)
    assert res.exit_code == 1 and "bad.tle:3: TLE line 2" in res.output


def test_tle_update_with_a_fake_network(tmp_path, monkeypatch):
    omm = (FIXTURES / "omm.json").read_bytes()
    calls = []

    def fake(url, timeout_s):
        calls.append(url)
        if "GROUP=weather" in url:
            raise OfflineError("cannot reach celestrak.org: timed out")
        return omm

    monkeypatch.setattr(download, "fetch_url", fake)
    cat = ["--catalog-dir", tmp_path]
    out = run("tle", "update", "stations", *cat).output
    assert "stations: 4 element sets, downloaded" in out and "4 new" in out
    out = run("tle", "update", "stations", *cat).output
    assert "cached copy" in out and len(calls) == 1
    res = run("tle", "update", "stations", "weather", *cat, ok=False)
    assert res.exit_code == 1
    assert "cannot download 1 of 2 CelesTrak group(s)" in res.output
    assert "weather: cannot reach celestrak.org: timed out (never downloaded)" in res.output


def test_station_and_catalog_from_the_config(tmp_path):
    from urc.config import Config

    if "station" not in Config.model_fields or "tracking" not in Config.model_fields:
        pytest.skip("this urc has no [station]/[tracking] configuration")
    conf = tmp_path / "urc.toml"
    conf.write_text(f"[station]\nlat_deg = 58.378\nlon_deg = 26.729\nalt_m = 70.0\n\n"
                    f"[tracking]\ncatalog_dir = '{tmp_path / 'cat'}'\nmin_el_deg = 5.0\n")
    run("tle", "import", FIXTURES / "leo.tle", "--config", conf)
    data = json.loads(run("passes", "iss", "--json", "--config", conf, *START).stdout)
    assert data["station"] == {"lat_deg": 58.378, "lon_deg": 26.729, "alt_m": 70.0}
    assert data["min_el_deg"] == 5.0 and data["passes"]
    over = json.loads(run("passes", "iss", "--json", "--min-el", "20", "--config", conf,
                          *START).stdout)
    assert over["min_el_deg"] == 20.0


def decayed_tle() -> str:
    """An element set sgp4 flags as decayed at its own epoch (perigee below the ground)."""
    import math

    from sgp4 import exporter
    from sgp4.api import WGS72, Satrec
    s = Satrec()
    s.sgp4init(WGS72, "i", 99999, 27028.0, 0.0, 0.0, 0.0, 0.1, math.radians(250), math.radians(51.6), 0.0,
               16.5 * 2 * math.pi / 1440, math.radians(10))  # epoch 2023-12-31
    return "DECAYED SAT\n" + "\n".join(exporter.export_tle(s)) + "\n"


def test_decayed_elements_are_refused_and_give_no_passes(tmp_path):
    """Issue 12.7: `urc passes` listed passes for sets sgp4 flags as decayed at epoch,
    and `tle import` accepted them silently."""
    f = tmp_path / "decayed.tle"
    f.write_text(decayed_tle())
    out = CliRunner().invoke(cli, ["tle", "import", str(f), "--catalog-dir", str(tmp_path / "cat")])
    assert out.exit_code == 0 and "not imported" in out.output and "decayed" in out.output
    assert "0 satellites" in out.output
    res = run("passes", "--tle", f, *STATION_ARGS, *START)
    assert res.output.startswith("0 passes"), res.output
    assert "decayed" in res.output


def test_stale_elements_are_flagged_when_tracked(leo_sets, tmp_path):
    """Issue 12.7: elements weeks old got no warning when tracked."""
    from conftest import Bench
    from urc.tracking.targets import SatelliteTarget
    from urc.tracking.tracker import Tracker

    iss = next(s for s in leo_sets if s.norad_id == 25544)
    tr = Tracker(Bench("tartu-urc", tmp_path).rot, TARTU, lambda now_s: now_s)
    tr.target = SatelliteTarget(iss, TARTU)
    fresh = tr.status(iss.epoch_unix_s + 86400.0)
    old = tr.status(iss.epoch_unix_s + 30 * 86400.0)
    assert not fresh.get("warnings")
    assert "30 days old" in old["warnings"][0]


def test_passes_warn_of_old_elements(tmp_path):
    """Issue 21: 60-day-old elements gave passes with no warning."""
    cat = ["--catalog-dir", tmp_path]
    run("tle", "import", FIXTURES / "leo.tle", *cat)
    late = ["--start", "2024-03-01T12:00:00Z"]  # 60 days after the fixture epochs
    res = CliRunner().invoke(cli, [str(a) for a in ("passes", "iss", *STATION_ARGS, *late, *cat)])
    assert res.exit_code == 0, res.output
    assert "warning: ISS (ZARYA) (NORAD 25544): elements 60 days old (epoch 2024-01-01)" in res.stderr
    assert "urc tle update" in res.stderr
    data = json.loads(run("passes", "iss", "--json", *STATION_ARGS, *late, *cat).stdout)
    assert any("60 days old" in w for w in data["warnings"])
    fresh = CliRunner().invoke(cli, [str(a) for a in ("passes", "iss", *STATION_ARGS, *START, *cat)])
    assert "days old" not in fresh.stderr


def test_two_line_sets_are_named_by_their_norad_id(tmp_path):
    """A 2LE set has no name line: it showed as a blank name in the pass list."""
    two_line = tmp_path / "iss.2le"
    two_line.write_text("\n".join((FIXTURES / "leo.tle").read_text().splitlines()[1:3]) + "\n")
    data = json.loads(run("passes", "--tle", two_line, "--json", *STATION_ARGS, *START).stdout)
    assert data["passes"] and {p["name"] for p in data["passes"]} == {"NORAD 25544"}
    table = run("passes", "--tle", two_line, *STATION_ARGS, *START).output
    assert "NORAD 25544" in table
    run("tle", "import", two_line, "--catalog-dir", tmp_path / "cat")
    assert " 25544  NORAD 25544" in run("tle", "list", "--catalog-dir", tmp_path / "cat").output


def test_a_geostationary_satellite_is_always_above_the_horizon(tmp_path):
    """GEO was one clipped 24 h "pass" with an AOS and LOS that are not rise and set."""
    cat = ["--catalog-dir", tmp_path]
    run("tle", "import", FIXTURES / "deep.tle", *cat)
    pacific = ["--lat", "20", "--lon", "175"]  # (the fixture's GEO hangs over 180 deg)
    table = run("passes", "astra", *pacific, *START, *cat).output
    row = next(line for line in table.splitlines() if line.startswith("ASTRA 1KR"))
    assert "always above the horizon" in row and "<" not in row and ">" not in row
    data = json.loads(run("passes", "astra", "--json", *pacific, *START, *cat).stdout)
    assert [p["always_up"] for p in data["passes"]] == [True]
def test_passes_take_the_station_from_the_running_urcs_gps(tmp_path):
    """Issue 22 (Berkeley): with [station] gps and no lat/lon, `urc passes --config` said
    only "no station position". The fix is the running controller's: asked for it, or
    told how to get one."""
    import socket
    import subprocess
    import threading

    from urc_process import HTTP, URC, free_port, wait_until

    gps_port, api_port = free_port(), free_port()
    listener = socket.create_server(("127.0.0.1", gps_port))
    stop = threading.Event()

    def receiver() -> None:                 # a GPS receiver's NMEA over TCP
        listener.settimeout(0.2)
        while not stop.is_set():
            try:
                conn, _ = listener.accept()
            except OSError:
                continue
            with conn:
                while not stop.is_set():
                    try:
                        conn.sendall((FIXTURES / "gps.nmea").read_bytes())
                    except OSError:
                        break
                    stop.wait(1.0)
    threading.Thread(target=receiver, daemon=True).start()
    cfg = tmp_path / "urc.toml"
    cfg.write_text(f'serve = []\n[station]\ngps = "tcp:127.0.0.1:{gps_port}"\n[api]\nport = {api_port}\n'
                   '[hardware.sim]\nwind = false\n')
    leo = ["--tle", FIXTURES / "leo.tle", "--config", cfg, *START, "--hours", "6"]
    res = run("passes", *leo, ok=False)            # no urc running: says how to get one
    assert res.exit_code == 2 and "no station position" in res.output and "urc run" in res.output
    proc = subprocess.Popen(URC + ["run", "--config", str(cfg), "--state-dir", str(tmp_path / "state")],
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        import httpx

        def fix():
            assert proc.poll() is None, proc.stdout.read()
            try:
                gps = (HTTP.get(f"http://127.0.0.1:{api_port}/api/status", timeout=2).json()
                       .get("tracking") or {}).get("gps") or {}
            except httpx.HTTPError:
                return None
            return gps if gps.get("lat_deg") is not None else None
        gps = wait_until(fix, timeout_s=60, what="a GPS fix in urc's status")
        data = json.loads(run("passes", *leo, "--json").stdout)
        assert data["station"] == {"lat_deg": gps["lat_deg"], "lon_deg": gps["lon_deg"], "alt_m": gps["alt_m"]}
        assert data["satellites"] == 7
    finally:
        stop.set()
        listener.close()
        proc.terminate()
        proc.wait(timeout=30)
