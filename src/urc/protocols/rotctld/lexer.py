"""rotctld's input tokenizer: a byte stream in, whole commands out.

rotctld reads a token stream, not lines (``rotctl_parse()`` in Hamlib, interactive mode
without prompt). Per command it reads:

* an optional extended-response prefix: ``+`` (separator ``\\n``), then optionally one
  punctuation character other than ``\\ _ #`` (that character becomes the separator);
* the command: one character, or ``\\`` + a long name of ``[A-Za-z0-9_]`` whose
  terminating character is consumed (so ``\\get_pos`` runs when its terminator arrives);
* as many whitespace-separated argument words as the command takes (``scanf("%s")``:
  line ends are just whitespace, so ``P 1\\n2\\n`` is ``P 1 2``); when the first one
  starts with ``?`` no more are read;
* ``#`` comments run to the end of the line, ``q``/``Q`` close, unknown characters and
  names are dropped silently (the session logs them), ``\\r``/``\\n`` between commands
  are skipped.

A no-argument command is complete the moment its character arrives; nothing waits for a
line end. Nothing is buffered beyond ``max_pending`` bytes of one unfinished command.
"""

from __future__ import annotations

import re
import string
from typing import Any

from ..base import MAX_PENDING_BYTES
from ...wire.rotctld.commands import BY_CHAR, BY_NAME, CommandSpec

# item kinds
CMD, CLOSE, UNKNOWN, OVERFLOW = range(4)
#: one lexer result: (kind, spec, args, sep). ``sep`` is None in default mode, else the
#: extended-response separator. UNKNOWN carries the dropped token in ``args[0]`` and
#: how many unknown one-character commands it stands for in ``args[1]`` (a run of them
#: is one item: junk costs a regex match, not a Python step per byte); OVERFLOW carries
#: the spec whose arguments were too long (or None).
#: (kind, spec, arguments, separator); an UNKNOWN run's arguments are (char, count)
Item = tuple[int, "CommandSpec | None", tuple[Any, ...], "str | None"]

_WS = b" \t\n\r\x0b\x0c"  # C isspace()
#: one argument word, complete only once whitespace follows it (as scanf("%s") needs)
_WORD = re.compile(rb"[ \t\n\r\x0b\x0c]*+([^ \t\n\r\x0b\x0c]++)(?=[ \t\n\r\x0b\x0c])")
_NAME = re.compile(rb"[A-Za-z0-9_]*+")
_EOL = re.compile(rb"[\r\n]")
_SPACE = re.compile(rb"[ \t\n\r\x0b\x0c]")

# byte classes
_SKIP, _PLUS, _PUNCT, _BSLASH, _HASH, _QUIT, _EOLC, _OTHER = range(8)


def _classify(b: int) -> int:
    ch = chr(b)
    if b in (0x0A, 0x0D):
        return _EOLC
    if ch in " \t\x0b\x0c":
        return _SKIP
    if ch == "+":
        return _PLUS
    if ch == "\\":
        return _BSLASH
    if ch == "#":
        return _HASH
    if ch in "qQ":
        return _QUIT
    if ch in string.punctuation and ch != "_":
        return _PUNCT
    return _OTHER


_CLASS = tuple(_classify(b) for b in range(256))

#: bytes that are unknown one-character commands and nothing else (no prefix, comment,
#: quit or long-name start): a run of them, with whitespace between, is skipped at once
_JUNK_BYTES = bytes(b for b in range(256) if _CLASS[b] == _OTHER and BY_CHAR[b] is None)
_JUNK_RUN = re.compile(b"[" + b"".join(b"\\x%02x" % b for b in _JUNK_BYTES) + rb" \t\n\r\x0b\x0c]*+")
_WS_BYTES = b" \t\n\r\x0b\x0c"

# lexer modes between feeds
_NORMAL, _COMMENT, _DISCARD = range(3)


class Lexer:
    """Incremental tokenizer; :meth:`feed` returns the items completed by ``data``."""

    __slots__ = ("_buf", "_mode", "max_pending")

    def __init__(self, max_pending: int = MAX_PENDING_BYTES):
        self._buf = b""
        self._mode = _NORMAL
        self.max_pending = max_pending

    @property
    def idle(self) -> bool:
        """No unfinished command, comment or discarded word pending."""
        return not self._buf and self._mode == _NORMAL

    def reset(self) -> None:
        self._buf, self._mode = b"", _NORMAL

    def feed(self, data: bytes) -> list[Item]:
        if self._mode != _NORMAL:
            data = self._leave_skip(data)
            if not data:
                return []
        buf = self._buf + data if self._buf else data
        n = len(buf)
        items: list[Item] = []
        cls = _CLASS
        i = 0
        while i < n:
            c = buf[i]
            k = cls[c]
            if k == _SKIP or k == _EOLC:
                i += 1
                continue
            start = i
            sep = None
            if k == _PLUS:
                sep = "\n"
                i += 1
                if i == n:
                    i = start
                    break
                c = buf[i]
                k = cls[c]
            if k == _PUNCT or k == _PLUS:  # after '+', a second '+' is a separator too
                sep = chr(c)
                i += 1
                if i == n:
                    i = start
                    break
                c = buf[i]
                k = cls[c]
            if k == _BSLASH:
                j = _NAME.match(buf, i + 1).end()  # type: ignore[union-attr]  # (matches "": never None)
                if j == n:  # the name ends only at its (consumed) terminator
                    if n - start > self.max_pending:
                        items.append((OVERFLOW, None, (), sep))
                        self._mode = _DISCARD
                        i = n
                    else:
                        i = start
                    break
                name = buf[i + 1:j].decode("ascii")
                i = j + 1
                spec = BY_NAME.get(name)
                if spec is None:
                    items.append((UNKNOWN, None, ("\\" + name,), sep))
                    continue
            elif k == _HASH:
                m = _EOL.search(buf, i + 1)
                if m is None:
                    self._mode = _COMMENT
                    i = n
                    break
                i = m.end()
                continue
            elif k == _QUIT:
                items.append((CLOSE, None, (), sep))
                i = n  # rotctld closes the connection: the rest is never read
                break
            elif k == _EOLC:  # a prefix followed by a line end is dropped
                i += 1
                continue
            else:
                spec = BY_CHAR[c]
                i += 1
                if spec is None:
                    end = _JUNK_RUN.match(buf, i).end()  # type: ignore[union-attr]  # (matches "")
                    count = 1 + (end - i) - sum(buf.count(w, i, end) for w in _WS_BYTES)
                    items.append((UNKNOWN, None, (chr(c), count), sep))
                    i = end
                    continue
            if not spec.n_args:
                items.append((CMD, spec, (), sep))
                continue
            end, args = _read_args(buf, i, spec)
            if end < 0:  # unfinished: keep it, unless it grew too long
                if n - start > self.max_pending:
                    items.append((OVERFLOW, spec, (), sep))
                    # the rest of a cut word must not be read as commands
                    self._mode = _DISCARD if buf[-1] not in _WS else _NORMAL
                    i = n
                else:
                    i = start
                break
            items.append((CMD, spec, args, sep))
            i = end
        self._buf = buf[i:] if i < n else b""
        return items

    def _leave_skip(self, data: bytes) -> bytes:
        """Drop the rest of a comment (to a line end) or of a cut word (to whitespace)."""
        if self._mode == _COMMENT:
            m = _EOL.search(data)
            if m is None:
                return b""
            self._mode = _NORMAL
            return data[m.end():]
        m = _SPACE.search(data)
        if m is None:
            return b""
        self._mode = _NORMAL
        return data[m.start():]


def _read_args(buf: bytes, i: int, spec: CommandSpec) -> tuple[int, tuple[str, ...]]:
    """(end, args) of the argument words from ``i``, or (-1, ()) if not all there yet."""
    if spec.rest_of_line:
        return _read_line(buf, i)
    args = []
    for k in range(spec.n_args):
        m = _WORD.match(buf, i)
        if m is None:
            return -1, ()
        word = m.group(1)
        args.append(word.decode("latin-1"))
        i = m.end()
        if k == 0 and word[0] == 0x3F:  # '?': a query, no further arguments are read
            break
    return i, tuple(args)


def _read_line(buf: bytes, i: int) -> tuple[int, tuple[str, ...]]:
    """``w``: fgets() the rest of the line (the next one if this one is empty)."""
    j = buf.find(b"\n", i)
    if j == i:
        i += 1
        j = buf.find(b"\n", i)
    if j < 0:
        return -1, ()
    line = buf[i:j]
    if line[:1] == b" ":
        line = line[1:]
    return j + 1, (line.decode("latin-1"),)
