"""pydantic's validation errors in urc's words: the dotted key, what the field holds
(its kind, unit and range, read from the schema itself) and what was found."""

from __future__ import annotations

import types
import typing
from typing import Any, Literal, Union

import annotated_types
from pydantic import BaseModel, ValidationError

from ..errors import ConfigError
from .issues import combine, fmt, key_text, make_error, suggest


def _unwrap_model(annotation: Any) -> type[BaseModel] | None:
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return annotation
    origin = typing.get_origin(annotation)
    if origin is typing.Annotated:
        return _unwrap_model(typing.get_args(annotation)[0])
    if origin in (Union, types.UnionType, tuple, list):
        for arg in typing.get_args(annotation):
            found = _unwrap_model(arg)
            if found is not None:
                return found
    return None


def _resolve(root: type[BaseModel], loc: tuple[Any, ...]) -> tuple[type[BaseModel] | None, Any]:
    """The model holding ``loc[-1]`` and that field's FieldInfo (or None)."""
    model: type[BaseModel] | None = root
    for part in loc[:-1]:
        if isinstance(part, int) or model is None:
            continue
        info = _fields_by_name(model).get(part)
        model = _unwrap_model(info.annotation) if info is not None else None
    if model is None or not loc or isinstance(loc[-1], int):
        return model, None
    return model, _fields_by_name(model).get(loc[-1])


def _fields_by_name(model: type[BaseModel]) -> dict[str, Any]:
    return dict(model.model_fields)


_UNITS = (("_deg_per_s2", "degrees per second squared"), ("_deg_per_s", "degrees per second"),
          ("_per_s2", "per second squared"), ("_per_s", "per second"), ("_deg", "degrees"),
          ("_hz", "Hz"), ("_s", "seconds"), ("_a", "amperes"))


def _unit(name: str) -> str:
    for suffix, unit in _UNITS:
        if name.endswith(suffix):
            return unit
    return ""


def _range_text(info: Any) -> str:
    parts = {}
    for m in getattr(info, "metadata", ()):
        for attr in ("ge", "gt", "le", "lt"):
            if isinstance(m, getattr(annotated_types, attr.capitalize())):
                parts[attr] = getattr(m, attr)
    lo = parts.get("ge", parts.get("gt"))
    hi = parts.get("le", parts.get("lt"))
    if "ge" in parts and "le" in parts:
        return f" in {fmt(parts['ge'])}..{fmt(parts['le'])}"
    bits = []
    if lo is not None:
        bits.append(f"{'>=' if 'ge' in parts else '>'} {fmt(lo)}")
    if hi is not None:
        bits.append(f"{'<=' if 'le' in parts else '<'} {fmt(hi)}")
    return (" " + " and ".join(bits)) if bits else ""


def _kind(model: type[BaseModel] | None, info: Any, name: str) -> str:
    """What a field holds, in words: 'a number (degrees)', 'an integer', ..."""
    if info is None:
        return "a value"
    ann = info.annotation
    args = set(typing.get_args(ann)) | {ann}
    if _unwrap_model(ann) is not None:
        if typing.get_origin(ann) is tuple:
            return f"an array of tables ([[{name}]])"
        return f"a table ([{name}])"
    literals = [a for a in typing.get_args(ann) if typing.get_origin(a) is Literal]
    if bool in args and literals:  # flip = "auto" | true | false
        words = [f'"{v}"' for lit in literals for v in typing.get_args(lit)]
        return "true, false or " + " or ".join(words)
    if bool in args:
        return "true or false"
    if typing.get_origin(ann) is Literal:  # zero = "north" | "south"
        return " or ".join(f'"{v}"' for v in typing.get_args(ann))
    if float in args:
        unit = _unit(name)
        return f"a number ({unit})" if unit else "a number"
    if int in args:
        return "an integer"
    if str in args:
        return "a string"
    return "a value"


def error_from_validation(exc: ValidationError, source: str, root: type[BaseModel]) -> ConfigError:
    """pydantic's errors about a document for ``root`` (the Config model) in urc's words:
    the dotted key, what the field holds (a number in degrees, 0..360) and what was found."""
    errs = []
    seen: set[tuple[Any, ...]] = set()
    for e in exc.errors(include_url=False):
        loc = tuple(e.get("loc", ()))
        if len(loc) >= 2 and e.get("type") != "extra_forbidden" and _resolve(root, loc)[1] is None \
                and _resolve(root, loc[:-1])[1] is not None:
            loc = loc[:-1]  # a union's member (flip: bool | "auto"): one error for the key
        if loc in seen:
            continue
        seen.add(loc)
        key = key_text(loc) or None
        etype = e.get("type", "")
        value = e.get("input")
        model, info = _resolve(root, loc)
        name = str(loc[-1]) if loc else ""
        if etype == "extra_forbidden":
            known = sorted(_fields_by_name(model)) if model is not None else []
            shown = name
            hint = suggest(shown, known)
            where = key_text(loc[:-1])
            expected = (f"one of the keys of [{where}]: " if where else
                        "one of the top-level sections: ") + ", ".join(known)
            errs.append(make_error(source, key, expected, shown,
                                    hint, found_text=f"unknown key {shown!r}"))
            continue
        kind = _kind(model, info, name)
        if etype == "missing":
            errs.append(make_error(source, key, f"{kind} (required)", None,
                                    found_text="nothing"))
            continue
        if etype in ("finite_number",):
            expected = kind + _range_text(info) + ", finite (not nan or inf)"
        elif etype.startswith(("greater_than", "less_than")):
            expected = kind + _range_text(info)
        elif etype in ("string_too_short",):
            expected = "a non-empty string"
        else:
            expected = kind + (_range_text(info) if kind.startswith(("a number", "an int"))
                               else "")
        errs.append(make_error(source, key, expected, value))
    if not errs:  # pragma: no cover - pydantic always reports at least one
        errs.append(make_error(source, None, "a valid configuration", str(exc)))
    return combine(errs)


# --------------------------------------------------------------------------- loading
