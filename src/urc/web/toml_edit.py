"""Edit a person's TOML file in place: only the keys whose values changed are touched.

Comments, blank lines, key order, quoting and inline tables everywhere else stay byte for
byte (tomlkit keeps the document's own layout). What changes is decided by comparing two
plain configuration dicts, the one the file was showing and the new one, so a value that
only the command line set (``--emulate``, ``--port``) and that nobody changed is never
written: the same in both, it is not a change.
"""

from __future__ import annotations

import copy
import tomllib
from typing import Any

import tomlkit
from tomlkit.items import AoT, Table

_MISSING = object()


class EditError(ValueError):
    """The edited file would not say what was asked (it is left as it was)."""


def edit(text: str, old: dict[str, Any], new: dict[str, Any]) -> str:
    """``text`` with every key that differs between ``old`` and ``new`` set to its new
    value (tables created where the file has none, keys gone from ``new`` removed).

    The result is checked by reading it back: it must hold exactly the file's values
    with the changes made. A new table under dotted keys (``gpio.az.motor = ...``) can
    land elsewhere as a [header] table; then new tables are written inline instead."""
    want = _apply_plain(tomllib.loads(text), old, new)
    for inline in (False, True):
        doc = tomlkit.parse(text) if text.strip() else tomlkit.document()
        _apply(doc, old, new, inline)
        out = tomlkit.dumps(doc)
        if tomllib.loads(out) == want:
            return out
    raise EditError("the configuration file's layout could not take the change in place")


def _apply_plain(data: dict[str, Any], old: dict[str, Any], new: dict[str, Any]) -> dict[str, Any]:
    """What the file must read as after the edit (plain dicts)."""
    data = copy.deepcopy(data)

    def walk(d: dict[str, Any], o: dict[str, Any], n: dict[str, Any]) -> None:
        for key, value in n.items():
            before = o.get(key, _MISSING)
            if value == before:
                continue
            if isinstance(value, dict) and not (isinstance(d.get(key), list)):
                sub = d.get(key)
                if not isinstance(sub, dict):
                    sub = d[key] = {}
                walk(sub, before if isinstance(before, dict) else {}, value)
            else:
                d[key] = copy.deepcopy(value)
        for key in o:
            if key not in n:
                d.pop(key, None)
    walk(data, old, new)
    return data


def _apply(table: Any, old: dict[str, Any], new: dict[str, Any], inline: bool = False) -> None:
    for key, value in new.items():
        before = old.get(key, _MISSING)
        if value == before:
            continue
        if isinstance(value, dict) and not _is_array_of_tables(table.get(key)):
            sub = table.get(key)
            if not hasattr(sub, "items"):        # no such table in the file yet
                sub = tomlkit.inline_table() if inline else \
                    tomlkit.table(is_super_table=all(isinstance(v, dict) for v in value.values()))
                table[key] = sub
                sub = table[key]
            _apply(sub, before if isinstance(before, dict) else {}, value, inline)
        else:
            table[key] = _item(_like(value, table.get(key)))
    for key in old:
        if key not in new and key in table:
            del table[key]


def _like(value: Any, present: Any) -> Any:
    """A whole number stays an integer where the file has an integer: the schema reads
    ``alt_m = 70`` as 70.0, and a save wrote ``alt_m = 71.0`` (issue 36 item 9)."""
    if isinstance(value, float) and value.is_integer() and abs(value) < 2**53 \
            and isinstance(present, int) and not isinstance(present, bool):
        return int(value)
    return value


def _is_array_of_tables(item: Any) -> bool:
    return isinstance(item, AoT)


def _item(value: Any) -> Any:
    """A new value as TOML writes it: a list of tables as [[name]] tables."""
    if isinstance(value, list) and value and all(isinstance(v, dict) for v in value):
        aot = tomlkit.aot()
        for entry in value:
            t: Table = tomlkit.table()
            for k, v in entry.items():
                t[k] = _inline(v)
            aot.append(t)
        return aot
    return _inline(value)


def _inline(value: Any) -> Any:
    if isinstance(value, dict):
        t = tomlkit.inline_table()
        for k, v in value.items():
            t[k] = _inline(v)
        return t
    return value
