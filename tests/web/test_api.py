"""The web API without a browser: security (token, CSP), validation, settings, tracking
contract, simulator-only debug endpoints, history, jog leases."""

from __future__ import annotations

import asyncio
import base64
import json
import math
import re
import tomllib
from pathlib import Path

import pytest
from starlette.websockets import WebSocketDisconnect
from urc.web import STATIC_DIR
from urc.web.live import JOG_LEASE_S, Hub

from .fake_tracker import FakeTracker

TOKEN = "s3cret-token"


def next_status(ws) -> dict:
    """The next status frame (skipping the parts sent apart: plan, events)."""
    while True:
        msg = ws.receive_json()
        if msg["type"] == "status":
            return msg


# ----------------------------------------------------------------------- security
def test_csp_and_security_headers_on_page_and_api(make_client):
    c = make_client()
    for path in ("/", "/api/status", "/static/js/main.js"):
        r = c.get(path)
        assert r.status_code == 200, path
        csp = r.headers["content-security-policy"]
        script_src = re.search(r"script-src ([^;]*)", csp).group(1)
        assert "'self'" in script_src and "unsafe-inline" not in csp and "unsafe-eval" not in csp
        assert "frame-ancestors 'none'" in csp
        assert r.headers["x-content-type-options"] == "nosniff"


def test_static_files_have_no_inline_script_or_html_injection_sinks():
    html = (STATIC_DIR / "index.html").read_text()
    assert not re.search(r"<script(?![^>]*\bsrc=)[^>]*>", html), "inline <script> would need 'unsafe-inline'"
    assert not re.search(r"\son[a-z]+\s*=", html), "inline event handlers would need 'unsafe-inline'"
    assert "style=" not in html
    for js in (STATIC_DIR / "js").glob("*.js"):
        text = js.read_text()
        for sink in ("innerHTML", "outerHTML", "insertAdjacentHTML", "document.write", "eval(", "new Function"):
            assert sink not in text, f"{js.name} uses {sink}"


def test_shipped_map_is_small_geojson():
    path = STATIC_DIR / "world-110m.geojson"
    assert path.stat().st_size < 300_000
    import json
    g = json.loads(path.read_text())
    assert g["features"][0]["geometry"]["type"] == "MultiPolygon"
    assert len(g["features"][0]["geometry"]["coordinates"]) > 100


CONTROL_CALLS = [("post", "/api/goto", {"az_deg": 10, "el_deg": 10}), ("post", "/api/stop", {}),
                 ("post", "/api/jog", {"axis": "az", "direction": 1, "speed": 0.5}),
                 ("post", "/api/jog/release", {}), ("post", "/api/settings", {}),
                 ("post", "/api/calibration/zero", {"az_deg": 1.0}),
                 ("post", "/api/calibration/homing", {"axis": "az"}),
                 ("post", "/api/sim/fault", {"axis": "az", "kind": "jam"}),
                 ("post", "/api/track", {"kind": "sun"}), ("post", "/api/track/stop", {})]


READ_TOKEN = "wall-display-9f3e"
READS = ("/api/status", "/api/info", "/api/history", "/api/settings", "/api/calibration", "/api/passes")


def test_remote_listener_needs_a_token_for_control_and_for_reading(make_client):
    """Issue 36.8: an exposed instance served /api/settings (the station's coordinates,
    the whole configuration) to anyone. Reads need the control token or the read-only
    one (a wall display); the read-only one never controls; the page's files stay open."""
    c = make_client(tracker=FakeTracker(), api={"host": "0.0.0.0", "token": TOKEN, "read_token": READ_TOKEN})
    control, reader = {"Authorization": f"Bearer {TOKEN}"}, {"Authorization": f"Bearer {READ_TOKEN}"}
    for method, path, body in CONTROL_CALLS:
        assert c.request(method, path, json=body).status_code == 401, path
        for wrong in ("Bearer wrong", f"Bearer {READ_TOKEN}"):
            bad = c.request(method, path, json=body, headers={"Authorization": wrong})
            assert bad.status_code == 401, (path, wrong)
    ok = c.post("/api/goto", json={"az_deg": 10, "el_deg": 10}, headers=control)
    assert ok.status_code == 200
    assert c.get("/").status_code == 200 and c.get("/static/js/main.js").status_code == 200
    for path in READS:
        refused = c.get(path)
        assert refused.status_code == 401 and "58." not in refused.text, path
        assert c.get(path, headers={"Authorization": "Bearer wrong"}).status_code == 401, path
        assert c.get(path, headers=reader).status_code == 200, path
        assert c.get(path, headers=control).status_code == 200, path
    assert "read_token" not in c.get("/api/settings", headers=control).json()["config"]["api"]
    with pytest.raises(WebSocketDisconnect):
        with c.websocket_connect("/api/ws") as ws:
            ws.receive_json()
    # a browser's WebSocket sends no Authorization: the token comes as a subprotocol
    code = base64.urlsafe_b64encode(READ_TOKEN.encode()).decode().rstrip("=")
    with c.websocket_connect("/api/ws", subprotocols=["urc", f"urc.bearer.{code}"]) as ws:
        assert ws.accepted_subprotocol == "urc"
        assert next_status(ws)["type"] == "status"
    with c.websocket_connect("/api/ws", headers=reader) as ws:
        assert next_status(ws)["type"] == "status"
    assert c.get("/api/info", headers=reader).json()["control_requires_token"] is True


def test_remote_listener_without_a_token_refuses_all_control_and_reading(make_client):
    c = make_client(api={"host": "0.0.0.0"})
    assert c.post("/api/stop", json={}).status_code == 401
    assert c.post("/api/stop", json={}, headers={"Authorization": "Bearer "}).status_code == 401
    assert c.get("/api/settings").status_code == 401 and c.get("/").status_code == 200


def test_a_save_makes_a_config_file_holding_a_token_the_owners_alone(make_client, tmp_path):
    """Issue 36.8: a configuration file with the token, readable by others (0644), is
    0600 after a save."""
    cfg_file = tmp_path / "station.toml"
    cfg_file.write_text(f'[api]\ntoken = "{TOKEN}"\n')
    cfg_file.chmod(0o644)
    c = make_client(config_path=cfg_file, api={"token": TOKEN})
    doc = c.get("/api/settings").json()["config"]
    doc["offsets"]["az_deg"] = 1.0
    assert c.post("/api/settings", json=doc).status_code == 200
    assert cfg_file.stat().st_mode & 0o777 == 0o600


def test_loopback_control_needs_no_token(make_client):
    c = make_client()
    assert c.post("/api/goto", json={"az_deg": 10, "el_deg": 10}).status_code == 200
    assert c.get("/api/info").json()["control_requires_token"] is False


def test_settings_never_reveal_the_token(make_client):
    c = make_client(api={"host": "0.0.0.0", "token": TOKEN})
    r = c.get("/api/settings", headers={"Authorization": f"Bearer {TOKEN}"})
    assert TOKEN not in r.text and r.json()["token_set"] is True


# ----------------------------------------------------------------------- validation
@pytest.mark.parametrize("path,body", [
    ("/api/goto", {"az_deg": "NaN", "el_deg": 10}),
    ("/api/goto", {"az_deg": "north", "el_deg": 10}),
    ("/api/jog", {"axis": "az", "direction": 2}),
    ("/api/jog", {"axis": "az", "direction": 1, "speed": 1.5}),
    ("/api/jog", {"axis": "roll", "direction": 1}),
    ("/api/calibration/zero", {"az_deg": "inf"}),
    ("/api/calibration/pot/apply", {"axis": "az", "points": [{"bearing_deg": 1, "p": 2}]}),
    ("/api/calibration/homing", {"axis": "az", "speed_frac": 0}),
    ("/api/sim/fault", {"axis": "az", "kind": "meteor"}),
    ("/api/sim/fault", {"axis": "az", "kind": "runaway", "duty": 5}),
    ("/api/track", {"kind": "point", "lat_deg": 10}),
    ("/api/track", {"kind": "satellite"}),
    ("/api/track", {"kind": "azel", "az_deg": 10, "el_deg": 10, "extra": 1}),
    ("/api/track/pass", {"norad": 25544, "aos": "tomorrow"}),
])
def test_bad_input_is_rejected_before_anything_moves(make_client, path, body):
    c = make_client(tracker=FakeTracker())
    r = c.post(path, json=body)
    assert r.status_code == 422, (path, r.text)


def test_refused_command_is_409_with_reason(make_client):
    c = make_client()
    r = c.post("/api/goto", json={"az_deg": 10, "el_deg": -60})
    assert r.status_code == 409 and r.json()["reason"] == "limit"


def test_history_arrays_line_up(make_client):
    c = make_client()
    with c.websocket_connect("/api/ws") as ws:
        for _ in range(3):
            next_status(ws)
    h = c.get("/api/history?which=recent").json()
    assert h["count"] >= 2
    n = len(h["t_wall_s"])
    assert all(len(h[k]) == n for k in ("az_deg", "el_deg", "target_az_deg", "error_deg"))
    assert c.get("/api/history?which=last").json()["count"] == 0
    assert c.get("/api/history?which=sometime").status_code == 422


def _status(t: float, az: float) -> dict:
    return {"az_deg": az, "el_deg": 10.0, "target_az_deg": None, "target_el_deg": None,
            "az": {"pos_deg": az, "target_deg": None}, "tracking": None}


def test_history_read_while_the_loop_appends():
    """GET /api/history runs in a worker thread while the loop appends: a reader that
    walked the deque itself got "deque mutated during iteration" (a 500). The append
    here comes mid-walk, from the comparison that filters by time, as a thread switch
    would bring it."""
    from urc.web.history import History

    h = History(capacity=100)
    for i in range(10):
        h.add(1000.0 + i, _status(1000.0 + i, i), None)

    class AppendsWhenCompared(float):
        def __ge__(self, other):
            h.add(2000.0, _status(2000.0, 99.0), None)
            return float(self) >= other

    h.recent.appendleft((AppendsWhenCompared(999.0), *h.recent[0][1:]))
    out = h.select("recent", seconds=1e6)
    assert out["count"] == 11 and out["t_wall_s"][-1] == 1009.0


def test_history_read_from_threads_while_appending():
    import threading

    from urc.web.history import History

    h = History(capacity=5000)
    stop = threading.Event()

    def writer():
        t = 0.0
        while not stop.is_set():
            t += 0.1
            h.add(t, _status(t, t % 360), None)
    w = threading.Thread(target=writer)
    w.start()
    try:
        for _ in range(300):
            out = h.select("recent", seconds=50.0, since_wall_s=1.0)
            assert len(out["t_wall_s"]) == out["count"]
    finally:
        stop.set()
        w.join()


def test_live_frames_carry_status_error_and_procedure(make_client):
    c = make_client()
    c.post("/api/goto", json={"az_deg": 90, "el_deg": 30})
    c.bench.run(0.02)  # the snapshot is rebuilt by the next control tick
    with c.websocket_connect("/api/ws") as ws:
        f = next_status(ws)
        f = next_status(ws)
    assert f["status"]["target_az_deg"] == 90 and f["status"]["tracking"] is None
    assert f["error_deg"] == pytest.approx(math.degrees(math.acos(math.cos(math.radians(30)) * math.cos(math.radians(90)))), abs=1.0)
    assert f["procedure"] is None and f["seq"] >= 1


# ----------------------------------------------------------------------- settings
def test_settings_validation_errors_name_the_field(make_client):
    c = make_client()
    doc = c.get("/api/settings").json()["config"]
    doc["limits"]["az"]["max_deg"] = 999
    r = c.post("/api/settings/validate", json=doc)
    assert r.status_code == 422
    keys = {e["key"]: e["message"] for e in r.json()["errors"]}
    assert "expected" in keys["limits.az.max_deg"] and "999" in keys["limits.az.max_deg"]
    doc["offsets"]["el_deg"] = "x"
    doc["faults"]["runaway_deg"] = -1
    keys = {e["key"] for e in c.post("/api/settings/validate", json=doc).json()["errors"]}
    assert {"offsets.el_deg", "faults.runaway_deg"} <= keys


def test_settings_save_to_the_started_file_keeping_token_and_comments(make_client, tmp_path):
    cfg_file = tmp_path / "station.toml"
    cfg_file.write_text(f'# my station\n[api]\ntoken = "{TOKEN}"  # keep secret\n')
    c = make_client(config_path=cfg_file, api={"token": TOKEN})
    doc = c.get("/api/settings").json()
    assert doc["config_path"] == str(cfg_file)
    data = doc["config"]
    data["keepout"] = [{"name": "tree", "az_min_deg": 170, "az_max_deg": 190, "el_min_deg": 0, "el_max_deg": 20}]
    data["rotator"]["profile"] = "g4jnt"
    r = c.post("/api/settings", json=data)
    assert r.status_code == 200, r.text
    body = r.json()
    assert body["saved_to"] == str(cfg_file)
    assert "rotator" in body["restart_needed"] and "keepout" in body["changed"]
    assert any("restart" in m for m in body["messages"])
    saved = tomllib.loads(cfg_file.read_text())
    assert saved["keepout"][0]["name"] == "tree" and saved["rotator"]["profile"] == "g4jnt"
    assert saved["api"]["token"] == TOKEN
    # edited in place: the person's lines first, as they were
    assert cfg_file.read_text().startswith(f'# my station\n[api]\ntoken = "{TOKEN}"  # keep secret\n')


def test_settings_without_a_config_file_go_to_the_state_dir(make_client):
    c = make_client()
    doc = c.get("/api/settings").json()
    assert doc["config_path"] is None and doc["save_path"].endswith("urc.toml")
    data = doc["config"]
    data["offsets"]["az_deg"] = 1.5
    r = c.post("/api/settings", json=data)
    assert r.status_code == 200
    body = r.json()
    assert body["started_without_file"] and Path(body["saved_to"]).parent == c.bench.state_dir
    assert any("without a configuration file" in m for m in body["messages"])


def test_settings_invalid_document_is_not_saved(make_client, tmp_path):
    cfg_file = tmp_path / "station.toml"
    c = make_client(config_path=cfg_file)
    r = c.post("/api/settings", json={"limits": {"el": {"min_deg": -50}}})
    assert r.status_code == 422 and not cfg_file.exists()


# ----------------------------------------------------------------------- tracking contract
def test_no_tracker_means_no_tracking_endpoints(make_client):
    c = make_client()
    assert c.get("/api/passes").status_code == 404
    assert c.post("/api/track", json={"kind": "sun"}).status_code in (404, 405)
    assert c.get("/api/status").json()["tracking"] is None


def test_tracking_endpoints_follow_the_contract(make_client):
    trk = FakeTracker()
    c = make_client(tracker=trk)
    passes = c.get("/api/passes?hours=12&min_el=20").json()
    assert passes[0]["norad"] == 25544 and ("passes", 12.0, 20.0) in trk.calls
    assert c.post("/api/track", json={"kind": "moon"}).status_code == 200
    assert c.get("/api/status").json()["tracking"]["target"] == "moon"
    assert c.post("/api/track/pass", json={"norad": 25544, "aos": passes[0]["aos"]}).status_code == 200
    st = c.get("/api/status").json()["tracking"]
    assert st["plan"]["track"] and st["ground_track"]
    assert c.post("/api/stop", json={}).status_code == 200
    assert ("stop",) in trk.calls and c.get("/api/status").json()["tracking"] is None


# ----------------------------------------------------------------------- simulator debug
def test_sim_fault_injection_latches_a_fault(make_client):
    c = make_client()
    assert c.post("/api/sim/fault", json={"axis": "el", "kind": "sensor_dead"}).status_code == 200
    c.bench.run(0.2)
    faults = c.get("/api/status").json()["faults"]
    assert faults and faults[0]["kind"] == "sensor_dead"
    assert c.post("/api/sim/clear", json={"axis": "el"}).status_code == 200


def test_sim_fault_refused_off_the_simulator(make_client):
    c = make_client()
    c.bench.rot.hw.backend = "gpio"          # real iron: no simulated world behind the parts
    world, c.bench.rot.hw.world = c.bench.rot.hw.world, None
    r = c.post("/api/sim/fault", json={"axis": "az", "kind": "jam"})
    assert r.status_code == 403 and "simulator" in r.json()["detail"]
    c.bench.rot.hw.world = world


def test_sim_fault_not_possible_on_this_profile_is_409(make_client):
    c = make_client("berkeley")
    assert c.post("/api/sim/fault", json={"axis": "az", "kind": "limit_switch"}).status_code == 409


# ----------------------------------------------------------------------- calibration API
def test_calibration_overview_and_zero(make_client):
    c = make_client("g4jnt")
    d = c.get("/api/calibration").json()
    assert "pot" in d["axes"]["az"]["procedures"]
    p = c.post("/api/calibration/pot/read", json={"axis": "az"}).json()
    assert p["p"] >= 0
    assert c.post("/api/calibration/zero", json={"az_deg": 12.0}).status_code == 200
    c.bench.run(0.1)
    assert c.get("/api/status").json()["az"]["pos_deg"] == pytest.approx(12.0, abs=1.0)


def test_calibration_refusals_are_409(make_client):
    c = make_client("berkeley")
    assert c.post("/api/calibration/magnetometer").status_code == 409
    assert c.post("/api/calibration/homing", json={"axis": "az"}).status_code == 409
    r = c.post("/api/calibration/pot/apply", json={"axis": "az", "points": [{"bearing_deg": 1, "p": 2},
                                                                             {"bearing_deg": 3, "p": 4}]})
    assert r.status_code == 409 and r.json()["reason"] == "calibration"


# ----------------------------------------------------------------------- jog dead man
class _Recorder:
    def __init__(self):
        self.calls = []

    def move(self, axis, direction, speed_frac=1.0, local=False):
        self.calls.append(("move", axis, direction, speed_frac))

    def stop(self, axis=None):
        self.calls.append(("stop", axis))

    def status(self):
        raise RuntimeError("not needed")


def test_jog_stops_when_the_page_stops_renewing():
    async def scenario():
        rec = _Recorder()
        hub = Hub(rec, frame_hz=50.0)
        hub.build_frame = lambda: "{}"
        await hub.jog("az", 1, 0.5)
        for _ in range(5):  # renewed: no second move, no stop
            await asyncio.sleep(JOG_LEASE_S / 3)
            await hub.jog("az", 1, 0.5)
        assert rec.calls == [("move", "az", 1, 0.5)]
        await asyncio.sleep(JOG_LEASE_S + 0.2)
        assert rec.calls[-1] == ("stop", "az") and not hub.jogs
        await hub.jog("el", -1, 1.0)
        await hub.release("el")
        assert rec.calls[-1] == ("stop", "el")
        hub._task.cancel()
    asyncio.run(scenario())


def test_static_files_served_from_memory_with_etag(make_client):
    c = make_client()
    r = c.get("/static/js/main.js")
    assert r.status_code == 200 and r.headers["content-type"].startswith("text/javascript")
    assert c.get("/static/js/main.js", headers={"If-None-Match": r.headers["etag"]}).status_code == 304
    assert c.get("/static/../api.py").status_code == 404
    assert c.get("/static/nothing.js").status_code == 404
    index = c.get("/").text
    for src in re.findall(r'(?:src|href)="(/static/[^"]+)"', index):
        assert c.get(src).status_code == 200, src


@pytest.mark.parametrize("origin,host,code", [
    ("http://evil.example", "127.0.0.1:8080", 403),           # cross-site form or fetch
    ("null", "127.0.0.1:8080", 403),                          # sandboxed frame, file://
    ("http://rebound.example:8080", "rebound.example:8080", 403),  # DNS rebinding
    ("http://127.0.0.1:8080", "127.0.0.1:8080", 200),         # the dashboard itself
    ("http://localhost:8080", "localhost:8080", 200),
    ("http://[::1]:8080", "[::1]:8080", 200),
])
def test_control_from_other_sites_is_refused(make_client, origin, host, code):
    c = make_client()
    r = c.post("/api/park", headers={"Origin": origin, "Host": host})
    assert r.status_code == code, r.text
    assert c.post("/api/park").status_code == 200        # no Origin: not a browser (CLI)


def test_a_tracker_failure_is_a_refusal_with_its_reason(make_client):
    trk = FakeTracker()

    def no_fit(norad, aos):
        raise ValueError("the pass does not fit inside the azimuth/elevation limits on any wrap or flip")
    trk.track_pass = no_fit
    c = make_client(tracker=trk)
    r = c.post("/api/track/pass", json={"norad": 25544, "aos": "2026-01-01T00:00:00Z"})
    assert r.status_code == 409 and "does not fit" in r.json()["error"] and r.json()["reason"] == "tracking"


def test_live_frames_carry_only_what_changes(make_client):
    """Plan and ground track (tens of KiB) reach a dashboard once per change, not in every
    frame; the frames stay small (issue 12, item 12)."""
    trk = FakeTracker()
    c = make_client(tracker=trk)
    aos = trk.pass_list[0]["aos"]
    assert c.post("/api/track/pass", json={"norad": 25544, "aos": aos}).status_code == 200
    full = c.get("/api/status").json()["tracking"]
    with c.websocket_connect("/api/ws") as ws:
        messages = [ws.receive_text() for _ in range(25)]
        frames = [m for m in messages if '"type":"status"' in m]
        plans = [json.loads(m) for m in messages if m.startswith('{"type":"plan"')]
        plans = [p for p in plans if p["data"]]   # (a frame built before the command may come first)
        assert len(plans) == 1 and len(frames) >= 20
        assert plans[0]["data"] == {"plan": full["plan"]}
        grounds = [json.loads(m) for m in messages if m.startswith('{"type":"ground"')]
        assert [g["data"] for g in grounds if g["data"]] == [{"ground_track": full["ground_track"]}]
        assert max(len(f) for f in frames) < 3000, max(len(f) for f in frames)
        last = json.loads(frames[-1])
        assert last["revs"]["plan"] == plans[0]["rev"]
        assert last["status"]["tracking"]["target"] == "ISS (ZARYA)" and "plan" not in last["status"]["tracking"]
        # a change of target: the new (empty) plan arrives before the frame that needs it
        assert c.post("/api/track", json={"kind": "moon"}).status_code == 200
        while True:
            msg = ws.receive_json()
            if msg["type"] == "plan":
                assert msg["data"] == {"plan": None} and msg["rev"] > plans[0]["rev"]
                break
            assert msg["type"] in ("status", "ground") and msg.get("revs", {}).get("plan", plans[0]["rev"]) == plans[0]["rev"]
        assert next_status(ws)["status"]["tracking"]["target"] == "moon"


def test_live_settings_reach_info_and_frames_and_restart_needs_are_kept(make_client, tmp_path):
    """Issue 12, item 10: a zone applied live is what /api/info lists (the page redraws
    when the frames' info revision moves); what waits for a restart stays listed."""
    c = make_client(config_path=tmp_path / "station.toml")
    with c.websocket_connect("/api/ws") as ws:
        rev0 = next_status(ws)["revs"]["info"]
        doc = c.get("/api/settings").json()["config"]
        doc["keepout"] = [{"name": "tree", "az_min_deg": 170, "az_max_deg": 190, "el_min_deg": 0, "el_max_deg": 20}]
        doc["api"]["port"] = 8181
        body = c.post("/api/settings", json=doc).json()
        assert body["applied_live"] and body["restart_needed"] == ["api"]
        c.bench.run(0.05)                                   # the control loop takes the new settings
        assert [z["name"] for z in c.get("/api/info").json()["keepout"]] == ["tree"]
        while (f := next_status(ws))["revs"]["info"] == rev0:
            pass
        assert f["revs"]["info"] > rev0
    doc["offsets"]["az_deg"] = 2.0                          # a second save: the port still waits
    body = c.post("/api/settings", json=doc).json()
    assert body["restart_needed"] == ["api"] and any("restart" in m for m in body["messages"])
    assert c.get("/api/info").json()["restart_pending"] == ["api"]
    assert c.get("/api/settings").json()["restart_pending"] == ["api"]     # the settings page shows it


def test_status_names_the_berkeley_state(make_client):
    """Seed 004: the status JSON carries the document's state machine name."""
    c = make_client("berkeley")
    cyc = c.get("/api/status").json()["cycle"]
    assert cyc["state"] == "process_tle" and cyc["document"] == "PROCESS_TLE" and cyc["why"]


def test_fault_injection_reaches_the_emulated_gpio_backend(make_client):
    """/api/info says simulator on the emulated gpio backend, and its fault injection
    works there too (the injected faults act on the emulated parts)."""
    from conftest import gpio_hardware
    c = make_client("berkeley", hardware=gpio_hardware("berkeley"))
    assert c.get("/api/info").json()["simulator"] and c.bench.rot.hw.backend == "gpio"
    assert c.post("/api/sim/fault", json={"axis": "el", "kind": "sensor_dead"}).status_code == 200
    s = c.bench.run(0.5)
    assert ("sensor_dead", "el") in [(f.kind, f.axis) for f in s.faults]
    assert c.post("/api/sim/clear", json={"axis": "el"}).status_code == 200


def test_goto_without_elevation_turns_the_azimuth_alone(make_client):
    c = make_client("tartu-urc", rotator={"profile": "tartu-urc", "elevation": False})
    assert c.get("/api/info").json()["axes"] == ["az"]
    r = c.post("/api/goto", json={"az_deg": 42.0})
    assert r.status_code == 200, r.text
    assert r.json()["route"][-1] == [42.0, 0.0]  # the mechanical pose: the beam at the horizon
    c.bench.run(10.0)
    s = c.get("/api/status").json()
    assert s["target_az_deg"] == 42.0 and s["el"] is None and s["el_deg"] is None and s["axes"] == ["az"]


class _LoopRecordingTracker(FakeTracker):
    """Records, for each status it computes, whether it ran on an event loop's thread."""

    def __init__(self):
        super().__init__()
        self.on_loop: list[bool] = []

    def status(self):
        try:
            asyncio.get_running_loop()
            self.on_loop.append(True)
        except RuntimeError:
            self.on_loop.append(False)
        return super().status()


def test_status_computes_the_trackers_status_off_the_event_loop(make_client):
    """The tracker's status is tens of ms (a ground track; a first one imports skyfield,
    seconds): /api/status computed it on the event loop when no dashboard was open
    (issue 33). Now in a worker thread, and still as fresh."""
    trk = _LoopRecordingTracker()
    c = make_client(tracker=trk)
    hub = c.app.state.web.hub
    for target in ("sun", "moon", "azel"):
        trk.track({"kind": target})
        hub._tracking_t = -math.inf  # (stale: as a second after the last one)
        st = c.get("/api/status").json()
        assert st["tracking"]["target"] == target
    assert trk.on_loop and not any(trk.on_loop), trk.on_loop
    assert st["loop_lag"] is None   # (no probe started in this app)


def test_mqtt_status_samples_never_compute_the_trackers_status_on_the_loop(bench):
    """MQTT's telemetry samples Hub.status_dict on the event loop every second; before any
    web request had started the dashboard's sampler, that computed the tracker's status
    right there (issue 33). Now a stale one is refreshed in a worker thread."""
    trk = _LoopRecordingTracker()
    trk.track({"kind": "sun"})
    hub = Hub(bench("berkeley").rot, trk)

    async def samples() -> dict:
        for _ in range(3):
            hub._tracking_t = -math.inf
            hub.status_dict()
            await asyncio.sleep(0.05)
        for _ in range(1000):  # (bounded: a refresh that never ends fails here)
            if hub.tracking() is not None and not hub._tracking_busy:
                break
            await asyncio.sleep(0.01)
        return hub.status_dict()
    st = asyncio.run(samples())
    assert st["tracking"]["target"] == "sun"
    assert trk.on_loop and not any(trk.on_loop), trk.on_loop


def test_urc_runs_app_has_its_routes_built_off_the_loop_before_the_first_request(bench, monkeypatch):
    """FastAPI builds a route's models the first time a request is matched against it,
    on the event loop: the first request for the page (routed after every API route)
    held the loop ~0.4 s (issue 33). The app urc run builds (on its running loop) has
    them built on a thread of its own at once."""
    import threading

    import pydantic

    from urc.api import create_api
    from urc.assembly import settings_from_config

    built_on: list[str] = []
    real = pydantic.TypeAdapter.__init__

    def counting(self, *args, **kw):
        built_on.append(threading.current_thread().name)
        return real(self, *args, **kw)
    monkeypatch.setattr(pydantic.TypeAdapter, "__init__", counting)
    b = bench("berkeley")

    async def main() -> tuple[int, list[str]]:
        app = create_api(b.rot, b.cfg, settings_of=settings_from_config)   # as urc run builds it: on its running loop
        for thread in threading.enumerate():
            if thread.name == "urc-warm-routes":
                await asyncio.to_thread(thread.join, 60.0)
        warmed = list(built_on)
        sent: list[dict] = []

        async def receive():
            return {"type": "http.request", "body": b"", "more_body": False}

        async def send(message):
            sent.append(message)
        for path in ("/", "/api/status", "/api/info"):
            await app({"type": "http", "asgi": {"version": "3.0"}, "http_version": "1.1", "method": "GET",
                       "scheme": "http", "path": path, "raw_path": path.encode(), "query_string": b"",
                       "root_path": "", "headers": [(b"host", b"127.0.0.1")], "client": ("127.0.0.1", 1),
                       "server": ("127.0.0.1", 80)}, receive, send)
        return [m["status"] for m in sent if m["type"] == "http.response.start"], warmed

    statuses, warmed = asyncio.run(main())
    assert statuses == [200, 200, 200]
    assert "urc-warm-routes" in warmed           # (the rest: as the routes were added)
    assert built_on == warmed, built_on[len(warmed):]   # nothing more built by the requests


def test_settings_saved_meanwhile_refuse_a_save_from_an_older_revision(make_client, tmp_path):
    """Issue 36.5: two tabs. The second, loaded before the first saved, must not undo it."""
    cfg_file = tmp_path / "station.toml"
    cfg_file.write_text("[offsets]\nel_deg = 0.0\n")
    c = make_client(config_path=cfg_file)
    tab1, tab2 = c.get("/api/settings"), c.get("/api/settings")
    etag = tab1.headers["ETag"]
    assert etag.startswith('"') and etag == tab2.headers["ETag"] == tab1.json()["revision"]
    doc1 = tab1.json()["config"]
    doc1["offsets"]["el_deg"] = 0.5
    r1 = c.post("/api/settings", json=doc1, headers={"If-Match": etag})
    assert r1.status_code == 200, r1.text
    assert r1.headers["ETag"] == r1.json()["revision"] != etag
    saved = cfg_file.read_text()
    doc2 = tab2.json()["config"]
    doc2["park"]["az_deg"] = 5
    r2 = c.post("/api/settings", json=doc2, headers={"If-Match": etag})
    assert r2.status_code == 412, r2.text
    assert r2.headers["ETag"] == r1.headers["ETag"] and "saved by someone else" in r2.json()["errors"][0]["message"]
    assert cfg_file.read_text() == saved                                   # nothing changed
    assert c.get("/api/settings").json()["config"]["offsets"]["el_deg"] == 0.5
    # reloaded: the new revision is taken
    fresh = c.get("/api/settings")
    doc3 = fresh.json()["config"]
    doc3["park"]["az_deg"] = 5
    assert c.post("/api/settings", json=doc3, headers={"If-Match": fresh.headers["ETag"]}).status_code == 200
    after = tomllib.loads(cfg_file.read_text())
    assert after["offsets"]["el_deg"] == 0.5 and after["park"]["az_deg"] == 5
    # a list naming the current revision, and *, match; a weak tag never does (strong comparison)
    cur = c.get("/api/settings").headers["ETag"]
    assert c.post("/api/settings", json=doc3, headers={"If-Match": f'"x", {cur}'}).status_code == 200
    assert c.post("/api/settings", json=doc3, headers={"If-Match": "*"}).status_code == 200
    assert c.post("/api/settings", json=doc3, headers={"If-Match": f"W/{cur}"}).status_code == 412


def test_settings_save_without_if_match_is_still_taken(make_client):
    """Clients written before revisions (scripts) post without If-Match: still saved."""
    c = make_client()
    doc = c.get("/api/settings").json()["config"]
    doc["offsets"]["az_deg"] = 1.0
    assert c.post("/api/settings", json=doc).status_code == 200


def test_urc_settings_set_sends_if_match_and_sets_its_keys_again_on_a_newer_revision(make_client, tmp_path,
                                                                                   monkeypatch):
    """`urc settings set` sends the revision it read; a save from the page in between
    (412) makes it load the settings again and set its keys on top, undoing nothing."""
    from click.testing import CliRunner

    from urc import api_client, cli

    cfg_file = tmp_path / "station.toml"
    cfg_file.write_text("[offsets]\nel_deg = 0.0\n")
    c = make_client(config_path=cfg_file)
    sent: list[tuple[str, dict]] = []

    def through_the_app(url, method, path, body=None, *, token="", timeout_s=0.0, headers=None):
        sent.append((method, dict(headers or {})))
        if method == "POST" and len(sent) == 2:  # the page saves between the command's read and its save
            page = c.get("/api/settings")
            doc = page.json()["config"]
            doc["offsets"]["el_deg"] = 0.5
            assert c.post("/api/settings", json=doc, headers={"If-Match": page.headers["ETag"]}).status_code == 200
        r = c.request(method, path, json=body, headers=headers or {})
        if r.status_code >= 400:
            raise api_client.ClientError(f"refused ({r.status_code})", r.status_code, r.json())
        return r.json()

    monkeypatch.setattr(cli, "api_request", through_the_app)
    res = CliRunner().invoke(cli.main, ["settings", "set", "park.az_deg=5", "--url", "http://127.0.0.1:1"])
    assert res.exit_code == 0, res.output
    assert [m for m, _ in sent] == ["GET", "POST", "GET", "POST"]
    assert all(h.get("If-Match", "").startswith('"') for m, h in sent if m == "POST")
    assert sent[1][1]["If-Match"] != sent[3][1]["If-Match"]
    saved = tomllib.loads(cfg_file.read_text())
    assert saved["offsets"]["el_deg"] == 0.5 and saved["park"]["az_deg"] == 5


def test_a_save_never_writes_into_an_example_it_copies_it_to_the_users_config_dir(make_client, tmp_path,
                                                                                  monkeypatch):
    """Issue 36.12: `urc settings set` on examples/bigras.toml modified the git checkout.
    The first save copies the example to the user's configuration directory, says so,
    and that copy is used from then on (this urc's saves, `urc run --config` the example)."""
    from urc.config.user_copy import in_use

    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path / "xdg"))
    example = Path(__file__).resolve().parents[2] / "examples" / "bigras.toml"
    before = example.read_bytes()
    assert in_use(example) == (example, "")
    c = make_client(profile="bigras", config_path=example)
    doc = c.get("/api/settings").json()["config"]
    doc["offsets"]["az_deg"] = 1.5
    r = c.post("/api/settings", json=doc)
    assert r.status_code == 200, r.text
    copy = tmp_path / "xdg" / "urc" / "bigras.toml"
    assert example.read_bytes() == before                     # the checkout is not touched
    assert r.json()["saved_to"] == str(copy) and any(str(copy) in m and "example" in m for m in r.json()["messages"])
    text = copy.read_text()
    assert text.startswith("# AlfaSpid BIG-RAS") and tomllib.loads(text)["offsets"]["az_deg"] == 1.5
    assert oct(copy.stat().st_mode & 0o777) == "0o600"
    doc = c.get("/api/settings").json()
    assert doc["config_path"] == str(copy)
    doc["config"]["offsets"]["el_deg"] = 0.5                   # the next save edits the copy
    r = c.post("/api/settings", json=doc["config"])
    assert r.json()["saved_to"] == str(copy) and not any("example" in m for m in r.json()["messages"])
    assert tomllib.loads(copy.read_text())["offsets"] == {"az_deg": 1.5, "el_deg": 0.5}
    assert example.read_bytes() == before
    used, note = in_use(example)                               # urc run --config examples/bigras.toml
    assert used == copy and str(copy) in note


# ----------------------------------------------------------------------- stop (urc.dispatch)
def test_a_tracker_that_fails_to_stop_leaves_the_rotator_stopped_and_is_a_409(make_client):
    """The stop goes to the rotator first; the tracker's failure after it is a refusal
    with its reason (it was a 500, a crash, with the tracker's exception)."""
    trk = FakeTracker()

    def stuck():
        raise RuntimeError("catalog locked")
    trk.stop = stuck
    c = make_client(tracker=trk)
    assert c.post("/api/goto", json={"az_deg": 200.0, "el_deg": 40.0}).status_code == 200
    c.bench.run(0.5)
    r = c.post("/api/stop", json={})
    assert r.status_code == 409 and r.json() == {"ok": False, "error": "catalog locked", "reason": "tracking"}
    c.bench.run(0.5)  # (the stop is applied at the next tick)
    s = c.get("/api/status").json()
    assert s["target_az_deg"] is None and s["target_el_deg"] is None, s


def test_a_stop_the_rotator_refuses_still_stops_the_tracker(make_client):
    """The link down: the 409 says why, and the tracker must not go on commanding."""
    from urc.link.client import ControlUnavailable

    trk = FakeTracker()
    c = make_client(tracker=trk)
    assert c.post("/api/track", json={"kind": "moon"}).status_code == 200

    def dead(*_args):
        raise ControlUnavailable("control loop died: it stopped")
    c.bench.rot.stop = dead
    r = c.post("/api/stop", json={})
    assert r.status_code == 409 and r.json()["reason"] == "fault" and "control loop died" in r.json()["error"]
    assert ("stop",) in trk.calls and c.get("/api/status").json()["tracking"] is None
