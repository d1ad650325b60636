"""Reading a configuration: a TOML file or text into a validated :class:`Config`, with
syntax errors located (file:line:column) and worded like every other problem."""

from __future__ import annotations

import os
import re
import tomllib
from pathlib import Path

from ..errors import ConfigError
from .schema import Config



def load_config(path: str | os.PathLike[str] | None) -> Config:
    """Read a TOML configuration file; ``None`` gives the defaults."""
    if path is None:
        return Config()
    source = os.fspath(path)
    try:
        raw = Path(source).read_bytes()
    except FileNotFoundError:
        raise ConfigError(f"{source}: configuration file not found: expected an existing file, "
                          "found no such file",
                          path=source, expected="an existing file", found="no such file"
                          ) from None
    except IsADirectoryError:
        raise ConfigError(f"{source}: expected a configuration file, found a directory",
                          path=source, expected="a file", found="a directory") from None
    except OSError as exc:
        raise ConfigError(f"{source}: cannot read the configuration file: {exc.strerror or exc}",
                          path=source, expected="a readable file", found=str(exc)) from None
    return loads_config(raw, source=source)


def loads_config(text: str | bytes, source: str = "<string>") -> Config:
    """Parse TOML text (str or UTF-8 bytes) into a Config."""
    if isinstance(text, bytes):
        raw = text
        try:
            text = raw.decode("utf-8")
        except UnicodeDecodeError as exc:
            line = raw[:exc.start].count(b"\n") + 1
            col = exc.start - (raw.rfind(b"\n", 0, exc.start) + 1) + 1
            raise ConfigError(
                f"{source}:{line}:{col}: expected UTF-8 text, found byte "
                f"0x{raw[exc.start]:02x} at line {line}, column {col}",
                path=source, expected="UTF-8 text", found=raw[exc.start:exc.end]) from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise _syntax_error(exc, text, source) from None
    except RecursionError:
        raise ConfigError(f"{source}: expected valid TOML, found nesting too deep to read",
                          path=source, expected="valid TOML", found="deep nesting") from None
    return Config.from_dict(data, source=source)


_POS = re.compile(r"\s*\(at line (\d+), column (\d+)\)\s*$")


def _syntax_error(exc: tomllib.TOMLDecodeError, text: str, source: str) -> ConfigError:
    msg = str(exc)
    m = _POS.search(msg)
    if m:
        line, col = int(m.group(1)), int(m.group(2))
        what = msg[:m.start()]
    else:
        what = msg.replace("(at end of document)", "").strip()
        lines = text.split("\n")
        line, col = len(lines), len(lines[-1]) + 1
    lines = text.split("\n")
    snippet = lines[line - 1] if 0 < line <= len(lines) else ""
    found = f"{what.rstrip('.').lower() or 'a syntax error'} in {snippet.strip()[:60]!r}"
    err = ConfigError(
        f"{source}:{line}:{col}: TOML syntax error at line {line}, column {col}: "
        f"expected valid TOML, found {found}",
        path=source, key=None, expected="valid TOML", found=found)
    err.line, err.column = line, col  # type: ignore[attr-defined]
    return err


# --------------------------------------------------------------------------- writing
