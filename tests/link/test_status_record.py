"""The shared-memory status record: real simulated statuses cross it and merge back
unchanged, cold_key says when they would not, a writer in another process never tears a
read, and a record of another layout is refused."""

from __future__ import annotations

import dataclasses
import math
import os
import platform
import subprocess
import sys
import tempfile
import textwrap

import pytest

from urc.link.status_record import (
    _BODY_OFF,
    _CRC,
    BODY,
    MODES,
    SIZE,
    ColdGeneration,
    HotAxis,
    HotStatus,
    StatusRecord,
    StatusRecordError,
    cold_key,
    merge,
)
from urc.model.snapshot import AxisStatus, Status

AZ_ONLY = {"rotator": {"elevation": False}}


@pytest.fixture
def record():
    rec = StatusRecord.create()
    yield rec
    rec.close()


def crossed(rec: StatusRecord, s: Status, tick: int = 1, gen: int = 1) -> HotStatus:
    rec.write(s, tick, gen)
    hot = rec.read()
    assert hot is not None and (hot.tick, hot.cold_gen, hot.pid) == (tick, gen, os.getpid())
    return hot


def no_truth(b):
    """The bench's rotator without the simulator's truth in its statuses (as on real
    hardware): the truth differs every tick, which would make every tick a cold change."""
    b.rot.hw.truth_hook = None
    return b


@pytest.mark.parametrize("config", [{}, AZ_ONLY], ids=["az-el", "az-only"])
def test_simulated_statuses_cross_and_merge_back_unchanged(bench, record, config):
    b = bench("tartu-urc", **config)  # (a brake: the "releasing" mode shows too)
    first = b.rot.status()
    hot = crossed(record, first)
    assert hot.target_az_deg is None and hot.target_el_deg is None and hot.az.target_deg is None
    assert merge(first, hot) == first
    seen = []

    def check(s: Status) -> None:
        h = crossed(record, s, tick=len(seen) + 2)
        assert merge(s, h) == s
        assert (h.el is None, h.el_deg is None) == (s.el is None, s.el is None)
        seen.append(h)
    b.rot.goto(200.0, 40.0)
    b.run(60.0, on_tick=check)
    assert {h.az.mode for h in seen} >= {"releasing", "driving", "holding"}
    assert any(h.moving for h in seen) and not seen[-1].moving
    assert seen[-1].target_az_deg == 200.0 and seen[-1].az.target_deg is not None
    if config:
        assert all(h.el is None and h.el_deg is None and h.target_el_deg is None for h in seen)
    else:
        assert seen[-1].target_el_deg == 40.0 and seen[-1].el.pos_deg == pytest.approx(40.0, abs=0.5)


def test_a_faulted_status_crosses(bench, record):
    b = bench("tartu-urc", faults={"overcurrent_a": 100.0})
    b.rot.goto(200.0, 40.0)
    b.run(1.5)
    b.world.inject("az", "jam")
    b.world.inject("el", "sensor_dead")
    b.run(5.0)
    s = b.rot.status()
    assert s.faults and s.el.sensor_error and not s.el.sensor_ok
    hot = crossed(record, s)
    assert merge(s, hot) == s
    assert hot.el.sensor_ok is False and hot.az.duty == 0.0
    # a cold status from before the faults: the merge shows where the axes are now, not
    # the faults (cold fields: its generation would have told the reader to get them)
    before = dataclasses.replace(s, faults=(), el=dataclasses.replace(s.el, sensor_ok=True, sensor_error=""))
    merged = merge(before, hot)
    assert merged.faults == () and merged.el.sensor_error == "" and merged.el.sensor_ok is False
    assert cold_key(before) != cold_key(s)


def test_none_is_nan_only_where_a_field_may_be_none(record, bench):
    s = bench("tartu-urc").rot.status()
    odd = dataclasses.replace(s, target_az_deg=12.5, target_el_deg=None, az_deg=math.nan,
                              az=dataclasses.replace(s.az, target_deg=None, pos_deg=math.nan),
                              el=dataclasses.replace(s.el, target_deg=-3.0))
    hot = crossed(record, odd)
    assert (hot.target_az_deg, hot.target_el_deg, hot.az.target_deg, hot.el.target_deg) == (12.5, None, None, -3.0)
    # a float field that is never None stays NaN (a NaN reading is not an absent one)
    assert math.isnan(hot.az_deg) and math.isnan(hot.az.pos_deg)
    single = dataclasses.replace(s, el=None, el_deg=None, target_el_deg=None, axes=("az",))
    hot = crossed(record, single, tick=2)
    assert hot.el is None and hot.el_deg is None and merge(single, hot) == single
    # a two-axis record merged into a single-axis cold status: the axis comes back, its
    # cold fields at their defaults
    both = crossed(record, s, tick=3)
    assert merge(single, both).el == dataclasses.replace(s.el, sensor_error="")


def test_cold_key_changes_whenever_merge_could_not_restore_the_status(bench, record):
    """Over a run with motion, faults, their clearing and events: for every tick whose
    cold key equals the last one, the last status merged with the new record is the new
    status itself; and most ticks of plain motion keep the key."""
    b = no_truth(bench("tartu-urc", faults={"overcurrent_a": 100.0}))
    statuses = [b.rot.status()]
    b.rot.goto(200.0, 40.0)
    b.run(20.0, on_tick=statuses.append)
    moving_ticks = len(statuses)
    b.world.inject("az", "jam")
    b.world.inject("el", "sensor_dead")
    b.run(5.0, on_tick=statuses.append)
    b.rot.announce("an event from outside")
    b.run(0.5, on_tick=statuses.append)
    b.world.clear("az")
    b.world.clear("el")
    b.run(0.5, on_tick=statuses.append)
    b.rot.clear_faults()
    statuses.append(b.rot.status())
    b.run(2.0, on_tick=statuses.append)
    cold = ColdGeneration()
    gens = [cold.update(s) for s in statuses]
    kept = 0
    for i, (prev, cur) in enumerate(zip(statuses, statuses[1:])):
        if gens[i + 1] == gens[i]:
            kept += 1
            assert merge(prev, crossed(record, cur, tick=i + 1)) == cur, i
        else:
            assert cold_key(prev) != cold_key(cur)
    assert len(set(gens)) > 3  # the faults, the sensor's error, the event, the clearing
    assert kept > 0.9 * moving_ticks


def writer_script(n: int) -> str:
    return textwrap.dedent(f"""
        import math, sys
        from urc.link.status_record import MODES, StatusRecord
        from urc.model.snapshot import AxisStatus, Status

        rec = StatusRecord.attach(int(sys.argv[1]))
        for i in range(1, {n} + 1):
            x, b, target = float(i), bool(i & 1), None if i % 3 == 0 else float(i)
            ax = AxisStatus(x, x, target, MODES[i % len(MODES)], x, b, x, b, not b, x, b)
            el = None if i % 7 == 0 else ax
            rec.write(Status(x, "p", x, None if el is None else x, ax, el, target, target, b, i, b, not b, b,
                             (), (), x), i, i)
    """)


def expected(i: int, pid: int) -> HotStatus:
    """What the writer above wrote as tick ``i``: every number ``i``."""
    x, b, target = float(i), bool(i & 1), None if i % 3 == 0 else float(i)
    ax = HotAxis(x, x, target, MODES[i % len(MODES)], x, b, x, b, not b, x, b)
    el = None if i % 7 == 0 else ax
    return HotStatus(i, x, i, pid, x, None if el is None else x, target, target, x, i, b, b, not b, b, ax, el)


#: how many records the writer process writes (4-5 s on a loaded 2-core machine)
N_WRITES = 100_000


def test_a_writer_process_never_tears_a_read(record):
    """A child process writes as fast as it can, every number of each record its tick;
    every record read here is exactly one tick's (it fails without the sequence's
    retries: the CRC then rejects torn copies, and without the CRC too they come back)."""
    proc = subprocess.Popen([sys.executable, "-c", writer_script(N_WRITES), str(record.fd)],
                            pass_fds=(record.fd,))
    reads, ticks = 0, set()
    try:
        while proc.poll() is None:
            for _ in range(256):
                hot = record.read()
                if hot is None:
                    continue
                assert hot == expected(hot.tick, proc.pid)
                reads += 1
                ticks.add(hot.tick)
    finally:
        proc.kill() if proc.poll() is None else None
        proc.wait()
    assert proc.returncode == 0
    assert record.read() == expected(N_WRITES, proc.pid)
    assert reads > 0 and len(ticks) > 10
    # the reads did meet the writer mid-write (else this proved nothing) ...
    assert record.busy_retries + record.torn_retries > 0, (reads, len(ticks))
    # ... and on x86-64 (stores and loads in program order) the sequence alone caught
    # every such read; on ARM the CRC may have to catch one (status_record's comment)
    if platform.machine() in ("x86_64", "AMD64"):
        assert record.crc_rejects == 0


def test_a_write_under_way_is_not_read(record, bench):
    """The writer stopped between its two stores (seq odd), the record's bytes already a
    newer one's: readers get the last good record and its tick, which stops advancing."""
    s = bench("tartu-urc").rot.status()
    record.write(s, 1, 1)
    assert record.read().tick == 1 and record.liveness()[0] == 1
    newer = StatusRecord.create()
    newer.write(dataclasses.replace(s, az_deg=77.0), 2, 1)
    record._seq[0] += 1  # (the writer's first store of tick 2)
    record._mm[_BODY_OFF:SIZE] = newer._mm[_BODY_OFF:SIZE]  # its copy, complete, CRC and all
    newer.close()
    assert record.read().tick == 1 and record.read().az_deg == s.az_deg
    assert record.liveness()[0] == 1
    assert record.busy_retries > 0 and record.crc_rejects == 0
    # a writer attached afresh (a restarted control process) goes on from there
    again = StatusRecord.attach(os.dup(record.fd))
    again.write(dataclasses.replace(s, az_deg=78.0), 1, 1)
    assert record.read().az_deg == 78.0 and record._seq[0] % 2 == 0
    again.close()


def test_a_corrupted_record_is_not_read(record, bench):
    s = bench("tartu-urc").rot.status()
    record.write(s, 1, 1)
    record.write(dataclasses.replace(s, az_deg=10.0), 2, 1)
    assert record.read().tick == 2
    record.write(dataclasses.replace(s, az_deg=11.0), 3, 1)
    body_end = _BODY_OFF + BODY.size
    record._mm[body_end - 1] ^= 0xFF  # one byte, the sequence even: only the CRC can tell
    assert record.read().tick == 2 and record.crc_rejects > 0  # (the copy it had read before)
    record._mm[body_end - 1] ^= 0xFF
    assert record.read().tick == 3
    stored = record._mm[body_end:body_end + _CRC.size]
    record._mm[body_end:body_end + _CRC.size] = bytes(4)
    fresh = StatusRecord.attach(os.dup(record.fd))
    assert fresh.read() is None and fresh.liveness() is None and fresh.crc_rejects > 0
    record._mm[body_end:body_end + _CRC.size] = stored
    assert fresh.read().az_deg == 11.0
    fresh.close()


def test_a_read_with_nothing_written_since_gives_the_record_it_read(record, bench):
    """Every rotctld ``p`` reads the record; between two ticks (20 ms) a poller asks many
    times, and all but the first read find the sequence where it was: no copy, no unpack."""
    s = bench("tartu-urc").rot.status()
    record.write(s, 1, 1)
    first = record.read()
    assert record.read() is first and record.read() is first
    record.write(dataclasses.replace(s, az_deg=12.5), 2, 1)
    second = record.read()
    assert second is not first and (second.tick, second.az_deg) == (2, 12.5)
    assert record.read() is second
    other = StatusRecord.attach(os.dup(record.fd))  # (another reader of the same record)
    assert other.read() == second and other.read() is other.read()
    other.close()


def test_liveness_advances_with_the_writers_ticks(record, bench):
    assert record.liveness() is None and record.read() is None
    b = bench("tartu-urc")
    lives = []

    def tick(s: Status) -> None:
        record.write(s, len(lives) + 1, 1)
        lives.append(record.liveness())
    b.run(1.0, on_tick=tick)
    assert [t for t, _, _ in lives] == list(range(1, len(lives) + 1))
    assert all(t1 > t0 for (_, t0, _), (_, t1, _) in zip(lives, lives[1:]))
    assert {pid for _, _, pid in lives} == {os.getpid()}
    # from another process: its pid, its tick
    proc = subprocess.run([sys.executable, "-c", writer_script(5), str(record.fd)], pass_fds=(record.fd,))
    assert proc.returncode == 0
    tick_n, t_s, pid = record.liveness()
    assert (tick_n, t_s) == (5, 5.0) and pid != os.getpid()


def test_an_unknown_mode_is_refused_and_nothing_is_written(record, bench):
    s = bench("tartu-urc").rot.status()
    record.write(s, 1, 1)
    with pytest.raises(ValueError, match="'spinning'"):
        record.write(dataclasses.replace(s, az=dataclasses.replace(s.az, mode="spinning")), 2, 1)
    assert record.read().tick == 1 and record._seq[0] % 2 == 0


def memfd(header: bytes, size: int = SIZE, seal: bool = True) -> int:
    import fcntl
    fd = os.memfd_create("test", os.MFD_ALLOW_SEALING)
    os.ftruncate(fd, size)
    os.pwrite(fd, header, 0)
    if seal:
        fcntl.fcntl(fd, fcntl.F_ADD_SEALS, fcntl.F_SEAL_SHRINK | fcntl.F_SEAL_GROW)
    return fd


def pipe_end() -> int:
    r, w = os.pipe()
    os.close(w)
    return r


@pytest.mark.parametrize("make,why", [
    (lambda: memfd(b"urcX" + (1).to_bytes(4, "little") + BODY.size.to_bytes(4, "little")), "b'urcX'"),
    (lambda: memfd(b"urcS" + (2).to_bytes(4, "little") + BODY.size.to_bytes(4, "little")), "version 2"),
    (lambda: memfd(b"urcS" + (1).to_bytes(4, "little") + (BODY.size - 8).to_bytes(4, "little")),
     rf"\({BODY.size - 8} bytes\)"),
    (lambda: memfd(b"urcS" + (1).to_bytes(4, "little") + BODY.size.to_bytes(4, "little"), seal=False), "unsealed"),
    (lambda: memfd(b"", size=SIZE - 1), "smaller"),
    (lambda: os.open(tempfile.gettempdir(), os.O_TMPFILE | os.O_RDWR), "not a memfd"),  # (a plain file)
    (pipe_end, "not a memfd"),
])
def test_attach_refuses_what_is_not_this_record(make, why):
    fd = make()
    try:
        with pytest.raises(StatusRecordError, match=why):
            StatusRecord.attach(fd)
    finally:
        os.close(fd)


def test_the_record_cannot_be_shrunk_under_a_reader(record):
    child_fd = os.dup(record.fd)  # (what the child gets)
    try:
        with pytest.raises(PermissionError):
            os.ftruncate(child_fd, 0)
        assert os.fstat(record.fd).st_size == SIZE
    finally:
        os.close(child_fd)


def test_every_status_field_is_hot_or_cold():
    from urc.link.status_record import AXIS_COLD, AXIS_HOT, STATUS_COLD, STATUS_HOT

    names = {f.name for f in dataclasses.fields(Status)}
    assert set(STATUS_HOT) <= names and set(STATUS_HOT) | set(STATUS_COLD) == names
    assert set(HotStatus._fields) - {"tick", "cold_gen", "pid"} == set(STATUS_HOT)
    assert AXIS_HOT == HotAxis._fields and AXIS_HOT + AXIS_COLD == tuple(f.name for f in dataclasses.fields(AxisStatus))
