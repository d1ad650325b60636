"""Position state in an I2C FRAM (MB85RC256V class, the Tartu board's non-volatile
memory) instead of a file on the SD card: no wear, no file system, a write that is
done the moment the bus transfer ends.

Same interface as :class:`urc.persistence.StateStore` (load, save, fresh,
mark_initialised, quarantine). Layout: byte 0 = initialised flag, then two slots
(A at 0x0010, B at 0x4008), each ``URCF`` + sequence (u32) + length (u32) + CRC-32 of
the payload (u32) + the canonical JSON payload. A save goes to the slot *not* holding
the newest good record, so a write torn by the power cut leaves the previous record
whole; load takes the good record with the highest sequence.
"""

from __future__ import annotations

import json
import logging
import struct
import time
import zlib
from pathlib import Path
from typing import Any

from ..errors import StateFileError
from ..persistence import check_finite, nonfinite_field, record_problem

log = logging.getLogger(__name__)

MAGIC = b"URCF"
HEADER = struct.Struct(">4sIII")
FLAG_ADDR = 0x0000
FLAG_SET = 0xA5
#: bytes per bus transfer: under smbus2's and the adapter's limits, and short, since the
#: tick's chip reads on the same bus wait for each one (32 bytes at the Pi's default
#: 100 kHz: ~3 ms, a sixth of a 50 Hz tick)
CHUNK = 30
#: a pause between two transfers of one record, so a tick waiting for the bus gets it
#: (a lock is not handed over: the writer could take it straight back)
YIELD_S = 0.001


class FramStore:
    def __init__(self, bus: Any, address: int = 0x50, size_bytes: int = 32768, state_dir: Any = None):
        self.bus, self.address, self.size_bytes = bus, address, size_bytes
        half = size_bytes // 2
        self.slots = (0x0010, half + 8)
        self.slot_bytes = half - 16
        # like StateStore.path: names the store in messages; its parent is the state
        # directory the rest of urc (settings, history) uses
        self.path = Path(state_dir or ".") / f"FRAM 0x{address:02x}"

    # ---------------------------------------------------------------- bus
    # (the bus is shared with the tick's chip reads, each transfer one transaction: a
    # real bus is a SerialisedBus; a save runs on the state writer's thread, never the tick)
    def _write(self, mem: int, data: bytes) -> None:
        for i in range(0, len(data), CHUNK):
            a = mem + i
            if i:
                time.sleep(YIELD_S)
            try:
                self.bus.write_i2c_block_data(self.address, a >> 8, [a & 0xFF, *data[i:i + CHUNK]])
            except OSError as exc:
                raise StateFileError(f"{self.path}: write failed ({exc})") from exc

    def _read(self, mem: int, n: int) -> bytes:
        from smbus2 import i2c_msg
        out = bytearray()
        for i in range(0, n, CHUNK):
            a, k = mem + i, min(CHUNK, n - i)
            if i:
                time.sleep(YIELD_S)
            w, r = i2c_msg.write(self.address, [a >> 8, a & 0xFF]), i2c_msg.read(self.address, k)
            try:
                self.bus.i2c_rdwr(w, r)
            except OSError as exc:
                raise StateFileError(f"{self.path}: read failed ({exc})") from exc
            out += bytes(r)
        return bytes(out)

    # ---------------------------------------------------------------- records
    def _slot(self, i: int) -> tuple[int, dict[str, Any]] | None | str:
        """(seq, payload), None when empty, or a string saying what is wrong."""
        head = self._read(self.slots[i], HEADER.size)
        magic, seq, length, crc = HEADER.unpack(head)
        if magic != MAGIC:
            return None if magic in (b"\x00" * 4, b"\xff" * 4) else f"slot {'AB'[i]}: no record"
        if length > self.slot_bytes - HEADER.size:
            return f"slot {'AB'[i]}: length {length} out of range"
        body = self._read(self.slots[i] + HEADER.size, length)
        if zlib.crc32(body) != crc:
            return f"slot {'AB'[i]}: checksum mismatch"
        try:
            payload = json.loads(body)
        except ValueError:
            return f"slot {'AB'[i]}: not JSON"
        if not isinstance(payload, dict):
            return f"slot {'AB'[i]}: no payload"
        bad = nonfinite_field(payload)
        if bad is not None:
            return f"slot {'AB'[i]}: {bad} is not a finite number"
        wrong = record_problem(payload)
        return (seq, payload) if wrong is None else f"slot {'AB'[i]}: {wrong}"

    def _newest(self) -> tuple[int | None, tuple[int, dict[str, Any]] | None, list[str]]:
        best, best_i, bad = None, None, []
        for i in (0, 1):
            s = self._slot(i)
            if isinstance(s, str):
                bad.append(s)
            elif s is not None and (best is None or s[0] > best[0]):
                best, best_i = s, i
        return best_i, best, bad

    def load(self) -> dict[str, Any] | None:
        _, best, bad = self._newest()
        if best is None:
            if bad:
                raise StateFileError(f"{self.path}: no good record ({'; '.join(bad)})")
            return None
        if bad:
            log.warning("%s: %s; using the other slot", self.path, "; ".join(bad))
        return best[1]

    def save(self, payload: dict[str, Any]) -> None:
        check_finite(payload, self.path)
        body = json.dumps(payload, sort_keys=True, separators=(",", ":")).encode()
        if len(body) > self.slot_bytes - HEADER.size:
            raise StateFileError(f"{self.path}: record of {len(body)} bytes does not fit")
        i, best, _ = self._newest()
        target = 0 if i is None else 1 - i
        seq = 1 if best is None else best[0] + 1
        # body first, header last: a cut before the header leaves the slot invalid, never half new
        self._write(self.slots[target] + HEADER.size, body)
        self._write(self.slots[target], HEADER.pack(MAGIC, seq, len(body), zlib.crc32(body)))

    def fresh(self) -> bool:
        flag = self._read(FLAG_ADDR, 1)[0]
        return flag != FLAG_SET and self._newest()[1] is None and not self._newest()[2]

    def mark_initialised(self) -> None:
        if self._read(FLAG_ADDR, 1)[0] != FLAG_SET:
            self._write(FLAG_ADDR, bytes([FLAG_SET]))

    def quarantine(self) -> None:
        """Nothing to set aside: the damaged slot is overwritten by the next save,
        the other slot is kept."""
        log.warning("%s: damaged record left in place; the next save replaces it", self.path)
        return None
