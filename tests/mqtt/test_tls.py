"""mqtts://: urc verifies the broker against ca_file and presents its client certificate;
without the certificate the broker refuses it (logged once) and urc runs on."""

from __future__ import annotations

import time

import pytest
from urc_process import wait_until

from .broker import Mosquitto, Pki


@pytest.fixture
def pki(tmp_path):
    return Pki(tmp_path / "pki")


@pytest.fixture
def tls_broker(tmp_path, pki):
    b = Mosquitto(tmp_path / "tls-broker", tls=pki).start()
    yield b
    b.stop()


def test_tls_with_a_client_certificate(tls_broker, pki, station, clients):
    assert tls_broker.url.startswith("mqtts://")
    station("dish", tls_broker.url, ca_file=str(pki.ca), cert_file=str(pki.client_cert), key_file=str(pki.client_key))
    c = clients(tls_broker.port, tls=pki)
    wait_until(lambda: c.on("urc/dish/availability") == [b"online"] and c.last("urc/dish/status"), 60,
               "the station over TLS")
    assert c.command("urc/dish", {"id": "t", "command": "goto", "az_deg": 45.0, "el_deg": 45.0}) == {"id": "t", "ok": True}


def test_tls_without_a_client_certificate_is_refused(tls_broker, pki, station):
    u = station("dish", tls_broker.url, ca_file=str(pki.ca))
    assert u.post("/api/goto", {"az_deg": 15.0, "el_deg": 80.0}).status_code == 200
    # (TLS 1.3: the broker's refusal comes after the handshake; the attempt ends when
    # aiomqtt's connect timeout (10 s) expires: let two attempts fail)
    time.sleep(25.0)
    u.wait(lambda s: s["target_az_deg"] == 15.0 and not s["faults"], 60)
    out = u.stop()
    assert out.count("unreachable or lost") == 1 and "certificate required" not in out, out


def test_tls_refuses_a_broker_it_cannot_verify(tls_broker, pki, station):
    """No ca_file: the system's CAs do not know the test CA: no connection."""
    u = station("dish", tls_broker.url, cert_file=str(pki.client_cert), key_file=str(pki.client_key))
    out = u.stop()
    assert out.count("unreachable or lost") == 1 and "certificate verify failed" in out, out
