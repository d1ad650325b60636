"""Client commands against a slow controller (issue 21): `urc track` gave up after a
fixed 5 s and said "cannot reach urc ... is `urc run` running?" while urc was tracking."""

from __future__ import annotations

import json
import subprocess
import threading
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

import pytest

from urc_process import URC

#: longer than the 5 s the client used to wait (the answer is held back this long after
#: the request came, so a client that gives up after 5 s surely does). `urc track` makes
#: two requests through the same client: the first (its POST) is held back, the status
#: read after it is answered at once
SLOW_S = 5.5


class SlowApi(BaseHTTPRequestHandler):
    """Answers like urc's API, its commands only after ``delay_s`` (a loaded controller)."""

    delay_s = SLOW_S
    released = threading.Event()

    def _answer(self, body: dict, delay_s: float = 0.0) -> None:
        self.released.wait(delay_s)
        data = json.dumps(body).encode()
        self.send_response(200)
        self.send_header("Content-Type", "application/json")
        self.send_header("Content-Length", str(len(data)))
        self.end_headers()
        self.wfile.write(data)

    def do_POST(self):  # noqa: N802 - http.server's name
        self.rfile.read(int(self.headers.get("Content-Length") or 0))
        self._answer({"ok": True}, self.delay_s)

    def do_GET(self):  # noqa: N802
        self._answer({"tracking": {"target": "ISS (ZARYA)", "az_deg": 10.0, "el_deg": 20.0}})

    def log_message(self, *args):
        pass


@pytest.fixture
def slow_api():
    server = ThreadingHTTPServer(("127.0.0.1", 0), SlowApi)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    yield f"http://127.0.0.1:{server.server_address[1]}"
    SlowApi.released.set()
    server.shutdown()
    server.server_close()
    SlowApi.released.clear()


def test_track_waits_for_a_slow_controller(slow_api):
    r = subprocess.run(URC + ["track", "ISS", "--url", slow_api], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    assert "tracking  ISS (ZARYA)" in r.stdout


def test_no_answer_in_time_is_not_called_unreachable(slow_api):
    r = subprocess.run(URC + ["track", "ISS", "--url", slow_api, "--timeout", "0.5"],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 1
    assert "gave no answer within 0.5 s" in r.stderr and "urc status" in r.stderr
    assert "cannot reach" not in r.stderr
