"""The control process's status in shared memory: one fixed-layout record the tick writes
and the I/O process reads whenever it likes, from any thread, with no thread of its own.

Why (issues 33 and 34): the pickled Status went over the socket to a reader thread in the
I/O process (now its event loop reads the socket), and a busy machine starves either. The I/O process judged from it
whether the control process was frozen, so a starved I/O process killed a healthy control
process. This record's ``tick`` and ``t_s`` show whether the control loop runs, whatever
the I/O process's own threads are doing. It also carries the Status fields that change
every tick ("hot"); the others ("cold": faults, events, settings, the loop dict, ...) change
rarely, and ``cold_gen`` counts their changes, so the reader knows when it needs the full
pickled Status (still sent on the socket) and can :func:`merge` the hot fields into the last
one it has.

Shared how: an anonymous memfd that the parent (the I/O process) makes (:meth:`StatusRecord.create`)
and hands to the child it starts (``subprocess.Popen(pass_fds=(record.fd,))``). The child
then calls :meth:`StatusRecord.attach` with the fd number. This is preferred over
multiprocessing.shared_memory because a named segment in /dev/shm outlives a killed
process unless someone unlinks it. Python's resource tracker unlinks it on one side's
exit even while the other still uses it. Two urc instances would also need names that
never collide, and any process of the same user can open a name. A memfd has no name: it
is gone once the last fd and mapping are closed, and only a process that was handed the
fd can map it. It is sealed to its size, so a confused control process cannot truncate
it under the reader; the reader's next access would otherwise kill it with SIGBUS.

Use: the control tick (the only writer) does ``gen = cold.update(status)`` (a
:class:`ColdGeneration`) and ``record.write(status, tick, gen)``, and pickles the full
Status only when ``gen`` changed, tagged with ``gen`` so the reader knows which generation
it holds. The reader's watch reads :meth:`StatusRecord.liveness`; a status query reads
:meth:`StatusRecord.read` and :func:`merge`\\s it into the full Status of that generation
(an older one lacks a change that is still on its way).

Layout (bytes; the header is written once, by :meth:`create`):

====== ==== =============================================================================
offset size field
====== ==== =============================================================================
0      4    magic ``b"urcS"``
4      4    version (uint32, little-endian): :data:`VERSION`, bumped whenever the layout changes
8      4    body size in bytes (uint32): a reader built for another layout refuses the record
12     4    (zero)
16     8    seq: the sequence lock's counter (uint64, native order): odd while a write is under way
24     N    body, little-endian :data:`BODY` (below)
24+N   4    CRC-32 of the body (uint32, little-endian)
====== ==== =============================================================================

Body, in order (NaN stands for None in the fields marked "or None"):

* ``tick`` uint64: +1 per control tick (the writer's count); ``t_s`` float64: the tick's
  time, CLOCK_MONOTONIC seconds (Status.t_s: ``time.monotonic()`` in the control process,
  the same clock in every process of the machine); ``cold_gen`` uint64: bumped by the
  writer whenever a cold field changed (:class:`ColdGeneration`); ``pid`` uint32: the writer.
* ``az_deg``, ``el_deg`` (or None: no elevation axis), ``target_az_deg`` (or None),
  ``target_el_deg`` (or None), ``tick_late_p99_ms``: float64 each.
* ``wrap_turns`` int32.
* ``flipped``, ``moving``, ``parked``, ``position_known``, ``has_el`` (the el block below is
  meaningful): one byte each (0/1).
* then for az and for el (zeros when ``has_el`` is 0), in AxisStatus order:
  ``pos_deg`` float64, ``rate_deg_per_s`` float64, ``target_deg`` float64 (or None),
  ``mode`` uint8 (the index in :data:`MODES`: idle, releasing, driving, holding),
  ``duty`` float64, ``brake_released`` byte, ``uncertainty_deg`` float64, ``limit_min`` byte,
  ``limit_max`` byte, ``current_a`` float64, ``sensor_ok`` byte.
"""

from __future__ import annotations

import dataclasses
import fcntl
import math
import mmap
import operator
import os
import struct
import typing
import zlib
from typing import Any, NamedTuple

from ..control.law import Mode
from ..errors import UrcError
from ..model.snapshot import AxisStatus, Status

MAGIC = b"urcS"
VERSION = 1
#: the axis modes, in the order of their codes (the control law's Literal)
MODES: tuple[str, ...] = typing.get_args(Mode)
_MODE_CODE = {m: i for i, m in enumerate(MODES)}

_HEADER = struct.Struct("<4sIII")
_AXIS = "ddd" "B" "d?d??d?"
BODY = struct.Struct("<QdQI" "ddddd" "i" "?????" + _AXIS + _AXIS)
_CRC = struct.Struct("<I")
_LIVENESS = struct.Struct("<QdQI")  # the body's first four fields
_SEQ_OFF = 16
_BODY_OFF = 24
_CRC_OFF = _BODY_OFF + BODY.size
SIZE = _CRC_OFF + _CRC.size
#: how often a read tries again while the writer is mid-write before it gives the last
#: good copy (a write takes about a microsecond; a writer stopped mid-write never ends it)
READ_TRIES = 64
_NAN = math.nan
_NO_AXIS = (0.0, 0.0, 0.0, 0, 0.0, False, 0.0, False, False, 0.0, False)

#: Status fields the record carries (AxisStatus's: all but ``sensor_error``); the others are
#: cold, every field added to Status later included
STATUS_HOT = ("t_s", "az_deg", "el_deg", "az", "el", "target_az_deg", "target_el_deg", "flipped",
              "wrap_turns", "moving", "parked", "position_known", "tick_late_p99_ms")
AXIS_HOT = ("pos_deg", "rate_deg_per_s", "target_deg", "mode", "duty", "brake_released",
            "uncertainty_deg", "limit_min", "limit_max", "current_a", "sensor_ok")
STATUS_COLD = tuple(f.name for f in dataclasses.fields(Status) if f.name not in STATUS_HOT)
AXIS_COLD = tuple(f.name for f in dataclasses.fields(AxisStatus) if f.name not in AXIS_HOT)


class StatusRecordError(UrcError):
    """An fd that is not a status record this code can read (another version, not sealed)."""


class HotAxis(NamedTuple):
    """An AxisStatus's hot fields (names and order as AxisStatus's)."""
    pos_deg: float
    rate_deg_per_s: float
    target_deg: float | None
    mode: str
    duty: float
    brake_released: bool
    uncertainty_deg: float
    limit_min: bool
    limit_max: bool
    current_a: float
    sensor_ok: bool


class HotStatus(NamedTuple):
    """One record as read: the tick, its time and writer, and the Status's hot fields."""
    tick: int
    t_s: float
    cold_gen: int
    pid: int
    az_deg: float
    el_deg: float | None
    target_az_deg: float | None
    target_el_deg: float | None
    tick_late_p99_ms: float
    wrap_turns: int
    flipped: bool
    moving: bool
    parked: bool
    position_known: bool
    az: HotAxis
    el: HotAxis | None


# (tuple.__new__: a named tuple made from its values without its __new__'s keyword
# handling, a microsecond less per read; ``x != x``: NaN, the only float unequal to itself)
_tuple = tuple.__new__


def _hot_axis(v: tuple) -> HotAxis:
    t = v[2]
    return _tuple(HotAxis, (v[0], v[1], None if t != t else t, MODES[v[3]], *v[4:]))


# Why a sequence lock written in Python holds. The writer stores seq odd, copies the body
# and its CRC in one slice assignment (a memcpy in mmap's C code), then stores seq even. The
# reader loads seq, copies the whole record in one slice (a memcpy into a new bytes), loads
# seq again, and only then unpacks its copy. It never unpacks fields straight out of the
# mapping: the writer could change the record between two of them. seq goes through a
# memoryview cast to "Q": one aligned 8-byte load or store (a memcpy of a constant 8 bytes,
# compiled to one instruction),
# which no CPU splits. struct's "<Q" goes byte by byte, and one increment can carry over
# several bytes.
# * Within a process the GIL serialises the two memcpys (a reader thread in the writer's own
#   process, as in the tests); the seq check covers what runs between them.
# * Between processes no Python statement is a fence. The C compiler cannot move the
#   accesses across the interpreter's calls in between: a call into code it cannot see
#   could touch any memory. An x86-64 CPU (TSO) makes stores visible in program order and
#   does not reorder loads with loads, so there the seqlock alone is exact. An ARM CPU (the
#   Raspberry Pi) may do either out of order. The hundreds of interpreter instructions
#   between the accesses make that rare, but not impossible. So the body carries a CRC-32,
#   checked after the sequence: a copy torn that way is retried like any other (a torn copy
#   whose CRC still matches: about 1 in 4e9 of such tears).
# * One writer: the seqlock needs one (the control tick's thread); a second one, from
#   another thread, could interleave with it.
class StatusRecord:
    """The shared record: :meth:`create` (parent), :meth:`attach` (child, from the fd number),
    :meth:`write` (the control tick), :meth:`read` / :meth:`liveness` (anyone)."""

    def __init__(self, fd: int, mm: mmap.mmap):
        self._fd = fd
        self._mm = mm
        self._seq = memoryview(mm)[_SEQ_OFF:_SEQ_OFF + 8].cast("Q")
        self._pid = os.getpid()
        self._wseq: int | None = None  # the writer's own seq (known from its first write on)
        self._last: HotStatus | None = None
        #: (seq, the record copied at it): while the record's seq is still that, nothing was
        #: written since (one tuple: a reader on another thread sees both or neither)
        self._at_seq: tuple[int, HotStatus | None] = (-1, None)
        self._last_live: tuple[int, float, int] | None = None
        #: reads retried: the writer was mid-write (seq odd), or wrote during the copy (seq
        #: changed), or the copy's CRC did not match (see above: never on x86-64)
        self.busy_retries = self.torn_retries = self.crc_rejects = 0

    @classmethod
    def create(cls) -> StatusRecord:
        """A new record (the parent; its :attr:`fd` is then handed to the child)."""
        fd = os.memfd_create("urc-status", os.MFD_CLOEXEC | os.MFD_ALLOW_SEALING)
        try:
            os.ftruncate(fd, SIZE)
            # (sealed to this size: nobody can shrink it under a reader's mapping)
            fcntl.fcntl(fd, fcntl.F_ADD_SEALS, fcntl.F_SEAL_SHRINK | fcntl.F_SEAL_GROW | fcntl.F_SEAL_SEAL)
            mm = mmap.mmap(fd, SIZE)
            _HEADER.pack_into(mm, 0, MAGIC, VERSION, BODY.size, 0)
        except BaseException:
            os.close(fd)
            raise
        return cls(fd, mm)

    @classmethod
    def attach(cls, fd: int) -> StatusRecord:
        """The record ``fd`` (inherited from the parent): refused unless it is a sealed
        record of this very layout. Closing the record closes ``fd``."""
        try:
            seals = fcntl.fcntl(fd, fcntl.F_GET_SEALS)
        except OSError as exc:
            raise StatusRecordError(f"fd {fd} is no status record (not a memfd: {exc})") from None
        if not seals & fcntl.F_SEAL_SHRINK:
            raise StatusRecordError(f"fd {fd} is no status record (a memfd unsealed: it could shrink under the reader)")
        if os.fstat(fd).st_size < SIZE:
            raise StatusRecordError(f"fd {fd} is no status record (smaller than {SIZE} bytes)")
        mm = mmap.mmap(fd, SIZE)
        header = _HEADER.unpack_from(mm, 0)
        if header[:3] != (MAGIC, VERSION, BODY.size):
            mm.close()
            raise StatusRecordError(
                f"fd {fd}: status record {header[0]!r} version {header[1]} ({header[2]} bytes), "
                f"this code reads {MAGIC!r} version {VERSION} ({BODY.size} bytes)")
        return cls(fd, mm)

    @property
    def fd(self) -> int:
        return self._fd

    def close(self) -> None:
        self._seq.release()
        self._mm.close()
        os.close(self._fd)

    # ------------------------------------------------------------------ the writer
    def write(self, status: Status, tick: int, cold_gen: int) -> None:
        """Publish ``status``'s hot fields as tick ``tick``. From one thread only (the
        tick's). Raises ValueError for an axis mode not in :data:`MODES`, struct.error for
        a number the layout cannot hold (both: the caller's bug)."""
        a, e = status.az, status.el
        el_deg, taz, tel = status.el_deg, status.target_az_deg, status.target_el_deg
        try:
            body = BODY.pack(
                tick, status.t_s, cold_gen, self._pid,
                status.az_deg, _NAN if el_deg is None else el_deg, _NAN if taz is None else taz,
                _NAN if tel is None else tel, status.tick_late_p99_ms, status.wrap_turns,
                status.flipped, status.moving, status.parked, status.position_known, e is not None,
                a.pos_deg, a.rate_deg_per_s, _NAN if a.target_deg is None else a.target_deg, _MODE_CODE[a.mode],
                a.duty, a.brake_released, a.uncertainty_deg, a.limit_min, a.limit_max, a.current_a, a.sensor_ok,
                *(_NO_AXIS if e is None else (
                    e.pos_deg, e.rate_deg_per_s, _NAN if e.target_deg is None else e.target_deg, _MODE_CODE[e.mode],
                    e.duty, e.brake_released, e.uncertainty_deg, e.limit_min, e.limit_max, e.current_a,
                    e.sensor_ok)))
        except KeyError as exc:
            raise ValueError(f"axis mode {exc.args[0]!r} has no code in the status record ({MODES})") from None
        data = body + _CRC.pack(zlib.crc32(body))
        seq = self._wseq
        if seq is None:  # (a writer attached to a used record goes on from its seq, even)
            seq = self._seq[0] + 1 & ~1
        self._seq[0] = seq + 1
        self._mm[_BODY_OFF:SIZE] = data
        self._seq[0] = self._wseq = seq + 2

    # ------------------------------------------------------------------ readers
    def _copy(self) -> tuple[bytes, int] | None:
        """A consistent copy of body and CRC, and the seq it was copied at; None if nothing
        was written yet, or the writer held the record through every try."""
        seq, mm = self._seq, self._mm
        for _ in range(READ_TRIES):
            s = seq[0]
            if s & 1:
                self.busy_retries += 1
                continue
            data = mm[_BODY_OFF:SIZE]
            if seq[0] != s:
                self.torn_retries += 1
                continue
            if s == 0:
                return None
            if zlib.crc32(data[:-4]) != _CRC.unpack_from(data, BODY.size)[0]:
                self.crc_rejects += 1
                continue
            return data, s
        return None

    def read(self) -> HotStatus | None:
        """The newest record; the last good one if the writer held it through every try
        (a writer stopped mid-write: its ``tick`` then stops advancing); None before the
        first write."""
        at_seq, same = self._at_seq
        if self._seq[0] == at_seq:  # (nothing written since: each rotctld p between two ticks
            return same             # costs one load, not a copy and an unpack)
        copied = self._copy()
        if copied is None:
            return self._last
        data, seq = copied
        v = BODY.unpack_from(data)
        e, ta, te = v[5], v[6], v[7]
        try:
            hot: HotStatus = _tuple(HotStatus, (
                *v[:5], None if e != e else e, None if ta != ta else ta, None if te != te else te, *v[8:14],
                _hot_axis(v[15:26]), _hot_axis(v[26:]) if v[14] else None))
        except IndexError:  # (a mode code past MODES: a writer of another build; the CRC matched)
            self.crc_rejects += 1
            return self._last
        self._last = hot
        self._at_seq = (seq, hot)
        return hot

    def liveness(self) -> tuple[int, float, int] | None:
        """``(tick, t_s, pid)`` of the newest record, unpacking no more than those (the
        last good ones if the writer held the record through every try; None before the
        first write)."""
        copied = self._copy()
        if copied is None:
            return self._last_live
        tick, t_s, _gen, pid = _LIVENESS.unpack_from(copied[0])
        self._last_live = (tick, t_s, pid)
        return self._last_live


# ---------------------------------------------------------------------- cold fields
_cold_of = operator.attrgetter(*STATUS_COLD)
_axis_cold_of = operator.attrgetter(*AXIS_COLD) if AXIS_COLD else (lambda _a: ())


def cold_key(status: Status) -> tuple:
    """What :func:`merge` cannot restore from a record: two statuses with equal keys differ
    in hot fields only. Equality of the keys is cheap on the statuses build_status makes:
    the sub-objects it copies afresh every tick (the faults and events tuples, the loop,
    limits and offsets dicts) hold the same elements while nothing changed, and
    tuple and dict comparison take an element identical to the other as equal without
    comparing it further. The simulator's truth dict, different on every tick, is the
    exception: on the simulator every tick is a cold change."""
    el = status.el
    return _cold_of(status), _axis_cold_of(status.az), None if el is None else _axis_cold_of(el)


class ColdGeneration:
    """The writer's count of cold changes: ``gen = cold.update(status)`` every tick, then
    ``record.write(status, tick, gen)``; a new generation means the full Status must go out."""

    def __init__(self) -> None:
        self.gen = 0
        self._key: Any = None

    def update(self, status: Status) -> int:
        key = cold_key(status)
        if key != self._key:
            self._key = key
            self.gen += 1
        return self.gen


#: the Status fields :func:`merge` takes from HotStatus[4:14], in HotStatus's order
_MERGED = HotStatus._fields[4:14]
_new = object.__new__
_set_attr = object.__setattr__


def _replaced(obj: Any, names: tuple[str, ...], values: Any) -> Any:
    """Frozen dataclass ``obj`` with ``names`` set to ``values``: urc.control.evolve's copy
    of the instance dict, without its keyword arguments and check of the names (fixed
    here, and tested): merge runs on every status read."""
    fields = obj.__dict__.copy()
    fields.update(zip(names, values))
    new = _new(type(obj))
    _set_attr(new, "__dict__", fields)
    return new


def merge(cold: Status, hot: HotStatus) -> Status:
    """``cold`` with the hot fields and ``t_s`` of ``hot``: equal to the status the record
    was written from whenever ``cold``'s :func:`cold_key` is that status's (a fraction of
    dataclasses.replace's cost: bench/status_record_bench.py)."""
    el: Any = hot.el
    if el is not None:  # (an axis the cold status lacks: its cold fields at their defaults)
        el = AxisStatus(*el) if cold.el is None else _replaced(cold.el, AXIS_HOT, el)
    fields = cold.__dict__.copy()
    fields.update(zip(_MERGED, hot[4:14]))
    fields["t_s"], fields["az"], fields["el"] = hot.t_s, _replaced(cold.az, AXIS_HOT, hot.az), el
    new = _new(Status)
    _set_attr(new, "__dict__", fields)
    return new
