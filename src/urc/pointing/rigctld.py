"""A rig's S-meter through Hamlib's ``rigctld``: ``l STRENGTH`` over TCP.

rigctld answers ``l STRENGTH`` with one line, the signal in whole dB relative to S9
(S9 = 0, S0 = -54; Hamlib's ``RIG_LEVEL_STRENGTH``), or ``RPRT -n`` when the rig cannot
say (``RPRT -11``: the backend has no S-meter). The sample time is the middle of the
round trip. A blocking client with a timeout: run it in a worker thread, never on an
event loop.
"""

from __future__ import annotations

import socket
import time

from .sources import Clock, Sample, SignalRefused, judge

#: Hamlib's error codes a reply may carry (rig.h ``enum rig_errcode_e``), for messages
_RPRT = {-1: "invalid parameter", -4: "not implemented", -5: "communication timed out",
         -6: "I/O error", -9: "command rejected by the rig", -11: "feature not available"}


def parse_strength(line: str) -> int:
    """The dB of one ``l STRENGTH`` answer line, or SignalRefused("bad")."""
    text = line.strip()
    if text.startswith("RPRT"):
        code = text[4:].strip()
        what = _RPRT.get(int(code), "error") if code.lstrip("-").isdigit() else "error"
        raise SignalRefused("bad", f"rigctld answered {text!r} ({what})")
    try:
        return int(text)
    except ValueError:
        raise SignalRefused("bad", f"rigctld: expected a whole number of dB, found {text[:40]!r}") from None


class RigctldStrength:
    """``read()``: the S-meter now, in dB over S9. ``ceiling_db``: where the rig's meter
    tops out (S9+60 dB on most rigs), refused as saturated."""

    def __init__(self, host: str = "127.0.0.1", port: int = 4532, *, timeout_s: float = 1.0,
                 ceiling_db: float | None = None, clock: Clock = time.time, name: str = ""):
        self.host, self.port, self.timeout_s = host, int(port), float(timeout_s)
        self.ceiling_db = ceiling_db
        self.clock = clock
        self.name = name or f"rigctld {host}:{port}"
        self._sock: socket.socket | None = None
        self._buf = b""

    def _connect(self) -> socket.socket:
        if self._sock is None:
            try:
                self._sock = socket.create_connection((self.host, self.port), timeout=self.timeout_s)
            except OSError as exc:
                raise SignalRefused("missing", f"{self.name}: cannot connect: {exc}") from None
            self._buf = b""
        return self._sock

    def _line(self, sock: socket.socket) -> bytes:
        deadline = time.monotonic() + self.timeout_s
        while b"\n" not in self._buf:
            left_s = deadline - time.monotonic()
            if left_s <= 0:
                raise TimeoutError
            sock.settimeout(left_s)
            chunk = sock.recv(4096)
            if not chunk:
                raise ConnectionError("closed by rigctld")
            self._buf += chunk
            if len(self._buf) > 4096:
                raise SignalRefused("bad", f"{self.name}: no line end in {len(self._buf)} bytes")
        line, self._buf = self._buf.split(b"\n", 1)
        return line

    def read(self) -> Sample:
        sock = self._connect()
        t0_s = self.clock()
        try:
            sock.sendall(b"l STRENGTH\n")
            line = self._line(sock)
        except (OSError, TimeoutError, ConnectionError, SignalRefused) as exc:
            self.close()  # a late answer must not be taken for the next question's
            if isinstance(exc, SignalRefused):
                raise
            raise SignalRefused("missing", f"{self.name}: no answer to l STRENGTH ({exc or 'timeout'})") from None
        t_s = (t0_s + self.clock()) / 2.0
        db = parse_strength(line.decode("ascii", "replace"))
        return judge(t_s, float(db), "dB", now_s=t_s, max_age_s=None, ceiling=self.ceiling_db,
                     what=self.name)

    def close(self) -> None:
        if self._sock is not None:
            try:
                self._sock.close()
            finally:
                self._sock = None
