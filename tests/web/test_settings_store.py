"""Saving settings: atomic replace, the hand-written original kept, permissions kept."""

import os
import stat
import tomllib

import pytest

from urc.config import Config
from urc.web import settings_store
from urc.web.settings_store import SettingsStore

HAND_WRITTEN = '# my station: comments only a person writes\n[api]\ntoken = "s3cret"\n'


def store_for(path):
    return SettingsStore(Config.from_dict(tomllib.loads(path.read_text())), path, None)


def changed(store, az_offset_deg):
    data = store.cfg.to_dict()
    data["offsets"]["az_deg"] = az_offset_deg
    return Config.from_dict(data)


def test_second_save_keeps_the_backup_of_the_hand_written_file(tmp_path):
    """Issue 12.13: the .bak must stay the person's file, not our first output."""
    path = tmp_path / "urc.toml"
    path.write_text(HAND_WRITTEN)
    store = store_for(path)
    store.save(changed(store, 1.0))
    store.save(changed(store, 2.0))
    assert (tmp_path / "urc.toml.bak").read_text() == HAND_WRITTEN
    assert tomllib.loads(path.read_text())["offsets"]["az_deg"] == 2.0


def test_save_keeps_a_private_file_private(tmp_path):
    path = tmp_path / "urc.toml"
    path.write_text(HAND_WRITTEN)
    os.chmod(path, 0o600)
    store = store_for(path)
    store.save(changed(store, 1.0))
    assert stat.S_IMODE(path.stat().st_mode) == 0o600
    assert stat.S_IMODE((tmp_path / "urc.toml.bak").stat().st_mode) == 0o600
    assert tomllib.loads(path.read_text())["api"]["token"] == "s3cret"


def test_new_file_is_private(tmp_path):
    store = SettingsStore(Config.from_dict({"api": {"token": "t"}}), None, tmp_path)
    path = store.save(changed(store, 1.0))
    assert stat.S_IMODE(path.stat().st_mode) == 0o600


@pytest.mark.parametrize("crash_at", [1, 2])
def test_a_crash_during_save_leaves_a_config(tmp_path, monkeypatch, crash_at):
    """Issue 9.4: a kill between two renames must not leave the station without a file."""
    path = tmp_path / "urc.toml"
    path.write_text(HAND_WRITTEN)
    store = store_for(path)
    calls = []
    real_replace = os.replace

    def replace(src, dst):
        calls.append((src, dst))
        if len(calls) == crash_at:
            raise KeyboardInterrupt("killed")
        real_replace(src, dst)
    monkeypatch.setattr(settings_store.os, "replace", replace)
    with pytest.raises(KeyboardInterrupt):
        store.save(changed(store, 1.0))
    cfg = tomllib.loads(path.read_text())
    assert cfg["api"]["token"] == "s3cret"
    assert not list(tmp_path.glob("*.tmp")) and not list(tmp_path.glob(".*.tmp"))
