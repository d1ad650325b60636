"""`urc status` without click (issue 19): the entry point answers it with the standard
library alone, and says exactly what click's `urc status` says."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import threading
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

import pytest

from urc_process import URC, free_port
from urc.entry import status_options

#: what the click command runs (the same code, entered through click's group)
CLICK = [sys.executable, "-c", "import sys; sys.argv[0] = 'urc'; from urc.cli import main; main()"]

#: never loaded by `urc status`: the click CLI, the configuration, the controller's
#: event loop and web stack, the tracking package's astronomy, and for a plain http
#: address http.client, whose ssl and email imports were half of its time
HEAVY = ("click", "pydantic", "urc.cli", "urc.config", "asyncio", "fastapi", "starlette", "uvicorn",
         "httpx", "numpy", "skyfield", "urc.tracking", "urc.app", "urc.model", "urc.rotator",
         "urc.link", "urc.procedures", "http.client", "ssl", "email")


class FakeApi(BaseHTTPRequestHandler):
    """Answers GET /api/status with ``body`` and ``code`` (a controller's snapshot, a
    refusal, a page that is not JSON)."""

    body: bytes = b"{}"
    code = 200
    seen: list[tuple[str, str | None]] = []

    def do_GET(self):  # noqa: N802 - http.server's name
        self.seen.append((self.path, self.headers.get("Authorization")))
        self.send_response(self.code)
        self.send_header("Content-Type", "application/json")
        self.send_header("Content-Length", str(len(self.body)))
        self.end_headers()
        self.wfile.write(self.body)

    def log_message(self, *args):
        pass


@pytest.fixture(scope="module")
def snapshot(tmp_path_factory):
    """A real status snapshot (an in-process rotator on the simulator), tracking a
    satellite, with an escape sequence in an event (click strips it when piped)."""
    from conftest import Bench

    b = Bench("tartu-urc", tmp_path_factory.mktemp("state"))
    b.run(0.2)
    s = b.rot.status().as_dict()
    s["events"] = [*s["events"], "a \033[31mred\033[0m event"]
    s["tracking"] = {"target": "ISS (ZARYA)", "state": "tracking", "az_deg": 123.4, "el_deg": 45.6,
                     "warnings": ["elements 3 days old"]}
    return json.loads(json.dumps(s))


@pytest.fixture
def api(snapshot):
    server = ThreadingHTTPServer(("127.0.0.1", 0), FakeApi)
    FakeApi.body, FakeApi.code, FakeApi.seen = json.dumps(snapshot).encode(), 200, []
    threading.Thread(target=server.serve_forever, daemon=True).start()
    yield server.server_address[1]
    server.shutdown()
    server.server_close()


def run(cmd: list[str], *args: str, env: dict | None = None) -> subprocess.CompletedProcess:
    full_env = {k: v for k, v in os.environ.items() if k not in ("URC_URL", "URC_TIMEOUT", "URC_TOKEN")}
    return subprocess.run(cmd + list(args), capture_output=True, text=True, timeout=60, env={**full_env, **(env or {})})


def imported(stderr: str) -> set[str]:
    """The modules ``-X importtime`` reported."""
    return {line.split("|")[-1].strip() for line in stderr.splitlines() if line.startswith("import time:")}


def test_status_imports_nothing_heavy(api, snapshot):
    # (an escape sequence in the text is printed through click, as it strips them: none here)
    FakeApi.body = json.dumps({**snapshot, "events": snapshot["events"][:-1]}).encode()
    res = run([sys.executable, "-X", "importtime", "-m", "urc"], "status", "--port", str(api))
    assert res.returncode == 0, res.stderr
    assert "tracking  ISS (ZARYA)" in res.stdout           # (the tracker's part printed too)
    mods = imported(res.stderr)
    assert {"urc.entry", "urc.api_client", "urc.status_text"} <= mods   # (the report is read right)
    heavy = sorted(m for m in mods if any(m == h or m.startswith(h + ".") for h in HEAVY))
    assert not heavy, f"urc status imported {heavy}"


def test_status_on_a_bare_interpreter_loads_no_typing(api, snapshot):
    """Without site (-S: no .pth hook loading certifi, as on a plain Pi) nothing has
    loaded ``typing`` either; `urc status` must not be the one to (~5 ms)."""
    import urc

    FakeApi.body = json.dumps({**snapshot, "events": []}).encode()
    src = os.path.dirname(os.path.dirname(urc.__file__))
    res = run([sys.executable, "-S", "-X", "importtime", "-m", "urc"], "status", "--port", str(api),
              env={"PYTHONPATH": src})
    assert res.returncode == 0 and "pointing  az" in res.stdout, res.stderr
    mods = imported(res.stderr)
    assert "urc.status_text" in mods and not mods & {"typing", *HEAVY}


def test_any_other_command_line_still_goes_to_click(api):
    res = run([sys.executable, "-X", "importtime", "-m", "urc"], "status", "--config", "/nonexistent/urc.toml")
    assert "click" in imported(res.stderr) and res.returncode != 0


@pytest.mark.parametrize("args, env", [
    ((), {}),
    (("--json",), {}),
    (("--timeout", "7.5", "--json"), {}),
    (("--timeout=0.5",), {"URC_TOKEN": "s3cret"}),
    ((), {"URC_TIMEOUT": "9"}),
])
def test_the_short_way_prints_what_click_prints(api, args, env):
    for address in (("--port", str(api)), (f"--url=http://127.0.0.1:{api}/",)):
        FakeApi.seen = []
        fast = run(URC, "status", *address, *args, env=env)
        slow = run(CLICK, "status", *address, *args, env=env)
        assert (fast.returncode, fast.stdout, fast.stderr) == (slow.returncode, slow.stdout, slow.stderr)
        assert fast.returncode == 0 and "\033" not in fast.stdout
        if "--json" in args:
            assert json.loads(fast.stdout)["tracking"]["target"] == "ISS (ZARYA)"
        else:
            assert "pointing  az" in fast.stdout and "a red event" in fast.stdout
        assert FakeApi.seen == [("/api/status", f"Bearer {env['URC_TOKEN']}" if "URC_TOKEN" in env else None)] * 2


def test_the_address_from_the_environment(api):
    env = {"URC_URL": f"http://127.0.0.1:{api}"}
    fast, slow = run(URC, "status", env=env), run(CLICK, "status", env=env)
    assert fast.returncode == 0 and (fast.stdout, fast.stderr) == (slow.stdout, slow.stderr)


@pytest.mark.parametrize("code, body, said", [
    (401, b'{"detail": "a token is needed"}', "Error: refused (401): a token is needed"),
    (500, b"<html>oops</html>", "Error: refused (500): <html>oops</html>"),
])
def test_refusals_say_what_click_says(api, code, body, said):
    FakeApi.code, FakeApi.body = code, body
    fast, slow = run(URC, "status", "--port", str(api)), run(CLICK, "status", "--port", str(api))
    assert (fast.returncode, fast.stdout, fast.stderr) == (slow.returncode, slow.stdout, slow.stderr)
    assert fast.returncode == 1 and fast.stderr.strip() == said


def test_unreachable_says_what_click_says():
    port = str(free_port())
    fast, slow = run(URC, "status", "--port", port), run(CLICK, "status", "--port", port)
    assert (fast.returncode, fast.stdout, fast.stderr) == (slow.returncode, slow.stdout, slow.stderr)
    assert fast.returncode == 1 and fast.stderr.startswith(f"Error: cannot reach urc at http://127.0.0.1:{port}:")


@pytest.mark.parametrize("args, env, expected", [
    (["--port", "8081"], {}, ("http://127.0.0.1:8081", False, 60.0)),
    (["--json", "--port=80", "--timeout", "2"], {}, ("http://127.0.0.1:80", True, 2.0)),
    (["--url", "http://rot:9000"], {}, ("http://rot:9000", False, 60.0)),
    ([], {}, ("http://127.0.0.1:8080", False, 60.0)),
    ([], {"URC_URL": "http://pi:8080", "URC_TIMEOUT": "3"}, ("http://pi:8080", False, 3.0)),
    ([], {"URC_URL": ""}, ("http://127.0.0.1:8080", False, 60.0)),     # click ignores an empty one
    (["--timeout", "1"], {"URC_TIMEOUT": "3"}, ("http://127.0.0.1:8080", False, 1.0)),
    # everything else is click's to read (its help, its errors, the configuration)
    (["--help"], {}, None),
    (["--config", "urc.toml"], {}, None),
    (["--port", "0"], {}, None),
    (["--port", "http"], {}, None),
    (["--port", "1", "--port", "2"], {}, None),
    (["--port", "1", "--url", "http://x"], {}, None),
    (["--port", "1"], {"URC_URL": "http://x"}, None),
    (["--json", "--json"], {}, None),
    (["--json=1"], {}, None),
    (["--url"], {}, None),
    (["--url", "--json"], {}, None),
    (["--timeout", "0.05"], {}, None),
    (["--timeout", "inf"], {}, None),
    (["--timeout", "nan"], {}, None),
    ([], {"URC_TIMEOUT": "soon"}, None),
    (["extra"], {}, None),
    (["--"], {}, None),
    ([], {"_URC_COMPLETE": "bash_complete"}, None),
])
def test_which_command_lines_take_the_short_way(args, env, expected):
    assert status_options(args, env) == expected


def test_an_ipv6_api_host_from_the_configuration(snapshot, tmp_path):
    """``[api] host = "::1"``: the client's address is http://[::1]:port (it was built
    without brackets, and reading its port raised ValueError)."""
    import socket

    class Server6(ThreadingHTTPServer):
        address_family = socket.AF_INET6

    try:
        server = Server6(("::1", 0), FakeApi)
    except OSError as exc:
        pytest.skip(f"no IPv6 loopback: {exc}")
    FakeApi.body, FakeApi.code, FakeApi.seen = json.dumps(snapshot).encode(), 200, []
    threading.Thread(target=server.serve_forever, daemon=True).start()
    try:
        cfg = tmp_path / "urc.toml"
        cfg.write_text(f'[api]\nhost = "::1"\nport = {server.server_address[1]}\n')
        res = run(URC, "status", "--config", str(cfg))
        assert res.returncode == 0 and "pointing  az" in res.stdout, res.stderr
        assert FakeApi.seen == [("/api/status", None)]
    finally:
        server.shutdown()
        server.server_close()
