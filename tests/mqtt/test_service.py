"""``urc run`` with [mqtt] against a real Mosquitto, read and commanded by a real client:
retained availability/status/discovery, every command and its result, bad payloads,
discovery removed, a broker that is missing at start and one killed mid-pass."""

from __future__ import annotations

import json
import time

from urc_process import wait_until

from .broker import Mosquitto, overhead_station

BASE = "urc/dish"


def sim_az_deg(u) -> float:
    return u.status()["simulator_truth"]["az"]["deg"]


def test_retained_availability_status_and_discovery(broker, station, clients):
    u = station("dish", broker.url)
    watcher = clients(broker.port)
    wait_until(lambda: watcher.last(f"{BASE}/status"), 60, "a status")
    # a client that comes later gets the retained latest of each, flagged retained
    late = clients(broker.port)
    wait_until(lambda: len([m for m in late.messages if m[0].startswith("homeassistant/")]) == 8, 60,
               "eight discovery configs")
    retained: dict = {}
    for t, p, r in late.messages:  # the first of each topic: what the broker kept
        retained.setdefault(t, (p, r))
    assert retained[f"{BASE}/availability"] == (b"online", True)
    status, was_retained = retained[f"{BASE}/status"]
    assert was_retained
    s = json.loads(status)
    api = u.status()
    assert s["station"] == "dish" and s["state"] == "idle" and s["position_known"] is True
    assert abs(s["az_deg"] - api["az_deg"]) < 0.1 and abs(s["el_deg"] - api["el_deg"]) < 0.1
    assert s["faults"] == [] and s["tracking"] is None
    configs = {t: json.loads(p) for t, (p, r) in retained.items() if t.startswith("homeassistant/") and r}
    kinds = sorted(t.split("/")[1] + ":" + t.split("/")[3] for t in configs)
    assert kinds == ["binary_sensor:fault", "button:park", "button:stop", "sensor:azimuth", "sensor:elevation",
                     "sensor:next_pass", "sensor:state", "sensor:tracking"]
    devices = {json.dumps(c["device"], sort_keys=True) for c in configs.values()}
    assert len(devices) == 1, "one device per station"
    device = configs["homeassistant/sensor/urc_dish/azimuth/config"]["device"]
    from urc import __version__
    assert device["sw_version"] == __version__ and device["identifiers"] == ["urc_dish"]
    assert configs["homeassistant/binary_sensor/urc_dish/fault/config"]["device_class"] == "problem"
    stop_button = configs["homeassistant/button/urc_dish/stop/config"]
    assert stop_button["command_topic"] == f"{BASE}/cmd"
    assert json.loads(stop_button["payload_press"])["command"] == "stop"
    assert all(c["availability_topic"] == f"{BASE}/availability" for c in configs.values())
    # Home Assistant 2025.10+: the entity id asked for with its domain (object_id is gone in 2026.4)
    assert all("object_id" not in c and c["default_entity_id"] == f"{t.split('/')[1]}.{c['unique_id']}"
               for t, c in configs.items())

    out = u.stop()  # a clean stop says offline (retained) before it goes
    assert "stopped, state saved" in out
    wait_until(lambda: watcher.on(f"{BASE}/availability")[-1:] == [b"offline"], 60, "offline")


def test_each_command_and_its_result(broker, station, clients):
    u = station("dish", broker.url)
    c = clients(broker.port)
    wait_until(lambda: c.last(f"{BASE}/status"), 60, "a status")
    assert c.command(BASE, {"id": "g1", "command": "goto", "az_deg": 120.0, "el_deg": 30.0}) == \
        {"id": "g1", "ok": True, "state": "accepted"}
    s = u.status()
    assert (s["target_az_deg"], s["target_el_deg"]) == (120.0, 30.0)
    wait_until(lambda: (c.last(f"{BASE}/status") or {}).get("state") == "moving", 60, "moving, on MQTT")
    assert c.command(BASE, {"id": 2, "command": "stop"}) == {"id": 2, "ok": True}
    u.wait(lambda s: not s["moving"], 60)
    stopped_az = sim_az_deg(u)
    assert abs(stopped_az - 120.0) > 1.0, "stopped before it got there"
    # the goto's end: one more result, never a silent idle (issue 33)
    end = c.outcome(BASE, "g1")
    assert end["ok"] is False and end["state"] == "stopped" and end["kind"] == "person", end
    assert c.command(BASE, {"id": "g2", "command": "goto", "az_deg": 40.0})["ok"]   # azimuth only
    assert u.status()["target_az_deg"] == 40.0
    # (a park at once: g2 replaced. A stop of the azimuth first would race it: the status
    # showing g2 stopped by a person may come before the park or after)
    assert c.command(BASE, {"id": "p", "command": "park"})["ok"]
    assert c.outcome(BASE, "g2")["state"] == "replaced"
    s = u.wait(lambda s: s["parked"], 60)
    assert c.outcome(BASE, "p") == {"id": "p", "ok": True, "command": "park", "state": "done"}
    assert c.command(BASE, {"id": "s-az", "command": "stop", "axis": "az"})["ok"]
    wait_until(lambda: (c.last(f"{BASE}/status") or {}).get("state") == "parked", 60, "parked, on MQTT")
    assert c.command(BASE, {"id": "cf", "command": "clear_faults"}) == {"id": "cf", "ok": True}
    # tracking needs a station position: refused here with the reason
    r = c.command(BASE, {"id": "t", "command": "track", "kind": "sun"})
    assert r["ok"] is False and "station" in r["error"]
    # refused by the rotator's gate: out of the profile's limits (Tartu: 0..180 el)
    r = c.command(BASE, {"id": "lim", "command": "goto", "az_deg": 10.0, "el_deg": -20.0})
    assert r["ok"] is False and r["error"] and r["reason"] != "invalid", r
    assert u.status()["target_el_deg"] != -20.0


def test_keepout_and_faults_refuse_what_every_protocol_refuses(broker, station, clients):
    u = station("dish", broker.url, station_extra="[[keepout]]\nname = \"mast\"\naz_min_deg = 80.0\n"
                "az_max_deg = 100.0\nel_min_deg = 0.0\nel_max_deg = 30.0\n")
    c = clients(broker.port)
    wait_until(lambda: c.last(f"{BASE}/status"), 60, "a status")
    r = c.command(BASE, {"id": "k", "command": "goto", "az_deg": 90.0, "el_deg": 10.0})
    assert r["ok"] is False and "mast" in r["error"], r
    assert u.status()["target_az_deg"] is None, "nothing moved"
    # the same answer as the HTTP API gives
    assert u.post("/api/goto", {"az_deg": 90.0, "el_deg": 10.0}).json()["error"] == r["error"]


def test_bad_payloads_get_errors_and_move_nothing(broker, station, clients):
    u = station("dish", broker.url)
    c = clients(broker.port)
    wait_until(lambda: c.last(f"{BASE}/status"), 60, "a status")
    before = sim_az_deg(u)
    bad = [
        (b"goto 120 30", None, "not a JSON object"),
        (b"[1, 2]", None, "expected a JSON object"),
        (b'{"id": "n", "command": "goto", "az_deg": NaN, "el_deg": 10}', "n", "finite"),
        (b'{"id": "i", "command": "goto", "az_deg": Infinity, "el_deg": 10}', "i", "finite"),
        (b'{"id": "s", "command": "goto", "az_deg": "120", "el_deg": 10}', "s", "az_deg"),
        (b'{"id": "b", "command": "goto", "az_deg": true, "el_deg": 10}', "b", "az_deg"),
        (b'{"id": "r", "command": "goto", "az_deg": 1e9, "el_deg": 10}', "r", "az_deg"),
        (b'{"id": "m", "command": "goto", "el_deg": 10}', "m", "az_deg"),
        (b'{"id": "x", "command": "goto", "az_deg": 10, "el_dge": 10}', "x", "unknown field"),
        (b'{"id": "u", "command": "self_destruct"}', "u", "expected one of"),
        (b'{"id": "nc"}', "nc", "command: missing"),
        (b'{"id": "t", "command": "track", "kind": "satellite"}', "t", "name or norad"),
        (b'{"id": "h", "command": "goto", "az_deg": 10, "el_deg": 10, "pad": "' + b"x" * 100_000 + b'"}',
         None, "at most 4096"),
        (b"\xff\xfe\x00garbage", None, "not a JSON object"),
        (b"", None, "not a JSON object"),
    ]
    for payload, _id, _ in bad:
        c.publish(f"{BASE}/cmd", payload)
    # commands are answered in order: once this one is, every bad one was
    assert c.command(BASE, {"id": "last", "command": "stop"})["ok"]
    results = c.json_on(f"{BASE}/cmd/result")[:-1]
    assert len(results) == len(bad)
    for (payload, cmd_id, says), r in zip(bad, results):
        assert r["ok"] is False and r["id"] == cmd_id and says in r["error"], (payload[:60], r)
    s = u.status()
    assert s["target_az_deg"] is None and not s["moving"] and abs(sim_az_deg(u) - before) < 0.05
    # a retained command would run again at every reconnection: it is never run
    c.publish(f"{BASE}/cmd", json.dumps({"id": "ret", "command": "goto", "az_deg": 50.0, "el_deg": 50.0}),
              retain=True)
    assert c.command(BASE, {"id": "after", "command": "stop"})["ok"]
    r = c.json_on(f"{BASE}/cmd/result")[-2]
    assert r["ok"] is False and "retained" in r["error"]
    assert u.status()["target_az_deg"] is None
    c.publish(f"{BASE}/cmd", b"", retain=True)  # (clear it)
    out = u.stop()
    assert out.count("MQTT command refused") <= 3, "bad input is logged rate-limited"


def test_discovery_off_removes_the_entities(broker, station, clients, tmp_path):
    u = station("dish", broker.url)
    c = clients(broker.port)
    wait_until(lambda: len([m for m in c.messages if m[0].startswith("homeassistant/")]) == 8, 60, "entities")
    u.stop()
    text = u.config.read_text()
    u.config.write_text(text.replace("[mqtt]\n", "[mqtt]\ndiscovery = false\n"))
    u.start(timeout_s=90.0)
    # the client subscribed all along sees each config emptied (retained, empty payload) ...
    wait_until(lambda: len([t for t, p, r in c.messages if t.startswith("homeassistant/") and p == b""]) == 8, 60,
               "the eight configs emptied")
    assert c.on(f"{BASE}/availability")[-1] == b"online"
    # ... and a client that subscribes now gets none of them (the broker dropped them)
    c2 = clients(broker.port)
    wait_until(lambda: c2.last(f"{BASE}/status"), 60, "retained status")
    assert not [t for t, p, r in c2.messages if t.startswith("homeassistant/")]


def test_starts_without_the_broker_and_connects_when_it_comes(tmp_path, station, clients):
    b = Mosquitto(tmp_path / "late-broker")   # not started yet
    u = station("dish", b.url, reconnect_max_s=1.0)   # (an attempt each second: back-off 1 s at most)
    assert u.status()["faults"] == []
    assert u.post("/api/goto", {"az_deg": 20.0, "el_deg": 60.0}).status_code == 200  # runs all the same
    # the first attempts (at 0, 1 and 2 s) fail meanwhile: one line says so, not one per attempt.
    # (A sleep: a refused connection leaves no trace to wait for, and one through a relay that
    # closes it at once fails only after [mqtt] timeout_s: aiomqtt ignores a close before CONNACK.)
    time.sleep(2.5)
    b.start()
    try:
        c = clients(b.port)
        wait_until(lambda: c.on(f"{BASE}/availability") == [b"online"], 60, "connected after the broker came")
        wait_until(lambda: (c.last(f"{BASE}/status") or {}).get("target_az_deg") == 20.0, 60, "its status")
    finally:
        out = u.stop()
        b.stop()
    assert out.count("unreachable or lost") == 1, out


def test_broker_killed_and_restarted_mid_pass(broker, station, clients, tmp_path):
    """Tracking goes on while the broker is away; telemetry resumes when it is back; the
    loss and the return are logged once each."""
    from click.testing import CliRunner

    from urc.cli import main as cli

    where, tle = overhead_station()
    cat = tmp_path / "cat"
    assert CliRunner().invoke(cli, ["tle", "import", str(tle), "--catalog-dir", str(cat)]).exit_code == 0
    u = station("dish", broker.url, station_extra=where + f"[tracking]\ncatalog_dir = '{cat}'\n",
                reconnect_max_s=1.0)   # (an attempt each second while the broker is away)
    c = clients(broker.port)
    wait_until(lambda: c.last(f"{BASE}/status"), 60, "a status")
    assert c.command(BASE, {"id": "trk", "command": "track", "kind": "satellite", "norad": 33591}) == \
        {"id": "trk", "ok": True}
    wait_until(lambda: ((c.last(f"{BASE}/status") or {}).get("tracking") or {}).get("target") == "NOAA 19", 60,
               "tracking NOAA 19, on MQTT")
    events = wait_until(lambda: [e for e in c.json_on(f"{BASE}/event") if e["type"] == "tracking_started"], 60,
                        "a tracking_started event")
    assert events[0]["target"] == "NOAA 19" and events[0]["station"] == "dish"
    c.close()
    broker.kill()
    # (the tracker's first setpoint may come a moment after tracking_started)
    s0 = u.wait(lambda s: s["target_az_deg"] is not None and s["target_el_deg"] is not None, 60)
    target0 = s0["target_az_deg"], s0["target_el_deg"]
    # tracking goes on without the broker: the setpoint follows the satellite
    u.wait(lambda s: s["target_az_deg"] is not None and (abs(s["target_az_deg"] - target0[0]) > 0.5 or
                                                          abs(s["target_el_deg"] - target0[1]) > 0.5), 60)
    time.sleep(2.5)  # (a few reconnection attempts fail meanwhile: one each second; see above)
    restarted = Mosquitto.__new__(Mosquitto)
    restarted.__dict__.update(broker.__dict__)
    restarted.start()  # same port, same configuration; no retained messages survive
    try:
        after = time.time()
        c2 = clients(broker.port)
        s = wait_until(lambda: next((m for m in c2.json_on(f"{BASE}/status") if m["t_unix_s"] > after), None), 60,
                       "a status after the restart")
        assert s["tracking"]["target"] == "NOAA 19" and not s["faults"]
        assert c2.on(f"{BASE}/availability")[-1] == b"online"
        n = len(c2.json_on(f"{BASE}/status"))
        wait_until(lambda: len(c2.json_on(f"{BASE}/status")) > n + 2, 60, "statuses flowing")
        api = u.status()
        assert api["tracking"]["target"] == "NOAA 19" and not api["faults"]
    finally:
        out = u.stop()
        restarted.stop()
    assert out.count("unreachable or lost") == 1 and out.count("reachable again") == 1, out


def test_a_fault_is_seen_everywhere_refuses_motion_and_stop_is_still_accepted(broker, station, clients):
    u = station("dish", broker.url)
    c = clients(broker.port)
    wait_until(lambda: c.last(f"{BASE}/status"), 60, "a status")
    assert u.post("/api/sim/fault", {"axis": "az", "kind": "jam"}).status_code == 200
    assert c.command(BASE, {"id": "g", "command": "goto", "az_deg": 90.0, "el_deg": 45.0})["ok"]
    s = wait_until(lambda: (c.last(f"{BASE}/status") or {}).get("state") == "fault" and c.last(f"{BASE}/status"),
                   60, "the fault on MQTT")
    assert s["faults"] and s["faults"][0]["axis"] == "az"
    ev = wait_until(lambda: [e for e in c.json_on(f"{BASE}/event") if e["type"] == "fault"], 60, "a fault event")
    assert ev[0]["kind"] == s["faults"][0]["kind"] and ev[0]["reason"] == s["faults"][0]["reason"]
    r = c.command(BASE, {"id": "g2", "command": "goto", "az_deg": 10.0, "el_deg": 45.0})
    assert r["ok"] is False and r["reason"] == "fault", r
    assert c.command(BASE, {"id": "st", "command": "stop"}) == {"id": "st", "ok": True}
    assert u.post("/api/sim/clear", {"axis": "az"}).status_code == 200
    assert c.command(BASE, {"id": "cf", "command": "clear_faults"}) == {"id": "cf", "ok": True}
    wait_until(lambda: [e for e in c.json_on(f"{BASE}/event") if e["type"] == "faults_cleared"], 60, "cleared")
    wait_until(lambda: (c.last(f"{BASE}/status") or {}).get("faults") == [], 60, "no faults on MQTT")
