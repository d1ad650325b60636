"""Shared by the tests that run a real control process (the simulator in a child process)."""

from __future__ import annotations

import threading
from typing import Callable

import pytest

from urc.config import Config
from urc.service.control_process import PING_S, ControlProcess
from urc.service.remote import RemoteRotator


@pytest.fixture
def start_control(tmp_path):
    """``start_control(profile, on_lost=None) -> (ControlProcess, RemoteRotator)``: a control
    process on the simulator, pinged as ``urc run``'s event loop pings it (a silent I/O
    process makes it stop the axes); killed at the end of the test if still running."""
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
