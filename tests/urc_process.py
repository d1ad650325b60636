"""Start a real ``urc run`` process for tests and benchmarks, and talk to its API."""

from __future__ import annotations

import json
import os
import signal
import re
import socket
import subprocess
import sys
import time
from pathlib import Path

import httpx

URC = [sys.executable, "-m", "urc"]

# Every process the suite starts inherits this variable (set per pytest process by
# conftest.py), so the leak check can find a ``urc`` process however it was started.
SUITE_MARK = "URC_TEST_SUITE_RUN"

# start-up waits end when the port answers; the bound is for a machine under heavy load
START_TIMEOUT_S = 120.0

#: The client every request to a test's urc goes through. ``httpx.get()`` builds a client
#: per call, and with it a TLS context from certifi's CA bundle: ~40 ms of CPU for each
#: plain-http status (2 ms through this one), so a test polling at 10 Hz kept 40 % of a
#: core busy. No keep-alive: each request is a connection of its own, as with httpx.get
#: (a kept one would count against urc's connection cap, and outlive a killed urc).
HTTP = httpx.Client(timeout=5.0, limits=httpx.Limits(max_keepalive_connections=0))


def _is_urc(cmdline: list[bytes]) -> bool:
    """``python -m urc ...``, the ``urc`` script, or a control process."""
    if any(a == b"urc.control_entry" for a in cmdline):
        return True
    if any(a == b"-m" and b == b"urc" for a, b in zip(cmdline, cmdline[1:])):
        return True
    return any(a.endswith(b"/urc") for a in cmdline[:2])


def suite_urc_processes(mark: str) -> list[tuple[int, str]]:
    """(pid, command line) of every live ``urc`` process whose environment carries
    ``SUITE_MARK=mark``."""
    needle = f"{SUITE_MARK}={mark}".encode()
    found = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit() or int(entry.name) == os.getpid():
            continue
        try:
            if needle not in (entry / "environ").read_bytes().split(b"\0"):
                continue
            cmdline = (entry / "cmdline").read_bytes().split(b"\0")
            state = (entry / "stat").read_text().rsplit(")", 1)[1].split()[0]
        except (FileNotFoundError, ProcessLookupError, PermissionError):
            continue
        if state != "Z" and _is_urc(cmdline):
            found.append((int(entry.name), b" ".join(cmdline).decode(errors="replace").strip()))
    return found


def reap_leaked(mark: str, grace_s: float) -> list[str]:
    """Wait up to ``grace_s`` for this suite's ``urc`` processes to end (a control process
    whose I/O process was killed stops its axes and saves first), then SIGKILL what is
    left. Returns the command lines that had to be killed."""
    deadline = time.monotonic() + grace_s
    while (left := suite_urc_processes(mark)) and time.monotonic() < deadline:
        time.sleep(0.2)
    for pid, _ in left:
        _kill(pid)
    return [f"{pid}: {cmd}" for pid, cmd in left]


def stop_process_group(proc: subprocess.Popen, timeout_s: float = 30.0) -> str:
    """SIGTERM a process started with ``start_new_session=True`` and everything in its
    group, wait up to ``timeout_s``, then SIGKILL the group. Returns its output."""
    if proc.returncode is not None:   # waited for already: only stragglers remain
        _kill_group(proc.pid)
        return ""
    for sig in (signal.SIGTERM, signal.SIGKILL):
        try:
            os.killpg(proc.pid, sig)
        except ProcessLookupError:
            pass
        try:
            out, _ = proc.communicate(timeout=timeout_s)
            break
        except subprocess.TimeoutExpired:
            continue
    else:
        out, _ = proc.communicate()
    _kill_group(proc.pid)     # a member that outlived its leader (not urc's control
    return out or ""          # process: it runs in a session of its own, see UrcProcess.stop)


def _term_with_parent() -> None:
    """In the child before exec: SIGTERM (an orderly stop) when the test process that
    started it dies, even by SIGKILL or a CI timeout, where no finalizer or session-end
    check runs (Linux PR_SET_PDEATHSIG; a new session alone leaves it running). Linux
    counts the *thread* that forked as the parent: a urc started from a thread that then
    ends is stopped with it, so start urcs from the test's own thread."""
    import ctypes

    ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGTERM)


def _kill(pid: int) -> None:
    try:
        os.kill(pid, signal.SIGKILL)
    except ProcessLookupError:
        pass


def _kill_group(pgid: int) -> None:
    try:
        os.killpg(pgid, signal.SIGKILL)
    except ProcessLookupError:
        pass


def _read_or_empty(path: Path) -> str:
    try:
        return path.read_text()
    except OSError:  # (a thread that ended meanwhile)
        return ""


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


def api_answers(url: str) -> bool:
    """True once urc's API at ``url`` answers a status read."""
    try:
        return HTTP.get(url + "/api/status", timeout=2.0).status_code == 200
    except httpx.HTTPError:
        return False


def process_gone(pid: int) -> bool:
    """True once ``pid`` has exited (gone, or a zombie not yet reaped). Race-free: its
    parent may reap it between looking for /proc/PID and reading its stat."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] == "Z"
    except (FileNotFoundError, ProcessLookupError):
        return True


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
        # an exposed instance's reads need its token (issue 36.8): the one in ``extra``
        token = re.search(r'^token = "([^"]*)"', extra, re.M)
        self.auth = {"Authorization": f"Bearer {token.group(1)}"} if token else {}
        self.proc: subprocess.Popen | None = None
        self.banner = ""
        #: a control process this urc run took over (not its child: urc.link.adoption)
        self.adopted_control_pid: int | None = None

    def start(self, timeout_s: float = START_TIMEOUT_S, env: dict | None = None,
              args: list[str] | None = None) -> "UrcProcess":
        """Start ``urc run`` (with ``args`` added) in a process group of its own (so a stop
        reaches its control process too) and wait until its API answers; a start that
        fails leaves nothing running."""
        self.proc = subprocess.Popen(URC + ["run", "--config", str(self.config), "--state-dir", str(self.state_dir),
                                            *(args or [])],
                                     stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                                     start_new_session=True, env=env, preexec_fn=_term_with_parent)
        try:
            wait_until(self._answers, timeout_s, "urc run answers on its API port", poll_s=0.02)
        except BaseException as exc:
            out = stop_process_group(self.proc, timeout_s=10)
            # (one that exited has had its output read into exc already: nothing is left)
            raise AssertionError(f"urc run did not start listening:\n{out or exc}") from None
        return self

    def start_logged(self, log_path: Path, prefix: list[str] | None = None,
                     timeout_s: float = START_TIMEOUT_S) -> "UrcProcess":
        """Start ``urc run`` with its output in ``log_path`` (a benchmark counts its log
        bytes) behind an optional command ``prefix`` (``prlimit ...``), and wait until
        its API answers. The caller stops it (:meth:`stop`)."""
        with open(log_path, "wb") as log:
            self.proc = subprocess.Popen((prefix or []) + URC + ["run", "--config", str(self.config),
                                                                 "--state-dir", str(self.state_dir)],
                                         stdout=log, stderr=subprocess.STDOUT, start_new_session=True,
                                         preexec_fn=_term_with_parent)
        try:
            wait_until(lambda: self.proc.poll() is None and api_answers(self.url), timeout_s, "urc run answers")
        except BaseException:
            stop_process_group(self.proc, timeout_s=10)
            raise
        return self

    def _answers(self) -> bool:
        self._raise_if_exited()
        try:
            HTTP.get(self.url + "/api/status", timeout=2.0)   # (any answer: the API is up)
            return True
        except httpx.HTTPError:
            return False

    def control_pid(self) -> int:
        """The pid of this urc's control process (the loop, the rotator, the hardware)."""
        assert self.proc is not None
        # (every thread's children: a control process started again after a takeover is
        # the watch thread's child)
        children = [pid for task in Path(f"/proc/{self.proc.pid}/task").iterdir()
                    for pid in _read_or_empty(task / "children").split()]
        for pid in children:
            try:
                if b"urc.control_entry" in Path(f"/proc/{pid}/cmdline").read_bytes():
                    return int(pid)
            except FileNotFoundError:
                pass
        if self.adopted_control_pid is not None and not process_gone(self.adopted_control_pid):
            return self.adopted_control_pid
        raise AssertionError("no control process found")

    def status(self) -> dict:
        return self.api_status()

    def api_status(self) -> dict:
        """GET /api/status (what :meth:`wait` polls, whatever ``status`` a subclass reads)."""
        try:
            return HTTP.get(self.url + "/api/status", headers=self.auth).json()
        except httpx.TransportError:
            self._raise_if_exited(grace_s=5.0)
            raise

    def _raise_if_exited(self, grace_s: float = 0.0) -> None:
        """A urc that has gone away: fail with what it said, not with 'connection refused'.
        ``grace_s``: how long to wait for it to exit (one on its way out has closed its
        port a moment before it exits)."""
        if self.proc is None:
            return
        try:
            self.proc.wait(timeout=grace_s)
        except subprocess.TimeoutExpired:
            return
        out = self.proc.stdout.read() if self.proc.stdout is not None else "(its output went to a log)"
        raise AssertionError(f"urc run exited with code {self.proc.returncode}:\n{out}")

    def post(self, path: str, body: dict | None = None) -> httpx.Response:
        return HTTP.post(self.url + path, json=body)

    def wait(self, pred, timeout_s: float = 60.0) -> dict:
        deadline = time.monotonic() + timeout_s
        s = self.api_status()
        while time.monotonic() < deadline:
            s = self.api_status()
            if pred(s):
                return s
            time.sleep(0.1)
        raise AssertionError(f"condition not met within {timeout_s} s; last status {s}")

    def stop(self) -> str:
        """SIGTERM, then SIGKILL after 30 s; either way nothing of this urc is left.
        Its output is also printed: pytest shows it under a failed test's captured output."""
        if self.proc is None:
            return ""
        control = self._running_control_pid()
        out = stop_process_group(self.proc)
        if control is not None and not process_gone(control):
            try:    # it ends in order once urc run has gone (axes stopped, state saved) ...
                wait_until(lambda: process_gone(control), 30.0, "the control process ended")
            except AssertionError:   # ... or is killed, like urc run after its 30 s
                _kill(control)
        if out:
            print(f"--- urc run (pid {self.proc.pid}) said:\n{out}")
        return out

    def kill(self) -> str:
        """End at once, without the orderly stop (1-2 s of its own): for a test done with a
        urc whose stop it does not check. Returns its output."""
        if self.proc is not None and self.proc.poll() is None:
            control = self._running_control_pid()
            if control is not None:
                _kill(control)
            _kill_group(self.proc.pid)
        return self.stop()

    def _running_control_pid(self) -> int | None:
        """The control process's pid while urc run runs (it is in a session of its own:
        the signals to urc run's group miss it)."""
        try:
            return self.control_pid() if self.proc is not None and self.proc.poll() is None else None
        except (AssertionError, OSError):
            return None
