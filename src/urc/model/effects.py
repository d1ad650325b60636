"""Port requests as effects: what a protocol session yields and a web route awaits.

A command to the rotator is one typed request (:mod:`urc.model.messages`: ``Goto``,
``Stop``, a hardware ``Query`` ...). Code that needs one does not call the rotator; it
hands the request to whoever drives it:

* a protocol session's ``receive()`` is a generator, ``value = yield Goto(az, el)``,
  that returns its replies (:data:`Effects`). :func:`drive` runs one here and now
  against an in-process Rotator (tests, tools); :func:`drive_async` runs it on the
  event loop, each request a round trip to the control process that suspends this
  session only (a point every reader sees: a ``yield``);
* a web route or MQTT command awaits :func:`call` directly.

Either way the exception the rotator raised (CommandRejected, a hardware error) comes
back at the ``yield`` or the ``await``, so each protocol still answers in its own form.
Status reads need no round trip (the I/O process reads the newest status locally), so
sessions keep reading ``rotator.status()`` directly.
"""

from __future__ import annotations

import dataclasses
import inspect
from typing import Any, Callable, Generator, TypeVar

from .messages import COMMANDS, Query, Request

T = TypeVar("T")

#: a session step: yields port requests, is sent each one's result, returns its value
Effects = Generator[Request, Any, T]


def as_effects(out: Any) -> Effects[Any]:
    """``yield from as_effects(step())``: a step that may act (a generator) or only
    answer (its value), as a dispatch table of both kinds holds them."""
    if inspect.isgenerator(out):
        return (yield from out)
    return out


#: runs a query on a rotator in this process (urc.rotator.queries.handle, which sets it
#: when imported, as urc.rotator is: a rotator in this process means its handlers are
#: here). Set from above so that this module, which every protocol imports, imports
#: nothing of the control process.
_handle_here: Callable[[Any, Query], Any] | None = None


def handle_queries_with(handler: Callable[[Any, Query], Any]) -> None:
    """Register the handler :func:`ask` runs for a rotator in this process."""
    global _handle_here
    _handle_here = handler


def ask(rotator: Any, query: Query) -> Any:
    """The answer to ``query``: from the control process in one round trip when
    ``rotator`` stands in for one there (RemoteRotator.ask), else run here."""
    remote = getattr(rotator, "ask", None)
    if remote is not None:
        return remote(query)
    if _handle_here is None:
        raise TypeError(f"{type(query).__name__}: no query handlers in this process (urc.rotator not imported)")
    return _handle_here(rotator, query)


def perform(rotator: Any, request: Request) -> Any:
    """Run ``request`` on ``rotator`` now: the Rotator method COMMANDS names for it, or a
    query's handler (a RemoteRotator's synchronous methods also work, off the loop)."""
    if isinstance(request, Query):
        return ask(rotator, request)
    method = COMMANDS.get(type(request))
    if method is None:
        raise TypeError(f"{type(request).__name__} is not a rotator request")
    return getattr(rotator, method)(*_positional(request))


def _positional(request: Request) -> list[Any]:
    """The request's fields in order (each Rotator method takes them in that order:
    tests/servers/test_effects.py), trailing defaults left out: the call a session made
    when it called the port itself (``goto_pose(az, el)``, ``stop()``), which any
    RotatorPort, a test's stand-in too, accepts."""
    args = []
    for f in dataclasses.fields(request):
        args.append((getattr(request, f.name), f.default))
    while args and args[-1][1] is not dataclasses.MISSING and _same(*args[-1]):
        args.pop()
    return [value for value, _default in args]


def _same(value: Any, default: Any) -> bool:
    return value is default or (type(value) is type(default) and value == default)


async def call(rotator: Any, request: Request) -> Any:
    """``await call(rotator, Goto(az, el))``: the request's value, or its exception. On
    the I/O process's RemoteRotator a round trip that suspends the caller only; on an
    in-process Rotator (tests, ``urc sim``) run at once."""
    remote = getattr(rotator, "call", None)
    if remote is not None:
        return await remote(request)
    return perform(rotator, request)


def drive(steps: Effects[T], rotator: Any) -> T:
    """Run a session step to its end against ``rotator`` in this process: each request
    it yields performed at once, its result (or exception) sent back in."""
    try:
        request = next(steps)
        while True:
            try:
                result = perform(rotator, request)
            except Exception as exc:
                request = steps.throw(exc)
            else:
                request = steps.send(result)
    except StopIteration as done:
        return done.value


async def drive_async(steps: Effects[T], rotator: Any) -> T:
    """:func:`drive` on the event loop: each request awaited with :func:`call`."""
    try:
        request = next(steps)
        while True:
            try:
                result = await call(rotator, request)
            except Exception as exc:
                request = steps.throw(exc)
            else:
                request = steps.send(result)
    except StopIteration as done:
        return done.value
