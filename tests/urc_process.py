"""Start a real ``urc run`` process for tests and benchmarks, and talk to its API."""

from __future__ import annotations

import json
import socket
import subprocess
import sys
import time
from pathlib import Path

import httpx

URC = [sys.executable, "-m", "urc"]


def free_port(kind: int = socket.SOCK_STREAM) -> int:
    with socket.socket(socket.AF_INET, kind) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def toml_serve(entries: list[dict]) -> str:
    """[[serve]] tables for a config file (empty list: serve nothing)."""
    if not entries:
        return "serve = []\n"
    out = []
    for e in entries:
        out.append("[[serve]]")
        for k, v in e.items():
            out.append(f"{k} = {json.dumps(v)}" if not isinstance(v, dict) else
                       f"{k} = {{ " + ", ".join(f"{a} = {json.dumps(b)}" for a, b in v.items()) + " }")
    return "\n".join(out) + "\n"


def wait_until(pred, timeout_s: float = 30.0, what: str = "condition", poll_s: float = 0.05):
    """Poll ``pred`` until it returns something true (returned), or fail after ``timeout_s``."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        got = pred()
        if got:
            return got
        time.sleep(poll_s)
    raise AssertionError(f"not within {timeout_s} s: {what}")


class UrcProcess:
    def __init__(self, workdir: Path, profile: str = "tartu-urc", serve: list[dict] | None = None,
                 extra: str = "", port: int | None = None):
        self.workdir = workdir
        self.port = port or free_port()
        self.state_dir = workdir / "state"
        self.config = workdir / "urc.toml"
        serve_text = toml_serve(serve or [])
        top, tables = (serve_text, "") if not serve else ("", serve_text)
        self.config.write_text(f'{top}[rotator]\nprofile = "{profile}"\n[hardware.sim]\nwind = false\n'
                               f'[api]\nport = {self.port}\n{extra}{tables}')
        self.url = f"http://127.0.0.1:{self.port}"
        self.proc: subprocess.Popen | None = None
        self.banner = ""

    def start(self, timeout_s: float = 30.0) -> "UrcProcess":
        self.proc = subprocess.Popen(URC + ["run", "--config", str(self.config), "--state-dir", str(self.state_dir)],
                                     stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            if self.proc.poll() is not None:
                raise AssertionError(f"urc run exited: {self.proc.stdout.read()}")
            try:
                httpx.get(self.url + "/api/status", timeout=0.5)
                return self
            except httpx.HTTPError:
                time.sleep(0.1)
        raise AssertionError("urc run did not start listening")

    def control_pid(self) -> int:
        """The pid of this urc's control process (the loop, the rotator, the hardware)."""
        assert self.proc is not None
        for pid in Path(f"/proc/{self.proc.pid}/task/{self.proc.pid}/children").read_text().split():
            try:
                if b"urc.service.control_process" in Path(f"/proc/{pid}/cmdline").read_bytes():
                    return int(pid)
            except FileNotFoundError:
                pass
        raise AssertionError("no control process found")

    def status(self) -> dict:
        return httpx.get(self.url + "/api/status", timeout=5).json()

    def post(self, path: str, body: dict | None = None) -> httpx.Response:
        return httpx.post(self.url + path, json=body, timeout=5)

    def wait(self, pred, timeout_s: float = 60.0) -> dict:
        deadline = time.monotonic() + timeout_s
        s = self.status()
        while time.monotonic() < deadline:
            s = self.status()
            if pred(s):
                return s
            time.sleep(0.1)
        raise AssertionError(f"condition not met within {timeout_s} s; last status {s}")

    def stop(self) -> str:
        if self.proc is None or self.proc.poll() is not None:
            return ""
        self.proc.terminate()
        try:
            out, _ = self.proc.communicate(timeout=20)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            out, _ = self.proc.communicate()
        return out
