"""A broker with a password file and an ACL: urc logs in as its own user; clients with
no or the wrong password are refused at CONNECT; a client allowed to read but not to
command is refused by the broker (MQTT 5 PUBACK "not authorized") and nothing moves."""

from __future__ import annotations

import json

import pytest
from urc_process import wait_until

from .broker import Client, Mosquitto

BASE = "urc/dish"
USERS = {"dish": "dish-secret", "operator": "op-secret", "viewer": "view-secret"}
ACL = """\
user dish
topic readwrite urc/dish/#
topic readwrite homeassistant/#

user operator
topic readwrite urc/#

user viewer
topic read urc/#
"""
NOT_AUTHORIZED = 135   # MQTT 5 reason code 0x87


@pytest.fixture
def secured(tmp_path):
    b = Mosquitto(tmp_path / "secured", users=USERS, acl=ACL).start()
    yield b
    b.stop()


def test_acl_refuses_unauthorised_clients(secured, station, clients):
    u = station("dish", secured.url, username="dish", password=USERS["dish"])
    op = clients(secured.port, username="operator", password=USERS["operator"])
    wait_until(lambda: op.on(f"{BASE}/availability") == [b"online"] and op.last(f"{BASE}/status"), 60,
               "the station logged in and publishing")

    for user, password in ((None, None), ("viewer", "wrong"), ("nobody", "x")):
        c = Client(secured.port, username=user, password=password)
        try:
            assert c.rc.is_failure, (user, c.rc)
        finally:
            c.close()

    viewer = clients(secured.port, username="viewer", password=USERS["viewer"])
    assert not viewer.rc.is_failure
    wait_until(lambda: viewer.last(f"{BASE}/status"), 60, "the viewer reads the status")
    rc = viewer.publish(f"{BASE}/cmd", json.dumps({"id": "intruder", "command": "goto", "az_deg": 200.0,
                                                   "el_deg": 10.0}))
    assert rc == NOT_AUTHORIZED, rc
    # the operator's command, sent after, is answered; the viewer's never was
    assert op.command(BASE, {"id": "op", "command": "goto", "az_deg": 30.0, "el_deg": 45.0}) == \
        {"id": "op", "ok": True, "state": "accepted"}
    assert [r["id"] for r in op.json_on(f"{BASE}/cmd/result")] == ["op"]
    assert u.status()["target_az_deg"] == 30.0


def test_wrong_station_password_is_one_logged_refusal_and_urc_runs_on(secured, station):
    u = station("dish", secured.url, username="dish", password="not-it")
    assert u.post("/api/goto", {"az_deg": 15.0, "el_deg": 80.0}).status_code == 200
    u.wait(lambda s: s["target_az_deg"] == 15.0, 60)
    wait_until(lambda: u.proc.poll() is None and u.status(), 5, "still running")
    out = u.stop()
    assert out.count("unreachable or lost") == 1 and ("authori" in out.lower() or "password" in out.lower()), out
