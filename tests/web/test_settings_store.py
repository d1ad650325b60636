"""Saving settings: the person's file edited in place (only the changed keys), no
command-line override persisted, atomic replace, permissions kept."""

import os
import stat
import tomllib

import pytest

from urc.cli import with_emulation
from urc.config import Config, load_config
from urc.web import settings_store
from urc.web.settings_store import SettingsStore

HAND_WRITTEN = '# my station: comments only a person writes\n[api]\ntoken = "s3cret"\n'


def store_for(path):
    return SettingsStore(Config.from_dict(tomllib.loads(path.read_text())), path, None)


def changed(store, az_offset_deg):
    data = store.cfg.to_dict()
    data["offsets"]["az_deg"] = az_offset_deg
    return Config.from_dict(data)


COMMENTED = """# G4JNT at the club station -- keep this file in git
[rotator]
profile = "g4jnt"        # the PIC rotator
flip = false

# measured with a compass, 2025-03
[offsets]
az_deg = 1.5    # mast twist
el_deg = 0.0

[hardware]
backend = "gpio"

[hardware.gpio.az]
motor = "relay"
pins = { cw = 5, ccw = 6 }   # relay board
adc = "mcp3008"
adc_channel = 0

[hardware.gpio.el]
motor = "relay"
pins = { cw = 20, ccw = 21 }
adc = "mcp3008"
adc_channel = 1

[[keepout]]
name = "roof"
az_min_deg = 100.0
az_max_deg = 140.0
el_min_deg = 0.0
el_max_deg = 20.0
"""


def test_save_edits_the_file_in_place_byte_for_byte_outside_the_changed_key(tmp_path):
    """Issue 22: a save rewrote the whole file with every default and moved the comments
    to .bak. Now the file is the person's: one changed key, one changed line."""
    path = tmp_path / "urc.toml"
    path.write_text(COMMENTED)
    store = store_for(path)
    store.save(changed(store, 2.25))
    assert path.read_text() == COMMENTED.replace("az_deg = 1.5    # mast twist", "az_deg = 2.25    # mast twist")
    assert not list(tmp_path.glob("*.bak"))
    # a second save, a new key in a table the file lacks and a key in a nested inline table
    data = store.cfg.to_dict()
    data["hardware"]["gpio"]["az"]["pins"]["cw"] = 7
    data["park"] = {"az_deg": 180.0}
    store.save(Config.from_dict(data))
    text = path.read_text()
    assert text.startswith(COMMENTED.replace("az_deg = 1.5    # mast twist", "az_deg = 2.25    # mast twist")
                           .replace("pins = { cw = 5, ccw = 6 }", "pins = { cw = 7, ccw = 6 }"))
    assert text.endswith("\n[park]\naz_deg = 180.0\n")
    assert Config.from_dict(tomllib.loads(text)) == store.cfg


def test_a_save_from_the_page_keeps_an_integer_an_integer(tmp_path):
    """Issue 36 item 9: ``alt_m = 70`` saved from the page as 71 became ``alt_m = 71.0``."""
    path = tmp_path / "urc.toml"
    path.write_text("[station]\nlat_deg = 58.3\nlon_deg = 26.7\nalt_m = 70\n")
    store = store_for(path)
    doc = store.document()["config"]
    doc["station"]["alt_m"] = 71          # as the page posts it (JSON)
    cfg, errors = store.validate(doc)
    assert not errors
    store.save(cfg)
    assert path.read_text() == "[station]\nlat_deg = 58.3\nlon_deg = 26.7\nalt_m = 71\n"


def test_a_command_line_override_is_never_saved(tmp_path):
    """Issue 22: a save from a urc started with --emulate wrote [hardware.gpio] emulate =
    true into the file: copied to a Pi, it ran on emulated pins."""
    path = tmp_path / "urc.toml"
    path.write_text(COMMENTED)
    running = with_emulation(load_config(path))
    store = SettingsStore(running, path, None)
    doc = store.document()["config"]
    assert doc["hardware"]["gpio"]["emulate"] is True        # what the page is shown
    doc["offsets"]["az_deg"] = 3.0
    cfg, errors = store.validate(doc)
    assert not errors
    store.save(cfg)
    assert "emulate" not in path.read_text()
    assert load_config(path).hardware.gpio.emulate is False
    assert path.read_text() == COMMENTED.replace("az_deg = 1.5    # mast twist", "az_deg = 3.0    # mast twist")


def test_a_new_file_holds_only_what_was_changed(tmp_path):
    """Started without a file (the state directory's urc.toml): the save writes the
    changed keys, not every default nor the command line's values."""
    store = SettingsStore(Config.from_dict({"api": {"port": 9999}}), None, tmp_path)
    path = store.save(changed(store, 1.0))
    assert tomllib.loads(path.read_text()) == {"offsets": {"az_deg": 1.0}}


def test_save_keeps_a_private_file_private(tmp_path):
    path = tmp_path / "urc.toml"
    path.write_text(HAND_WRITTEN)
    os.chmod(path, 0o600)
    store = store_for(path)
    store.save(changed(store, 1.0))
    assert stat.S_IMODE(path.stat().st_mode) == 0o600
    assert tomllib.loads(path.read_text())["api"]["token"] == "s3cret"


def test_new_file_is_private(tmp_path):
    store = SettingsStore(Config.from_dict({"api": {"token": "t"}}), None, tmp_path)
    path = store.save(changed(store, 1.0))
    assert stat.S_IMODE(path.stat().st_mode) == 0o600


@pytest.mark.parametrize("crash_at", [1])   # one rename now: no .bak is written
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


def test_dotted_keys_take_a_new_table_inline(tmp_path):
    """A file written with dotted keys: a new table lands among them (tomlkit alone put
    it at the top level as [gpio.az...], a different key)."""
    path = tmp_path / "urc.toml"
    text = ('[rotator]\nprofile = "g4jnt"\n[hardware]\nbackend = "gpio"  # the Pi\n'
            'gpio.az.motor = "relay"\ngpio.az.pins = { cw = 5, ccw = 6 }\ngpio.az.adc = "mcp3008"\n'
            'gpio.el.motor = "relay"\ngpio.el.pins = { cw = 20, ccw = 21 }\ngpio.el.adc = "mcp3008"\n'
            'gpio.el.adc_channel = 1\n')
    path.write_text(text)
    store = store_for(path)
    data = store.cfg.to_dict()
    data["hardware"]["gpio"]["az"]["pins"]["cw"] = 7
    data["panel"] = {"enabled": True, "emulate": True, "buttons": {"cw": 17}}
    store.save(Config.from_dict(data))
    saved = path.read_text()
    assert saved.startswith(text.replace("cw = 5", "cw = 7"))
    assert Config.from_dict(tomllib.loads(saved)) == store.cfg
