"""Synchronous code on the event loop that never blocks it: a call to the control
process suspends that code, not the loop.

What is left of it: protocol sessions yield their requests and web routes and MQTT await
them (urc.service.effects), but the tracker (its step and commands) and calibration
procedures (poll, start, cancel) are still synchronous code that calls the rotator port.
They run in a greenlet: when the port needs a reply it hands the pending future to the
event loop and switches out; the loop serves everyone else and switches back in with the
outcome when it arrives (the technique of SQLAlchemy's asyncio layer). Once those return
effects too, this module and the greenlet dependency go (issue 34.3).
"""

from __future__ import annotations

import asyncio
from typing import Any, Callable

from greenlet import getcurrent, greenlet


class _Bridged(greenlet):
    """A greenlet whose code may suspend on a future (marks where :func:`wait` may switch)."""

    __slots__ = ()


def in_bridge() -> bool:
    """Does the caller run in a bridged greenlet (so it may suspend instead of block)?"""
    return isinstance(getcurrent(), _Bridged)


def wait(fut: asyncio.Future) -> Any:
    """From bridged code: give the event loop ``fut`` and resume with its result (or its
    exception raised here) once it is done."""
    me = getcurrent()
    assert isinstance(me, _Bridged), "wait() outside a bridged greenlet would block the loop"
    me.parent.switch(fut)
    return fut.result()


def start(fn: Callable[..., Any], args: tuple, on_done: Callable[[Any, BaseException | None], None]) -> None:
    """Run ``fn(*args)`` now on the event loop thread; ``on_done(result, error)`` is called
    when it has finished, at once if it never had to wait. Callback-based (no Task per
    call): it serves every protocol request."""
    if in_bridge():  # (already suspendable: run inline, suspending the outer greenlet)
        try:
            result = fn(*args)
        except BaseException as exc:
            on_done(None, exc)
        else:
            on_done(result, None)
        return
    _step(_Bridged(fn), args, on_done)


def _step(g: _Bridged, args: tuple, on_done: Callable[[Any, BaseException | None], None]) -> None:
    try:
        out = g.switch(*args)
    except BaseException as exc:  # fn raised: its greenlet is dead
        on_done(None, exc)
        return
    if g.dead:
        on_done(out, None)
    else:  # suspended on a future: resume it when that is done
        out.add_done_callback(lambda _f: _step(g, (), on_done))


async def run(fn: Callable[..., Any], *args: Any, **kwargs: Any) -> Any:
    """``await run(rotator.goto, 10, 20)``: from a coroutine, synchronous port code that
    may wait on the control process without blocking the loop."""
    done: asyncio.Future = asyncio.get_running_loop().create_future()

    def finish(result: Any, error: BaseException | None) -> None:
        if done.cancelled():
            return
        if error is not None:
            done.set_exception(error)
        else:
            done.set_result(result)
    start(lambda: fn(*args, **kwargs), (), finish)
    return await done
