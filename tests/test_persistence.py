"""Atomic, checksummed state file: round trip, corruption and truncation detected."""

import json

import pytest

from urc.errors import StateFileError
from urc.persistence import StateStore

PAYLOAD = {"profile": "tartu-urc", "axes": {"az": {"mech_deg": 123.4, "moving": False}}}


def test_round_trip(tmp_path):
    store = StateStore(tmp_path / "state.json")
    assert store.load() is None
    store.save(PAYLOAD)
    assert store.load() == PAYLOAD
    assert not (tmp_path / "state.json.tmp").exists()


@pytest.mark.parametrize("cut", [0, 1, 10, -1, -10])
def test_truncated_file_detected(tmp_path, cut):
    store = StateStore(tmp_path / "state.json")
    store.save(PAYLOAD)
    raw = store.path.read_bytes()
    store.path.write_bytes(raw[:cut] if cut >= 0 else raw[:cut])
    with pytest.raises(StateFileError):
        store.load()


def test_flipped_value_detected_by_checksum(tmp_path):
    store = StateStore(tmp_path / "state.json")
    store.save(PAYLOAD)
    rec = json.loads(store.path.read_text())
    rec["payload"]["axes"]["az"]["mech_deg"] = 124.4
    store.path.write_text(json.dumps(rec))
    with pytest.raises(StateFileError, match="checksum"):
        store.load()


@pytest.mark.parametrize("content", [b"[]", b'{"format": "other"}', b"\xff\xfe\x00garbage",
                                     b'{"format": "urc-state", "version": 99, "payload": {}}'])
def test_foreign_files_rejected(tmp_path, content):
    store = StateStore(tmp_path / "state.json")
    store.path.write_bytes(content)
    with pytest.raises(StateFileError):
        store.load()


def test_quarantine_moves_file_aside(tmp_path):
    store = StateStore(tmp_path / "state.json")
    store.path.write_bytes(b"junk")
    moved = store.quarantine()
    assert moved is not None and moved.read_bytes() == b"junk"
    assert store.load() is None
