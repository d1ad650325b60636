"""Problems found in a configuration, as text: one issue is (dotted key, what was
expected, what was found, a hint), and every error urc reports about a configuration
reads ``<source>: <key>: expected <what>, found <value>; <hint>``.

A leaf module (no urc import but the error type) so that the backends' own checks
(:mod:`urc.hardware.gpio.checks`, :mod:`urc.hardware.bridge.checks`,
:mod:`urc.frontpanel.checks`) can speak it without importing the schema."""

from __future__ import annotations

import difflib
from typing import Any

from ..errors import ConfigError

#: key, expected, found, hint
Issue = tuple[str, str, Any, str]


def fmt(x: float) -> str:
    return f"{x:g}"


def describe(value: Any) -> str:
    """``'abc' (str)``; long values shortened."""
    if isinstance(value, tuple) and len(value) == 2 and all(isinstance(v, float) for v in value):
        return f"az {fmt(value[0])}, el {fmt(value[1])}"
    if isinstance(value, dict):
        return f"a table ({len(value)} key{'' if len(value) == 1 else 's'})"
    text = repr(value)
    if len(text) > 60:
        text = text[:57] + "..."
    return f"{text} ({type(value).__name__})"


def key_text(loc: tuple[Any, ...]) -> str:
    """A pydantic location as a dotted key: ``keepout[0].az_min_deg``."""
    out = ""
    for part in loc:
        if isinstance(part, int):
            out += f"[{part}]"
        else:
            out += ("." if out else "") + str(part)
    return out


def suggest(word: str, choices: list[str]) -> str:
    close = difflib.get_close_matches(str(word), choices, n=1, cutoff=0.6)
    return f"did you mean {close[0]!r}?" if close else ""


def warning(key: str, found: str, why: str, hint: str = "") -> str:
    """A warning (``urc config check``): ``<key>: <found>: <why>; <hint>``, keyed like an
    error, for what is allowed but likely wrong."""
    return f"{key}: {found}: {why}" + (f"; {hint}" if hint else "")


def one_of(key: str, choices: list[str], found: str) -> Issue:
    """``found`` is not among ``choices``: the issue, with the nearest as a hint."""
    return (key, "one of " + ", ".join(choices), found, suggest(found, choices))


def make_error(source: str, key: str | None, expected: str, found: Any, hint: str = "",
               *, found_text: str | None = None) -> ConfigError:
    found_text = found_text if found_text is not None else describe(found)
    where = f"{source}: {key}: " if key else f"{source}: "
    msg = f"{where}expected {expected}, found {found_text}"
    if hint:
        msg += f"; {hint}"
    return ConfigError(msg, path=source, key=key, expected=expected, found=found)


def combine(errors: list[ConfigError]) -> ConfigError:
    """One error for several: the first's message, then the others indented."""
    first = errors[0]
    msg = str(first)
    if len(errors) > 1:
        msg += f"\n  ({len(errors) - 1} more problem{'s' if len(errors) > 2 else ''}:)"
        msg += "".join(f"\n  {e}" for e in errors[1:])
    err = ConfigError(msg, path=first.path, key=first.key, expected=first.expected,
                      found=first.found)
    err.errors = errors  # type: ignore[attr-defined]
    return err


def error_from_issues(issues: list[Issue], source: str) -> ConfigError:
    errs = [make_error(source, k, exp, found, hint) for k, exp, found, hint in issues]
    err = combine(errs)
    err._issues = issues  # type: ignore[attr-defined]
    return err
