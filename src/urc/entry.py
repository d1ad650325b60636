"""The ``urc`` command's entry point: ``urc status`` answered with the standard library
alone, everything else by the click command line (urc.cli).

``urc status`` is what scripts and a shell prompt run over and over; loading click for
it cost more than the request itself (issue 19). Only a command line this module fully
understands takes the short way: ``status`` with ``--json``, ``--port``, ``--url`` and
``--timeout`` each at most once and with a valid value. Anything else (``--help``,
``--config``, which needs the configuration package, a value click would refuse, shell
completion) goes to click, which answers as it always did. What the short way prints, its
messages and exit codes are the click command's: both call the same request
(urc.api_client) and formatting (urc.status_text).
"""

from __future__ import annotations

import os
import sys

from .api_client import CLIENT_TIMEOUT_S, ClientError, base_url, request
from .status_text import render

# the options of `urc status` that take a value -> the environment variable click reads
# for each when it is not given (urc.cli._client_options)
_VALUED = {"--port": None, "--url": "URC_URL", "--timeout": "URC_TIMEOUT"}


def main() -> None:
    args = sys.argv[1:]
    if args[:1] == ["status"]:
        options = status_options(args[1:], dict(os.environ))
        if options is not None:
            sys.exit(run_status(*options))
    from .cli import main as click_main

    click_main()


def status_options(args: list[str], env: dict[str, str]) -> tuple[str, bool, float] | None:
    """(API address, --json, timeout in s) of a ``urc status`` command line, or None
    when click must read it."""
    if any(k.startswith("_") and k.endswith("_COMPLETE") for k in env):
        return None  # click's shell completion
    given: dict[str, str] = {}
    as_json = False
    rest = list(args)
    while rest:
        arg = rest.pop(0)
        if arg == "--json" and not as_json:
            as_json = True
            continue
        name, eq, value = arg.partition("=")
        if name not in _VALUED or name in given:
            return None
        if not eq:
            if not rest:
                return None
            value = rest.pop(0)
        if not value or value.startswith("-"):
            return None
        given[name] = value
    for name, var in _VALUED.items():
        if name not in given and var and env.get(var):  # (click ignores an empty variable)
            given[name] = env[var]
    port: int | None = None
    if "--port" in given:
        text = given["--port"]
        if not (text.isascii() and text.isdigit() and 1 <= int(text) <= 65535):
            return None
        port = int(text)
        if "--url" in given:
            return None  # "give --url or --port, not both": click's usage error
    timeout_s = CLIENT_TIMEOUT_S
    if "--timeout" in given:
        try:
            timeout_s = float(given["--timeout"])
        except ValueError:
            return None
        if not 0.1 <= timeout_s < float("inf"):
            return None
    return base_url(given.get("--url"), port), as_json, timeout_s


def run_status(url: str, as_json: bool, timeout_s: float) -> int:
    """Ask, print as ``click.echo`` would, and return the exit code click's ``urc status``
    gives (1 on an error, after ``Error: ...`` on stderr)."""
    try:
        try:
            data = request(url, "GET", "/api/status", token=os.environ.get("URC_TOKEN", ""), timeout_s=timeout_s)
        except ClientError as exc:
            _echo(f"Error: {exc}", sys.stderr)
            return 1
        _echo(render(data, as_json), sys.stdout)
        return 0
    except KeyboardInterrupt:
        _echo("", sys.stderr)  # (click closes the terminal's ^C echo, then says so)
        _echo("Aborted!", sys.stderr)
        return 1
    except BrokenPipeError:
        # the reader left (`urc status | head -1`): quietly, as click does
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 1


def _echo(text: str, stream) -> None:
    """``click.echo(text)``: plain text goes straight out; text with an escape sequence
    (click strips them when not writing to a terminal) or that the stream's encoding may
    not hold goes through click itself."""
    utf = (getattr(stream, "encoding", "") or "").lower().replace("-", "") == "utf8"
    if "\033" in text or not (text.isascii() or utf):
        import click

        click.echo(text, file=stream)
        return
    stream.write(text + "\n")
    stream.flush()
