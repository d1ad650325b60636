"""One urc per state directory and per real hardware (issue 9.6)."""

from __future__ import annotations

import os

import pytest

from urc.link import instance
from urc.link.instance import InstanceLocked, lock_instance


def test_a_second_lock_on_one_state_dir_is_refused_with_the_holder(tmp_path):
    first = lock_instance(tmp_path / "state", "sim", real_hardware=False)
    with pytest.raises(InstanceLocked, match=f"pid {os.getpid()}"):
        lock_instance(tmp_path / "state", "sim", real_hardware=False)
    for lock in first:
        lock.release()
    again = lock_instance(tmp_path / "state", "sim", real_hardware=False)  # free once released
    for lock in again:
        lock.release()


def test_real_hardware_is_locked_across_state_dirs(tmp_path, monkeypatch):
    monkeypatch.setattr(instance, "hardware_lock_path", lambda backend: tmp_path / f"urc-{backend}.lock")
    first = lock_instance(tmp_path / "a", "gpio", real_hardware=True)
    with pytest.raises(InstanceLocked, match="gpio hardware"):
        lock_instance(tmp_path / "b", "gpio", real_hardware=True)
    # the refused start released what it had taken: the state dir b is free
    for lock in lock_instance(tmp_path / "b", "sim", real_hardware=False):
        lock.release()
    for lock in first:
        lock.release()


def test_a_holder_on_its_way_out_is_waited_for_a_live_one_is_not(tmp_path, monkeypatch):
    """A control process whose I/O process died keeps the lock (an inherited descriptor)
    while it brings the axes to rest: a new start waits for it, bounded; a running urc
    is refused at once."""
    import threading

    held = lock_instance(tmp_path / "state", "sim", real_hardware=False)[0]
    instance.mark_stopping(held.fd)
    released = threading.Event()

    def release() -> None:
        released.set()
        held.release()
    threading.Timer(0.4, release).start()
    for lock in lock_instance(tmp_path / "state", "sim", real_hardware=False):
        assert released.is_set(), "the lock was had only once the stopping holder let go"
        lock.release()

    held = lock_instance(tmp_path / "state", "sim", real_hardware=False)[0]
    instance.mark_stopping(held.fd)
    with pytest.raises(InstanceLocked, match="stopping"):  # bounded: it never left
        instance.InstanceLock(tmp_path / "state" / instance.LOCK_FILE, "state dir").acquire(stopping_wait_s=0.3)
    held.release()
    held = lock_instance(tmp_path / "state", "sim", real_hardware=False)[0]  # (names this live pid)

    def no_waiting(_s: float) -> None:
        raise AssertionError("a live holder is refused without waiting")
    monkeypatch.setattr(instance.time, "sleep", no_waiting)
    with pytest.raises(InstanceLocked, match=f"pid {os.getpid()}"):
        lock_instance(tmp_path / "state", "sim", real_hardware=False)
    held.release()
