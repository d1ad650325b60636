"""The FRAM state store on an emulated MB85RC256V: round trip, a write torn by a power
cut keeps the previous record, damage is detected, and a restarted controller gets its
position back from the chip."""

from __future__ import annotations

from pathlib import Path

import pytest

from urc.assembly import build_rotator
from urc.clock import VirtualClock
from urc.config import Config, load_config
from urc.errors import StateFileError
from urc.hardware.fram import FramStore
from urc.hardware.gpio.emulate import FakeFram, FakeSMBus
from urc.rotator.loop import run_virtual



EXAMPLES = sorted((Path(__file__).resolve().parents[2] / "examples").glob("*.toml"))


def store():
    bus = FakeSMBus()
    chip = FakeFram()
    bus.devices[0x50] = chip
    return FramStore(bus, 0x50), chip, bus


def test_round_trip_and_slots_alternate():
    s, chip, bus = store()
    assert s.fresh() and s.load() is None
    s.save({"axes": {"az": {"mech_deg": 12.5}}})
    s.mark_initialised()
    assert not s.fresh()
    assert s.load() == {"axes": {"az": {"mech_deg": 12.5}}}
    assert chip.mem[s.slots[0]:s.slots[0] + 4] == b"URCF"
    s.save({"axes": {"az": {"mech_deg": 13.0}}})
    assert chip.mem[s.slots[1]:s.slots[1] + 4] == b"URCF"
    assert s.load()["axes"]["az"]["mech_deg"] == 13.0


def test_memory_address_goes_first_on_the_wire():
    s, chip, bus = store()
    bus.keep_log = True
    s.save({"a": 1})
    # the slots are read first (2-byte address written, then read) ...
    assert bus.log[0] == ("wr", 0x50, -1, (s.slots[0] >> 8, s.slots[0] & 0xFF))
    assert bus.log[1][0] == "rd"
    # ... then the body is written: address high byte as the command, low byte first
    op, addr, reg, data = next(e for e in bus.log if e[0] == "w")
    body_addr = s.slots[0] + 16
    assert (op, addr, reg, data[:3]) == ("w", 0x50, body_addr >> 8, (body_addr & 0xFF, *b'{"'))


def test_a_torn_write_keeps_the_previous_record():
    s, chip, _ = store()
    s.save({"pos": 1.0})
    s.save({"pos": 2.0})
    chip.fail_after_bytes = 5                 # the power goes 5 bytes into the next write
    with pytest.raises(StateFileError):
        s.save({"pos": 3.0, "pad": "x" * 100})
    chip.fail_after_bytes = None
    assert s.load() == {"pos": 2.0}


def test_damage_is_detected_never_trusted():
    s, chip, _ = store()
    s.save({"pos": 1.0})
    chip.mem[s.slots[0] + 20] ^= 0xFF
    with pytest.raises(StateFileError, match="checksum"):
        s.load()


def test_restart_gets_the_position_from_the_fram(tmp_path):
    data = load_config(next(p for p in EXAMPLES if p.stem == "tartu-urc")).to_dict()
    data["hardware"]["gpio"].update({"emulate": True, "fram_address": 0x50})
    data["hardware"]["sim"] = {"wind": False}
    cfg = Config.from_dict(data)
    clock = VirtualClock(1000.0)
    rot = build_rotator(cfg, clock, tmp_path, durable_state=False)
    assert isinstance(rot.store, FramStore)
    rot.goto(100.0, 40.0)
    s = run_virtual(rot, clock, 60.0, until=lambda s: not s.moving and abs(s.az_deg - 100) < 0.3)
    rot.shutdown()
    rot.hw.close()
    assert not (tmp_path / "state.json").exists()
    rot2 = build_rotator(cfg, clock, tmp_path, durable_state=False)
    s2 = rot2.status()
    assert not rot2.position_uncertain()
    assert s2.az_deg == pytest.approx(s.az_deg, abs=0.2) and s2.el_deg == pytest.approx(s.el_deg, abs=0.2)
    assert s2.sim_truth["az"]["deg"] == pytest.approx(s2.az_deg, abs=0.3)


def test_non_finite_slot_is_damage_and_never_written():
    """A slot whose CRC is good but whose record holds NaN is a bad slot: the other one
    is used (issue 21); a NaN is never written."""
    import json
    import struct
    import zlib
    s, chip, bus = store()
    s.save({"axes": {"az": {"mech_deg": 12.5}}})
    with pytest.raises(StateFileError, match="not a finite number"):
        s.save({"axes": {"az": {"mech_deg": float("nan")}}})
    body = json.dumps({"axes": {"az": {"mech_deg": float("nan")}}}).encode()
    s._write(s.slots[1] + 16, body)
    s._write(s.slots[1], struct.pack(">4sIII", b"URCF", 99, len(body), zlib.crc32(body)))
    assert s.load() == {"axes": {"az": {"mech_deg": 12.5}}}


def test_a_record_with_a_field_of_the_wrong_type_is_damage():
    """Issue 36.20: a checksummed record whose position is text ("13.0") is damaged,
    not trusted: the other slot's record is used (and with none, the load fails)."""
    s, _, _ = store()
    s.save({"axes": {"az": {"mech_deg": 12.5}}})
    s.save({"axes": {"az": {"mech_deg": "13.0"}}})     # (the store checksums what it is given)
    assert s.load() == {"axes": {"az": {"mech_deg": 12.5}}}
    only, _, _ = store()
    only.save({"axes": {"az": {"mech_deg": "13.0"}}})
    with pytest.raises(StateFileError, match="mech_deg: expected a number"):
        only.load()
