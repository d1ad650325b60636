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


def test_quarantine_keeps_a_copy_and_the_file_until_replaced(tmp_path):
    """The damaged file is copied aside; it stays in place until a new record replaces
    it, so a crash in between still finds a (damaged, hence distrusted) file."""
    store = StateStore(tmp_path / "state.json")
    store.path.write_bytes(b"junk")
    kept = store.quarantine()
    assert kept is not None and kept.read_bytes() == b"junk"
    assert store.path.read_bytes() == b"junk"
    store.save(PAYLOAD)
    assert store.load() == PAYLOAD and kept.read_bytes() == b"junk"


def test_fresh_only_before_first_use(tmp_path):
    """A deleted state file in a used directory is not a fresh start (issue 9.3)."""
    store = StateStore(tmp_path / "state" / "state.json")
    assert store.fresh()
    store.save(PAYLOAD)
    store.mark_initialised()
    assert not store.fresh()
    store.path.unlink()
    assert not store.fresh(), "the marker remembers the directory was used"


@pytest.mark.parametrize("value", [float("nan"), float("inf"), float("-inf")])
@pytest.mark.parametrize("field", ["mech_deg", "uncertainty_deg", "window_deg"])
def test_non_finite_field_with_a_valid_checksum_is_damage(tmp_path, value, field):
    """Python's JSON reader takes NaN and Infinity, and a CRC over them is valid: such a
    record must still be called damaged (issue 21: NaN uncertainty was trusted)."""
    store = StateStore(tmp_path / "state.json")
    payload = json.loads(json.dumps(PAYLOAD))
    payload["axes"]["az"][field] = [0.0, value] if field == "window_deg" else value
    text = json.dumps(payload, sort_keys=True, separators=(",", ":"))
    import time
    import zlib
    record = {"format": "urc-state", "version": 1, "saved_unix_s": time.time(),
              "crc32": zlib.crc32(text.encode()), "payload": payload}
    store.path.write_text(json.dumps(record))
    with pytest.raises(StateFileError, match=f"axes.az.{field}.* not a finite number"):
        store.load()


def test_non_finite_value_is_never_written(tmp_path):
    store = StateStore(tmp_path / "state.json")
    store.save(PAYLOAD)
    with pytest.raises(StateFileError, match="not a finite number"):
        store.save({"profile": "x", "axes": {"az": {"mech_deg": float("nan")}}})
    assert store.load() == PAYLOAD, "the good record stays"


def test_a_fifo_in_place_of_the_state_file_is_an_error_not_a_hang(tmp_path):
    """Reading a FIFO blocks until a writer comes; the control process must not."""
    import os
    import threading

    store = StateStore(tmp_path / "state.json")
    os.mkfifo(store.path)
    outcome: list[BaseException | object] = []

    def load():
        try:
            outcome.append(store.load())
        except BaseException as exc:  # noqa: BLE001 - recorded for the assertion
            outcome.append(exc)
    t = threading.Thread(target=load, daemon=True)
    t.start()
    t.join(timeout=10.0)  # a hang guard, not a measurement
    if t.is_alive():
        with open(store.path, "wb"):  # let the blocked reader go
            pass
        t.join()
        pytest.fail("loading a FIFO blocked")
    assert isinstance(outcome[0], StateFileError) and "not a regular file (a FIFO)" in str(outcome[0])
    assert store.quarantine() is None, "nothing copied (copying a FIFO would block too)"


@pytest.mark.parametrize("payload, said", [
    ({"profile": 7, "axes": {}}, "payload.profile"),
    ({"profile": "x", "axes": []}, "payload.axes"),
    ({"profile": "x", "axes": {"az": 12.5}}, "payload.axes.az: expected a table"),
    ({"profile": "x", "axes": {"az": {"mech_deg": "12.5"}}}, "payload.axes.az.mech_deg"),
    ({"profile": "x", "axes": {"az": {"mech_deg": 1.0, "calibration": {"M": [1, "2"]}}}}, "calibration"),
])
def test_a_field_not_as_urc_writes_it_is_damage(tmp_path, payload, said):
    """Issue 36.20: a valid checksum over a field of the wrong type is still damage."""
    import time
    import zlib
    store = StateStore(tmp_path / "state.json")
    text = json.dumps(payload, sort_keys=True, separators=(",", ":"))
    store.path.write_text(json.dumps({"format": "urc-state", "version": 1, "saved_unix_s": time.time(),
                                      "crc32": zlib.crc32(text.encode()), "payload": payload}))
    with pytest.raises(StateFileError, match=f"{said}.*damaged"):
        store.load()
