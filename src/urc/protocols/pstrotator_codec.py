"""PstRotator UDP messages (protocols.md §5.2): parse a datagram, format replies.

A datagram holds one or more ``<PST>...</PST>`` envelopes; inside, any sequence of
elements ``<NAME>value</NAME>`` (AZIMUTH, ELEVATION, PARK, STOP, TRACK) and queries
``NAME?`` (AZ?, EL?, TGA?, TGE?). Names are matched case-insensitively. Text outside
an envelope and unparseable pieces inside are reported as garbage.

Numbers are read leniently, as Hamlib 4.6 writes them with ``%f.2`` (a bug):
``100.000000.2`` is 100.0. The accepted form is a decimal number followed only by
further ``.digits`` groups; exponents, ``nan`` and ``inf`` are refused.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

from .numbers import DECIMAL

_ENVELOPE = re.compile(rb"<PST>(.*?)</PST>", re.S | re.I)
_TOKEN = re.compile(rb"\s*(?:<([A-Z]+)>([^<]*)</\1>|([A-Z]+)\?)\s*", re.I)
_TOKEN_START = re.compile(rb"<([A-Z]+)>([^<]*)</\1>|[A-Z]+\?", re.I)
_LENIENT_NUMBER = re.compile(rf"\s*({DECIMAL})((?:\.\d*)*)\s*\Z")

SET_ELEMENTS = ("AZIMUTH", "ELEVATION", "PARK", "STOP", "TRACK")
QUERIES = ("AZ", "EL", "TGA", "TGE")


@dataclass(frozen=True)
class PstItem:
    kind: str             # "set" | "query" | "garbage"
    name: str = ""        # upper case element or query name
    value: str = ""       # raw element text (set)
    raw: bytes = b""      # the offending bytes (garbage)


def parse_datagram(data: bytes) -> list[PstItem]:
    """All items of one datagram, in order (garbage included, to be logged)."""
    items: list[PstItem] = []
    pos = 0
    for env in _ENVELOPE.finditer(data):
        if data[pos:env.start()].strip():
            items.append(PstItem("garbage", raw=data[pos:env.start()]))
        pos = env.end()
        inner = env.group(1)
        i = 0
        while i < len(inner):
            m = _TOKEN.match(inner, i)
            if not m or m.end() == i:
                # resynchronise on the next well-formed element or query
                found = _TOKEN_START.search(inner, i + 1)
                nxt = len(inner) if found is None else found.start()
                items.append(PstItem("garbage", raw=inner[i:nxt]))
                i = nxt
                continue
            if m.group(1) is not None:
                name = m.group(1).decode("ascii").upper()
                items.append(PstItem("set", name=name, value=m.group(2).decode("latin-1")))
            else:
                items.append(PstItem("query", name=m.group(3).decode("ascii").upper()))
            i = m.end()
    if data[pos:].strip():
        items.append(PstItem("garbage", raw=data[pos:]))
    return items


def parse_number(text: str) -> float:
    """'100.000000.2' -> 100.0; raises ValueError for anything else non-numeric."""
    m = _LENIENT_NUMBER.match(text)
    if not m:
        raise ValueError(f"expected a number like 123.4, got {text[:40]!r}")
    v = float(m.group(1))
    if not math.isfinite(v):
        raise ValueError(f"number {text[:40]!r} out of range")
    return v


def format_reply(name: str, value_deg: float) -> bytes:
    """``AZ:123.4\\r``: one value per datagram, as Hamlib cuts at the first CR/LF."""
    return f"{name}:{value_deg:.1f}\r".encode("ascii")


def format_set(name: str, value: float | int | str) -> bytes:
    """What a PstRotator client sends (for tests and bridges)."""
    return f"<PST><{name}>{value}</{name}></PST>".encode("ascii")


def format_query(name: str) -> bytes:
    return f"<PST>{name}?</PST>".encode("ascii")
