"""A real Mosquitto on a free loopback port, and a real paho client, for the MQTT tests
and bench/mqtt_bench.py."""

from __future__ import annotations

import json
import os
import queue
import shutil
import subprocess
import threading
import time
import uuid
from pathlib import Path

import paho.mqtt.client as paho
from urc_process import free_port, wait_until

MOSQUITTO = shutil.which("mosquitto") or "/usr/sbin/mosquitto"


class Mosquitto:
    """``users``: name -> password; with them a password file and ``acl`` (the text of an
    ACL file) are written and anonymous clients are refused."""

    def __init__(self, workdir: Path, users: dict[str, str] | None = None, acl: str = "",
                 tls: Pki | None = None):
        self.workdir = workdir
        workdir.mkdir(parents=True, exist_ok=True)
        self.port = free_port()
        self.url = f"{'mqtts' if tls else 'mqtt'}://127.0.0.1:{self.port}"
        lines = [f"listener {self.port} 127.0.0.1", "persistence false", "log_dest stdout",
                 "log_type error", "log_type warning"]
        if tls is not None:  # TLS, and only clients with a certificate from our CA
            lines += [f"cafile {tls.ca}", f"certfile {tls.server_cert}", f"keyfile {tls.server_key}",
                      "require_certificate true"]
        if os.geteuid() == 0:  # (as root it would become user mosquitto: unable to read our files)
            lines.append("user root")
        if users:
            pw = workdir / "passwd"
            pw.write_text("")
            for name, password in users.items():
                subprocess.run(["mosquitto_passwd", "-b", str(pw), name, password], check=True,
                               capture_output=True)
            pw.chmod(0o600)
            lines += ["allow_anonymous false", f"password_file {pw}"]
        else:
            lines.append("allow_anonymous true")
        if acl:
            (workdir / "acl").write_text(acl)
            (workdir / "acl").chmod(0o600)
            lines.append(f"acl_file {workdir / 'acl'}")
        self.conf = workdir / "mosquitto.conf"
        self.conf.write_text("\n".join(lines) + "\n")
        self.proc: subprocess.Popen | None = None

    def start(self) -> Mosquitto:
        self.proc = subprocess.Popen([MOSQUITTO, "-c", str(self.conf)], stdout=subprocess.PIPE,
                                     stderr=subprocess.STDOUT, text=True)
        import socket

        def listening() -> bool:
            if self.proc.poll() is not None:
                raise AssertionError(f"mosquitto exited: {self.proc.stdout.read()}")
            with socket.socket() as s:
                return s.connect_ex(("127.0.0.1", self.port)) == 0
        wait_until(listening, 20.0, "mosquitto listening")
        return self

    def kill(self) -> None:
        if self.proc is not None and self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait()

    def stop(self) -> None:
        self.kill()


#: the keys' type: P-256 EC keys (openssl makes one in ~10 ms; an RSA 2048 one took 0.3-1 s)
KEY = ("-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1")


class Pki:
    """A throwaway CA (openssl) with a server certificate for 127.0.0.1 and a client one."""

    def __init__(self, workdir: Path):
        workdir.mkdir(parents=True, exist_ok=True)
        self.ca, ca_key = workdir / "ca.pem", workdir / "ca.key"
        self._openssl("req", "-x509", *KEY, "-nodes", "-days", "2", "-subj", "/CN=urc test CA",
                      "-keyout", ca_key, "-out", self.ca)
        self.server_cert, self.server_key = self._issue(workdir, "server", ca_key, "subjectAltName=IP:127.0.0.1")
        self.client_cert, self.client_key = self._issue(workdir, "client", ca_key, "extendedKeyUsage=clientAuth")

    def _issue(self, workdir: Path, name: str, ca_key: Path, ext: str) -> tuple[Path, Path]:
        key, csr, cert = workdir / f"{name}.key", workdir / f"{name}.csr", workdir / f"{name}.pem"
        self._openssl("req", *KEY, "-nodes", "-subj", f"/CN={name}", "-keyout", key, "-out", csr)
        (workdir / f"{name}.ext").write_text(ext + "\n")
        self._openssl("x509", "-req", "-in", csr, "-CA", self.ca, "-CAkey", ca_key, "-CAcreateserial",
                      "-days", "2", "-extfile", workdir / f"{name}.ext", "-out", cert)
        return cert, key

    @staticmethod
    def _openssl(*args) -> None:
        subprocess.run(["openssl", *map(str, args)], check=True, capture_output=True)


class Client:
    """A paho client that records every message it receives (topic -> payloads)."""

    def __init__(self, port: int, username: str | None = None, password: str | None = None,
                 subscribe: tuple[str, ...] = ("#",), tls: Pki | None = None):
        # (no reconnecting: a refused or lost client's network thread ends at once, so close()
        # does not wait out paho's reconnection delay)
        self.c = paho.Client(paho.CallbackAPIVersion.VERSION2, client_id=f"test-{uuid.uuid4().hex[:8]}",
                             protocol=paho.MQTTv5, reconnect_on_failure=False)
        if tls is not None:
            self.c.tls_set(ca_certs=str(tls.ca), certfile=str(tls.client_cert), keyfile=str(tls.client_key))
        if username:
            self.c.username_pw_set(username, password)
        self.lock = threading.Lock()
        self.messages: list[tuple[str, bytes, bool]] = []
        self.connack = queue.Queue()
        self.acks: dict[int, object] = {}
        self.c.on_message = self._on_message
        self.c.on_connect = lambda c, u, f, rc, p: self.connack.put(rc)
        self.c.on_publish = self._on_publish
        self.subscribe_to = subscribe
        self.c.connect("127.0.0.1", port, keepalive=30)
        self.c.loop_start()
        self.rc = self.connack.get(timeout=10)
        if not self.rc.is_failure:
            for t in subscribe:
                self.c.subscribe(t, qos=1)

    def _on_message(self, _c, _u, msg) -> None:
        with self.lock:
            self.messages.append((msg.topic, msg.payload, bool(msg.retain)))

    def _on_publish(self, _c, _u, mid, reason_code, _props) -> None:
        with self.lock:
            self.acks[mid] = reason_code

    def publish(self, topic: str, payload: str | bytes, qos: int = 1, retain: bool = False):
        """Publish and wait for the broker's acknowledgement; returns its reason code."""
        info = self.c.publish(topic, payload, qos=qos, retain=retain)
        if qos == 0:
            return None
        wait_until(lambda: info.mid in self.acks, 10.0, "the broker's PUBACK")
        return self.acks[info.mid]

    def on(self, topic: str) -> list[bytes]:
        with self.lock:
            return [p for t, p, _r in self.messages if t == topic]

    def json_on(self, topic: str) -> list[dict]:
        return [json.loads(p) for p in self.on(topic) if p]

    def last(self, topic: str) -> dict | None:
        got = self.json_on(topic)
        return got[-1] if got else None

    def result(self, base: str, cmd_id, timeout_s: float = 60.0) -> dict:
        return wait_until(lambda: next((r for r in self.json_on(f"{base}/cmd/result") if r.get("id") == cmd_id),
                                       None), timeout_s, f"result of command {cmd_id!r}")

    def outcome(self, base: str, cmd_id, timeout_s: float = 60.0) -> dict:
        """The second result of a goto or park: how it ended (urc.mqtt.outcomes)."""
        return wait_until(lambda: next((r for r in self.json_on(f"{base}/cmd/result")
                                        if r.get("id") == cmd_id and r.get("state") not in (None, "accepted")),
                                       None), timeout_s, f"the end of command {cmd_id!r}")

    def command(self, base: str, doc: dict, timeout_s: float = 60.0) -> dict:
        self.publish(f"{base}/cmd", json.dumps(doc))
        return self.result(base, doc.get("id"), timeout_s)

    def close(self) -> None:
        # DISCONNECT first: it wakes the network thread, which then ends (stopped first, it
        # would end only when its wait for the socket times out, up to 1 s)
        self.c.disconnect()
        self.c.loop_stop()


def overhead_station() -> tuple[str, Path]:
    """[station] lines for a station 4 deg off NOAA 19's ground track 40 s from now (the
    satellite is high for the next minutes), and the test element sets' file (NORAD 33591)."""
    from skyfield.api import EarthSatellite, wgs84

    from urc.tracking import sky
    from urc.tracking.elements import load_elements

    fixtures = Path(__file__).resolve().parents[1] / "tracking" / "fixtures"
    noaa = next(s for s in load_elements(fixtures / "leo.tle") if s.norad_id == 33591)
    ts = sky.timescale()
    sub = wgs84.subpoint_of(EarthSatellite.from_satrec(noaa.satrec, ts).at(
        ts.from_datetime(sky.utc_datetime(time.time() + 40.0))))
    lat = float(sub.latitude.degrees) + (4.0 if sub.latitude.degrees < 80.0 else -4.0)
    return f"lat_deg = {lat}\nlon_deg = {float(sub.longitude.degrees)}\n", fixtures / "leo.tle"
