"""`urc fleet` against three real stations on one real broker."""

from __future__ import annotations

import json
import subprocess

from urc_process import URC, wait_until

from urc.mqtt.fleet import Fleet, plain_table


def fleet(url: str, *args: str, timeout_s: float = 60.0) -> subprocess.CompletedProcess:
    return subprocess.run(URC + ["fleet", "--mqtt", url, *args], capture_output=True, text=True, timeout=timeout_s)


def test_three_stations_listed_and_commanded(broker, station, clients):
    names = ["yagi", "dish", "hf beam"]
    stations = {n: station(n, broker.url) for n in names}
    watch = clients(broker.port)
    wait_until(lambda: all(watch.last(f"urc/{k}/status") for k in ("yagi", "dish", "hf-beam")), 60, "three statuses")

    res = fleet(broker.url, "--once", "--wait-s", "1")
    assert res.returncode == 0, res.stderr
    lines = res.stdout.splitlines()
    assert lines[0].split()[:4] == ["STATION", "ONLINE", "AZ", "EL"]
    rows = {line.split("  ")[0].strip(): line for line in lines[1:]}
    assert sorted(rows) == ["dish", "hf beam", "yagi"], res.stdout
    assert all(" online " in row and " idle " in row for row in rows.values()), res.stdout

    # a command to one station: it moves, the others do not
    res = fleet(broker.url, "goto", "dish", "200", "20")
    assert res.returncode == 0 and "urc/dish: goto accepted" in res.stdout, res.stdout + res.stderr
    stations["dish"].wait(lambda s: s["moving"], 60)
    assert stations["yagi"].status()["target_az_deg"] is None
    res = fleet(broker.url, "stop", "dish")
    assert res.returncode == 0 and "stop accepted" in res.stdout, res.stdout + res.stderr
    stations["dish"].wait(lambda s: not s["moving"], 60)
    # refused by the gate: the reason, exit status 1
    res = fleet(broker.url, "goto", "yagi", "--", "10", "-40")
    assert res.returncode == 1 and "refused" in res.stderr, res.stdout + res.stderr

    # the JSON form, and a station that went away is shown offline and refuses commands
    stations["hf beam"].stop()
    got = json.loads(fleet(broker.url, "--once", "--wait-s", "1", "--json").stdout)
    assert got["hf-beam"]["online"] is False and got["dish"]["online"] is True
    assert got["dish"]["status"]["station"] == "dish" and got["dish"]["status"]["state"] == "idle"
    res = fleet(broker.url, "park", "hf beam")
    assert res.returncode == 1 and "offline" in res.stderr, res.stdout + res.stderr


def test_fleet_without_a_broker_says_so(tmp_path):
    from urc_process import free_port

    res = fleet(f"mqtt://127.0.0.1:{free_port()}", "--once")
    assert res.returncode == 1 and "MQTT broker" in res.stderr, res.stderr
    res = fleet("http://example", "--once")
    assert res.returncode == 2 and "mqtt://" in res.stderr


def test_fleet_table_from_messages():
    f = Fleet("urc")
    f.feed("urc/a/availability", b"online")
    f.feed("urc/a/status", json.dumps({"station": "A", "t_unix_s": 100.0, "az_deg": 12.345, "el_deg": None,
                                       "state": "fault", "faults": [{"kind": "stall", "reason": "az stalled"}],
                                       "tracking": {"target": "ISS"},
                                       "next_pass": {"aos": "2026-01-01T10:00:00+00:00"}}).encode())
    f.feed("urc/b/status", b"not json")
    f.feed("other/c/status", b"{}")
    f.feed("urc/a/b/status", b"{}")
    rows = f.rows(now_unix_s=103.0)
    assert len(rows) == 2  # (b: seen, nothing readable yet)
    a = rows[0]
    assert (a["station"], a["online"], a["az"], a["el"], a["state"], a["faults"], a["tracking"], a["next pass"],
            a["age"]) == ("A", "online", "12.3", "-", "fault", "stall: az stalled", "ISS", "2026-01-01 10:00:00", "3 s")
    assert rows[1]["online"] == "?"
    text = plain_table(rows)
    assert text.splitlines()[1].startswith("A ") and "stall: az stalled" in text


def test_a_window_keeps_the_messages_that_arrived_in_it(broker, clients):
    """`urc fleet --once` gathers for --wait-s: what the broker sent within it is shown,
    read or not when the time is up (it dropped those still queued)."""
    import asyncio
    import time

    from urc.mqtt.config import parse_url
    from urc.mqtt.fleet import watch

    pub = clients(broker.port)
    names = [f"st{i}" for i in range(6)]
    for n in names:
        pub.publish(f"urc/{n}/availability", "online", retain=True)   # (waits for the PUBACK)
    fleet_ = Fleet("urc")
    calls = []

    def slow_change() -> None:
        calls.append(1)
        if len(calls) == 1:
            time.sleep(0.5)   # the event loop held past the window: the rest wait in the queue

    asyncio.run(watch(parse_url(broker.url), fleet_, slow_change, seconds=0.2))
    assert sorted(fleet_.stations) == names, sorted(fleet_.stations)
