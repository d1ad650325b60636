"""Every public method of the Rotator holds its lock, by construction (issue 19).

The control loop ticks on its own thread while commands come from others; a command
that ran beside a tick could see or leave half of one. The methods are found by
introspection, so a new public method is covered the day it is written: it must take
the lock on entry, or be marked ``lock_free`` with its reason.
"""

from __future__ import annotations

import inspect
import sys
import threading
from typing import Any, Callable

import pytest

from urc.errors import CommandRejected
from urc.rotator.locking import LOCK_FREE_ATTR, LOCKED_ATTR, lock_free, locked_api
from urc.model.program import PassProgram
from urc.rotator.rotator import Rotator


def public_methods() -> list[str]:
    return sorted(n for n, _ in inspect.getmembers(Rotator, inspect.isfunction) if not n.startswith("_"))


def lock_free_reason(name: str) -> str | None:
    return getattr(getattr(Rotator, name), LOCK_FREE_ATTR, None)


#: how to call each public method (given the rotator); a refusal counts as a call too
Args = tuple[tuple[Any, ...], dict[str, Any]]
CALLS: dict[str, Callable[[Rotator], Args]] = {
    "goto": lambda rot: ((90.0, 20.0), {}),
    "goto_az": lambda rot: ((90.0,), {}),
    "goto_el": lambda rot: ((20.0,), {}),
    "goto_pose": lambda rot: ((90.0, 20.0), {}),
    "park": lambda rot: ((), {}),
    "track": lambda rot: ((90.0, 20.0, 0.1, 0.0), {}),
    "track_pose": lambda rot: ((90.0, 20.0), {}),
    "move": lambda rot: (("az", 1), {}),
    "stop": lambda rot: ((), {}),
    "stop_open_ended": lambda rot: (("the I/O process was silent",), {}),
    "bounded_in_flight": lambda rot: ((), {}),
    "fly_program": lambda rot: ((PassProgram(1, "test", (rot.clock.now_s() + 5.0, rot.clock.now_s() + 10.0),
                                             (90.0, 91.0), (20.0, 21.0), (False, False),
                                             rot.clock.now_s()),), {}),
    "cancel_program": lambda rot: ((), {}),
    "safety_chain_failed": lambda rot: (("safety chain self-test FAILED: a test",), {}),
    "set_position": lambda rot: ((), {"az_deg": 100.0}),
    "adopt_sensor_reading": lambda rot: (("az",), {}),
    "search_frame": lambda rot: (("az", 10.0), {}),
    "end_search": lambda rot: (("az",), {}),
    "set_overshoot": lambda rot: (("az", 1.0), {}),
    "overshoot_deg": lambda rot: (("az",), {}),
    "reconfigure": lambda rot: ((rot.settings,), {}),
    "clear_faults": lambda rot: ((), {}),
    "announce": lambda rot: (("a test event",), {}),
    "position_uncertain": lambda rot: ((), {}),
    "note_lateness": lambda rot: ((0.0,), {}),
    "tick": lambda rot: ((), {}),
    "shutdown": lambda rot: ((), {}),
}


class WatchedLock:
    """The rotator's RLock, telling which function had to wait for it."""

    def __init__(self, on_wait: Callable[[str], None]):
        self._lock = threading.RLock()
        self._on_wait = on_wait

    def acquire(self, blocking: bool = True, timeout: float = -1) -> bool:
        if self._lock.acquire(blocking=False):
            return True
        if not blocking:
            return False
        self._on_wait(_asker(sys._getframe(1)))
        return self._lock.acquire(True, timeout)

    def release(self) -> None:
        self._lock.release()

    def __enter__(self) -> bool:
        return self.acquire()

    def __exit__(self, *exc: object) -> None:
        self.release()


def _asker(frame: Any) -> str:
    """The method that asked for the lock: the one a lock wrapper wraps, or the caller."""
    while frame.f_code.co_filename == __file__:  # (this module's own frames)
        frame = frame.f_back
    wrapped = frame.f_locals.get("method") if frame.f_code.co_name == "locked" else None
    return wrapped.__name__ if wrapped is not None else frame.f_code.co_name


@pytest.mark.parametrize("name", public_methods())
def test_every_public_method_waits_for_the_lock_or_says_why_not(bench, name):
    """Called from a second thread while this one holds the rotator's lock, each public
    method must wait for the lock on entry, before its body runs (and run once it is
    released), unless it is marked lock-free with a reason."""
    reason = lock_free_reason(name)
    if reason is not None:
        assert isinstance(reason, str) and reason.strip(), f"Rotator.{name} is lock-free without a reason"
        return
    assert name in CALLS, f"Rotator.{name} is new: add how to call it to CALLS in this test"
    b = bench("tartu-urc")
    rot = b.rot
    args, kwargs = CALLS[name](rot)
    events: list[str] = []
    happened = threading.Event()

    def on_wait(asker: str) -> None:
        events.append(f"waits in {asker}")
        happened.set()
    rot.lock = WatchedLock(on_wait)

    def call() -> None:
        try:
            getattr(rot, name)(*args, **kwargs)
        except CommandRejected:
            pass  # refused: still a call that had to wait
        finally:
            events.append("done")
            happened.set()

    try:
        with rot.lock:
            worker = threading.Thread(target=call, name=f"call-{name}", daemon=True)
            worker.start()
            assert happened.wait(30), f"Rotator.{name} neither waited nor finished"
            assert events == [f"waits in {name}"], \
                f"Rotator.{name} did not take the rotator's lock on entry: {events}"
        worker.join(30)
        assert events == [f"waits in {name}", "done"]
    finally:
        rot.lock = threading.RLock()
        if name != "shutdown":
            rot.shutdown()
        rot.hw.close()


def test_the_lock_free_methods_are_few_and_each_says_why():
    free = {n: lock_free_reason(n) for n in public_methods() if lock_free_reason(n) is not None}
    assert set(free) == {"status", "hold_local", "local_controls", "power_fail", "save_now",
                         "motion_ticket", "confirm_motion_record"}
    assert all(len(reason) > 20 for reason in free.values())


def test_locked_api_wraps_new_public_methods_and_leaves_the_rest():
    @locked_api
    class Thing:
        def __init__(self):
            self.lock = WatchedLock(lambda asker: None)

        def command(self) -> str:
            return "ran"

        @lock_free("only for this test")
        def query(self) -> str:
            return "read"

        def _inner(self) -> str:
            return "inner"

    assert getattr(Thing.command, LOCKED_ATTR).__name__ == "command"
    assert not hasattr(Thing.query, LOCKED_ATTR) and not hasattr(Thing._inner, LOCKED_ATTR)
    assert Thing().command() == "ran"


def test_locked_api_refuses_what_it_cannot_lock():
    with pytest.raises(TypeError, match="static or class method"):
        @locked_api
        class Thing:
            @staticmethod
            def command() -> None:
                return None
    with pytest.raises(ValueError):
        lock_free("  ")
