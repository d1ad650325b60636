"""Writing a configuration as a fresh TOML document (``Config.to_toml``). Editing a
user's file in place, keeping its comments and layout, is :mod:`urc.web.toml_edit`."""

from __future__ import annotations

import math
import re
from typing import Any



def strip_none(value: Any) -> Any:
    if isinstance(value, dict):
        return {k: strip_none(v) for k, v in value.items() if v is not None}
    if isinstance(value, (list, tuple)):
        return [strip_none(v) for v in value]
    return value


_BARE_KEY = re.compile(r"^[A-Za-z0-9_-]+$")


def _toml_key(key: str) -> str:
    return key if _BARE_KEY.match(key) else _toml_str(key)


def _toml_str(s: str) -> str:
    out = ['"']
    for ch in s:
        o = ord(ch)
        if ch == '"':
            out.append('\\"')
        elif ch == "\\":
            out.append("\\\\")
        elif ch == "\n":
            out.append("\\n")
        elif ch == "\t":
            out.append("\\t")
        elif o < 0x20 or o == 0x7F:
            out.append(f"\\u{o:04x}")
        elif 0xD800 <= o <= 0xDFFF:  # lone surrogate: not representable, replace
            out.append("\\ufffd")
        else:
            out.append(ch)
    out.append('"')
    return "".join(out)


def _toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if not math.isfinite(v):  # pragma: no cover - the schema forbids it
            raise ValueError(f"cannot write {v!r}")
        return repr(v)
    if isinstance(v, str):
        return _toml_str(v)
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(i) for i in v) + "]"
    if isinstance(v, dict):  # inline table, e.g. [[serve]] options
        return "{ " + ", ".join(f"{_toml_key(k)} = {_toml_value(i)}" for k, i in v.items()) + " }"
    raise TypeError(f"cannot write {type(v).__name__} to TOML")  # pragma: no cover


def dump_toml(data: dict[str, Any]) -> str:
    lines: list[str] = []

    def is_tables(v: Any) -> bool:  # a non-empty list of tables: written as [[name]]
        return isinstance(v, list) and bool(v) and all(isinstance(i, dict) for i in v)

    def table(prefix: str, d: dict[str, Any], header: str | None) -> None:
        scalars = [(k, v) for k, v in d.items() if not isinstance(v, dict) and not is_tables(v)]
        if header is not None and (scalars or (not d and header.startswith("[["))):
            if lines:
                lines.append("")
            lines.append(header)
        for k, v in scalars:
            lines.append(f"{_toml_key(k)} = {_toml_value(v)}")
        for k, v in d.items():
            name = f"{prefix}.{_toml_key(k)}" if prefix else _toml_key(k)
            if isinstance(v, dict):
                table(name, v, f"[{name}]")
            elif is_tables(v):
                for item in v:
                    table(name, item, f"[[{name}]]")

    table("", data, None)
    return "\n".join(lines) + "\n"
