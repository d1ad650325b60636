"""Shared fixtures: a rotator on the physics simulator and a virtual clock."""

from __future__ import annotations

import functools
import os
import threading
import uuid
from pathlib import Path
from typing import Callable

import pytest

import urc.registrations  # noqa: F401  (the configuration's checks, before any test reads one)
from urc.assembly import build_rotator
from urc.clock import VirtualClock
from urc.config import Config
from urc.profiles import PROFILES
from urc.rotator.loop import run_virtual

ALL_PROFILES = sorted(PROFILES)
EXAMPLES_DIR = Path(__file__).resolve().parents[1] / "examples"


def gpio_hardware(profile: str) -> dict:
    """``[hardware]`` of the profile's shipped example (examples/<profile>.toml) on
    emulated pins and chips: the gpio backend's real drivers fed by the simulator.
    ``bench(profile, hardware=gpio_hardware(profile))`` runs a test on it."""
    from urc.config import load_config

    hw = load_config(EXAMPLES_DIR / f"{profile}.toml").to_dict()["hardware"]
    hw["gpio"]["emulate"] = True
    return hw


class Bench:
    """A rotator on the simulator, driven on virtual time."""

    def __init__(self, profile: str, state_dir: Path, exact: bool = False, **config):
        """``exact=True``: every state/truth record written on virtual time (restart
        tests); otherwise writes are spaced in wall time too, which is much faster."""
        config.setdefault("rotator", {})["profile"] = profile
        config.setdefault("hardware", {}).setdefault("sim", {}).setdefault("wind", False)
        self.cfg = Config.from_dict(config)
        self.clock = VirtualClock(1000.0)
        self.state_dir = state_dir
        self.exact = exact
        self.rot = self._build()
        self.world = self.rot.hw.world

    def _build(self):
        return build_rotator(self.cfg, self.clock, self.state_dir, durable_state=False, fast_virtual=not self.exact)

    def run(self, seconds: float, until=None, on_tick=None):
        return run_virtual(self.rot, self.clock, seconds, until=until, on_tick=on_tick)

    def settle(self, timeout_s: float = 200.0):
        """Run until both axes hold still (or time out)."""
        return self.run(timeout_s, until=lambda s: not s.moving and all(
            a is None or a.mode in ("holding", "idle") for a in (s.az, s.el)))

    def truth(self, axis: str) -> float:
        return self.rot.status().sim_truth[axis]["deg"]

    def restart(self, clean: bool = True) -> "Bench":
        """Stop this controller (orderly, or as if killed) and start a new one on the same iron."""
        if clean:
            self.rot.shutdown()
        self.rot.hw.close() if clean else self.world.close()
        nxt = Bench.__new__(Bench)
        nxt.cfg, nxt.clock, nxt.state_dir, nxt.exact = self.cfg, self.clock, self.state_dir, self.exact
        nxt.rot = nxt._build()
        nxt.world = nxt.rot.hw.world
        return nxt


def bounded(s, axis: str, slack_deg: float = 0.0) -> bool:
    """The truth lies where urc says: within its bound if uncertain, else within
    ``slack_deg`` (a count or two: the hold band of a known position)."""
    ax = getattr(s, axis)
    err = abs(ax.pos_deg - s.sim_truth[axis]["deg"])
    return err <= ax.uncertainty_deg if ax.uncertainty_deg else err <= slack_deg


@pytest.fixture
def bench(tmp_path):
    def make(profile: str = "tartu-urc", exact: bool = False, **config) -> Bench:
        return Bench(profile, tmp_path / f"state-{profile}", exact=exact, **config)
    return make


@pytest.fixture
def urc_processes(tmp_path):
    """``urc_processes(workdir=None, **kw)``: a ``UrcProcess`` (not started) in ``workdir``
    (default: the test's tmp_path); every one made is stopped when the test ends, its
    whole process group, passed or failed."""
    from urc_process import UrcProcess

    made: list[UrcProcess] = []

    def make(workdir: Path | None = None, **kw) -> UrcProcess:
        u = UrcProcess(workdir or tmp_path, **kw)
        made.append(u)
        return u
    yield make
    for u in made:
        u.stop()


@pytest.fixture(autouse=True)
def no_session_bugs():
    """Every test: bad-input logging starts fresh, and no protocol session may hit an
    unexpected exception (issue 12.21: sessions answer a bug with their protocol's error
    reply, so a test looking only at replies could not notice one; the counter can)."""
    from urc.protocols.base import internal_error_count, reset_bad_input_logs

    reset_bad_input_logs()
    before = internal_error_count()
    yield
    assert internal_error_count() == before, "a session caught an unexpected exception (see the log)"


# -- no process outlives its test module or the run ---------------------------------
# Each pytest process (the xdist controller and every worker) marks the environment its
# children inherit; after each test module, and at the end of the run, any ``urc``
# process still carrying this process's mark is a leak: killed, and the run fails.

LEAK_GRACE_S = 30.0   # a control process whose I/O process died stops its axes first


def pytest_configure(config):
    from urc.link.client import STRICT_ENV
    from urc_process import SUITE_MARK

    os.environ[SUITE_MARK] = f"{os.getpid()}-{uuid.uuid4().hex[:8]}"
    # a round trip to the control process that would block the event loop raises
    # (in every urc run the suite starts) instead of being logged
    os.environ[STRICT_ENV] = "1"


# -- longest first ------------------------------------------------------------------
# The suite's time goes to files that start real processes (urc run, Chromium, Mosquitto,
# Hamlib's rotctld) and wait on real clocks. Run with ``--dist loadfile
# --no-loadscope-reorder`` (.ci/run), xdist hands files out in this order: the heavy ones
# first, so the two workers finish together instead of one running the last long file
# while the other idles.

#: what a test file does that costs seconds of wall time per use
PROCESS_MARKS = ("UrcProcess(", "urc_processes(", "station(", "open_page", "Mosquitto(", "subprocess.",
                 "rotctld(", "stress(")


@functools.cache
def _file_weight(path: Path) -> int:
    text = path.read_text(errors="replace")
    return sum(text.count(mark) for mark in PROCESS_MARKS)


def pytest_collection_modifyitems(session, config, items):
    items.sort(key=lambda item: -_file_weight(Path(str(item.fspath))))   # (stable: file order kept)


@pytest.fixture(autouse=True, scope="module")
def no_leaked_urc_processes():
    from urc_process import SUITE_MARK, reap_leaked

    yield
    leaked = reap_leaked(os.environ[SUITE_MARK], LEAK_GRACE_S)
    assert not leaked, "urc processes still running after this module (killed now):\n" + "\n".join(leaked)


def pytest_sessionfinish(session, exitstatus):
    from urc_process import SUITE_MARK, reap_leaked

    leaked = reap_leaked(os.environ[SUITE_MARK], LEAK_GRACE_S)
    if leaked:
        print("\nurc processes still running at the end of the run (killed now):\n" + "\n".join(leaked))
        session.exitstatus = pytest.ExitCode.TESTS_FAILED


@pytest.fixture
def start_control(tmp_path):
    """``start_control(profile, on_lost=None) -> (ControlProcess, RemoteRotator)``: a control
    process on the simulator, pinged as ``urc run``'s event loop pings it (a silent I/O
    process makes it stop the axes); killed at the end of the test if still running.
    (Shared by tests/link's control-process and round-trip tests.)"""
    from urc.link.control_process import PING_S, ControlProcess
    from urc.link.remote import RemoteRotator

    started: list[tuple[ControlProcess, threading.Event]] = []

    def start(profile: str, on_lost: Callable[[str], None] | None = None) -> tuple[ControlProcess, RemoteRotator]:
        cfg = Config.from_dict({"rotator": {"profile": profile}, "hardware": {"sim": {"wind": False}}})
        proc = ControlProcess(cfg, tmp_path / "state", [], on_lost=on_lost)
        rot = proc.start()
        done = threading.Event()
        started.append((proc, done))

        def ping() -> None:
            while not done.wait(PING_S):
                proc.ping()
        threading.Thread(target=ping, daemon=True).start()
        return proc, rot

    yield start
    for proc, done in started:
        done.set()
        if proc.proc is not None and proc.proc.poll() is None:
            proc.proc.kill()
            proc.proc.wait()
