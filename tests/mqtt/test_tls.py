"""mqtts://: urc verifies the broker against ca_file and presents its client certificate;
without the certificate the broker refuses it (logged once) and urc runs on."""

from __future__ import annotations

import asyncio
import socket
import threading

import pytest
from urc_process import wait_until

from .broker import Mosquitto, Pki


@pytest.fixture(scope="module")
def pki(tmp_path_factory):
    """(One CA and its certificates for the module; every test's broker is its own.)"""
    return Pki(tmp_path_factory.mktemp("pki"))


class Relay:
    """A TCP relay to ``port`` that counts the connections made through it: each is one
    connection attempt of urc's MQTT client (the broker does not log a TLS refusal)."""

    def __init__(self, port: int):
        self.port_to = port
        self.listener = socket.create_server(("127.0.0.1", 0))
        self.port = self.listener.getsockname()[1]
        self.accepted = 0
        threading.Thread(target=self._accept, daemon=True).start()

    def _accept(self) -> None:
        while True:
            try:
                conn, _ = self.listener.accept()
            except OSError:
                return
            self.accepted += 1
            try:
                upstream = socket.create_connection(("127.0.0.1", self.port_to), timeout=5)
            except OSError:
                conn.close()
                continue
            upstream.settimeout(None)
            for a, b in ((conn, upstream), (upstream, conn)):
                threading.Thread(target=self._pump, args=(a, b), daemon=True).start()

    @staticmethod
    def _pump(src: socket.socket, dst: socket.socket) -> None:
        try:
            while data := src.recv(65536):
                dst.sendall(data)
        except OSError:
            pass
        for s in (src, dst):   # one side closed: so does the other
            try:
                s.shutdown(socket.SHUT_RDWR)
            except OSError:
                pass

    def close(self) -> None:
        self.listener.close()


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
    assert c.command("urc/dish", {"id": "t", "command": "goto", "az_deg": 45.0, "el_deg": 45.0}) == \
        {"id": "t", "ok": True, "state": "accepted"}


def test_tls_without_a_client_certificate_is_refused(tls_broker, pki, station):
    relay = Relay(tls_broker.port)   # (the server certificate is for 127.0.0.1: so is the relay)
    try:
        # (TLS 1.3: the broker's refusal comes after the handshake; the attempt ends when
        # the client's timeout ([mqtt] timeout_s, 10 s by default) expires; the next one
        # comes after a back-off of at most reconnect_max_s)
        u = station("dish", f"mqtts://127.0.0.1:{relay.port}", ca_file=str(pki.ca), timeout_s=1.0,
                    reconnect_max_s=1.0)
        assert u.post("/api/goto", {"az_deg": 15.0, "el_deg": 80.0}).status_code == 200
        # let two attempts fail: a third connection comes only after the second one failed
        wait_until(lambda: relay.accepted >= 3, 90, "a third connection attempt")
        u.wait(lambda s: s["target_az_deg"] == 15.0 and not s["faults"], 60)
        out = u.stop()
    finally:
        relay.close()
    assert out.count("unreachable or lost") == 1 and "certificate required" not in out, out


def test_tls_refuses_a_broker_it_cannot_verify(tls_broker, pki, station):
    """No ca_file: the system's CAs do not know the test CA: no connection."""
    u = station("dish", tls_broker.url, cert_file=str(pki.client_cert), key_file=str(pki.client_key))
    out = u.stop()
    assert out.count("unreachable or lost") == 1 and "certificate verify failed" in out, out


def test_the_broker_timeout_is_a_setting():
    """[mqtt] timeout_s reaches the client (its timeout for every answer from the broker)."""
    from urc.config import loads_config
    from urc.errors import ConfigError
    from urc.mqtt.service import MqttService

    async def client_timeout(text: str) -> float:   # (an aiomqtt client needs a running loop)
        section = loads_config(text).mqtt
        return MqttService(section, "urc/x", "x", status=dict, handler=None)._client().timeout

    assert asyncio.run(client_timeout("[mqtt]\n")) == 10.0
    assert asyncio.run(client_timeout("[mqtt]\ntimeout_s = 2.5\n")) == 2.5
    for bad in ("0", "-1", "nan", "1000"):
        with pytest.raises(ConfigError, match="mqtt.timeout_s: expected"):
            loads_config(f"[mqtt]\ntimeout_s = {bad}\n", source="site.toml")
