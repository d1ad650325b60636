"""One urc per state directory and per real hardware (issue 9.6)."""

from __future__ import annotations

import os

import pytest

from urc.service import instance
from urc.service.instance import InstanceLocked, lock_instance


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
