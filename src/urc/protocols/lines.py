"""Line input and output shared by every line-based session (Tartu, SARCNET, G4JNT,
Easycomm, GS-232).

* :class:`LineSplitter`: bytes -> lines ended by CR, LF or CRLF, any split, bounded;
  backspace editing on request (consoles a person types at; off for machine protocols).
* :class:`TerminalEcho`: character echo for a console (Tartu ``ECHO ON``).
* :func:`crlf_line`: one reply line ending CR LF.
* :func:`next_due_s`: the pace of an unsolicited line stream (G4JNT, SARCNET).

Pure, no I/O (the splitter logs a dropped line when given a logger).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Protocol

from .base import MAX_PENDING_BYTES

_EOL_RE = re.compile(rb"[\r\n]")
_CR, _LF = 0x0D, 0x0A
_BACKSPACES = (0x08, 0x7F)


@dataclass(frozen=True)
class Line:
    """One complete input line (terminator removed), or an overflow notice."""

    text: bytes
    overflowed: bool = False


class WarningLog(Protocol):
    """Where a dropped line is told: a ``logging.Logger`` or a ``RateLimitedLog``."""

    def warning(self, msg: str, *args: object) -> None: ...


class LineSplitter:
    """Split a byte stream into lines ended by CR, LF or CRLF (CRLF counts once, so a
    CRLF client gets no extra empty line; LF CR still makes one). Empty lines are
    passed on: each session decides what an empty line means.

    A line longer than ``max_len`` is dropped: one ``Line(b"", overflowed=True)`` is
    produced at once (so the session can answer while the flood goes on) and everything
    up to the next terminator is discarded with it (its tail is not a command), so the
    stream resynchronises at the next line. With ``log``, the drop is logged there.

    ``backspace``: BS/DEL delete the previous character, as on a terminal (consoles);
    off, they are ordinary bytes of the line (machine protocols).
    """

    def __init__(self, max_len: int = MAX_PENDING_BYTES, *, backspace: bool = False,
                 log: WarningLog | None = None):
        self.max_len = max_len
        self.backspace = backspace
        self.log = log
        self._buf = bytearray()
        self._after_cr = False
        self._discarding = False

    @property
    def pending(self) -> int:
        """How many bytes of an unfinished line are buffered (at most ``max_len``)."""
        return len(self._buf)

    @property
    def partial(self) -> bytes:
        """The unfinished line so far (what a terminal would show after the prompt)."""
        return bytes(self._buf)

    def feed(self, data: bytes) -> list[Line]:
        data = bytes(data)
        lines: list[Line] = []
        start = 0
        for m in _EOL_RE.finditer(data):
            end = m.start()
            self._add(data[start:end], lines)
            start = m.end()
            if data[end] == _LF and (data[end - 1] == _CR if end else self._after_cr):
                continue                                  # the LF of a CRLF
            if not self._discarding:
                lines.append(Line(bytes(self._buf)))
            self._buf.clear()
            self._discarding = False
        self._add(data[start:], lines)
        if data:
            self._after_cr = data[-1] == _CR
        return lines

    def _add(self, chunk: bytes, lines: list[Line]) -> None:
        """Append terminator-free bytes to the line being collected."""
        if self._discarding or not chunk:
            return
        if self.backspace and (b"\x08" in chunk or b"\x7f" in chunk):
            for byte in chunk:
                if byte in _BACKSPACES:
                    if self._buf:
                        del self._buf[-1]
                    continue
                self._buf.append(byte)
                if len(self._buf) > self.max_len:
                    self._overflow(lines)
                    return
        elif len(self._buf) + len(chunk) > self.max_len:
            self._overflow(lines)
        else:
            self._buf += chunk

    def _overflow(self, lines: list[Line]) -> None:
        self._buf.clear()
        self._discarding = True
        lines.append(Line(b"", overflowed=True))
        if self.log is not None:
            self.log.warning("line longer than %d bytes dropped", self.max_len)


class TerminalEcho:
    """Character echo for a console session (Tartu ``ECHO ON``): what a terminal needs
    to show the line being typed, with backspaces rubbed out and CRLF at each end."""

    def __init__(self) -> None:
        self._shown = b""

    def update(self, partial: bytes) -> bytes:
        """Echo that brings the screen from what was shown to ``partial``."""
        common = 0
        for a, b in zip(self._shown, partial):
            if a != b:
                break
            common += 1
        out = b"\b \b" * (len(self._shown) - common) + partial[common:]
        self._shown = partial
        return out

    def end_line(self, text: bytes) -> bytes:
        out = self.update(text) + b"\r\n"
        self._shown = b""
        return out


def crlf_line(text: str) -> bytes:
    """One reply line: ASCII (anything else as ``?``) ending CR LF."""
    return text.encode("ascii", "replace") + b"\r\n"


def next_due_s(due_s: float | None, now_s: float, interval_s: float) -> float | None:
    """Pacing of an unsolicited line stream (G4JNT position, SARCNET monitor) from
    ``tick(now_s)``: ``due_s`` is when the next line is due (None: at once). Returns
    None when no line is due yet, else when the line after it is due. One line per tick
    at most: after a stall the period restarts from now instead of catching up."""
    if due_s is not None and now_s < due_s - 1e-9:   # float drift
        return None
    nxt = now_s if due_s is None else due_s + interval_s
    return nxt if nxt > now_s else now_s + interval_s
