"""Sessions return effects (issue 34.3): a command is a request the session yields, a
position query yields nothing, and the server adapter awaits each request, so a session
waiting for the control process holds up nobody else and no greenlet is involved."""

from __future__ import annotations

import asyncio

from urc.errors import CommandRejected
from urc.model.messages import Goto, Move, Stop
from urc.protocols.rotctld import RotctldSession
from urc.servers.common import SessionRunner


def test_a_set_yields_its_goto_and_a_query_yields_nothing(bench):
    b = bench("tartu-urc")
    s = RotctldSession(b.rot)
    steps = s.receive(b"P 10 20\n")
    assert next(steps) == Goto(10.0, 20.0)          # nothing has moved: only asked
    assert b.rot.status().target_az_deg is None
    try:
        steps.send([])
    except StopIteration as done:
        assert done.value == [b"RPRT 0\n"]
    get = s.receive(b"p\n")
    try:
        next(get)
        raise AssertionError("p yielded a request")
    except StopIteration as done:
        assert done.value[0].endswith(b"\n")


def test_a_refusal_thrown_in_at_the_yield_is_answered_in_the_protocols_form(bench):
    s = RotctldSession(bench("tartu-urc").rot)
    steps = s.receive(b"M 2 50\n")                   # UP at half speed
    assert next(steps) == Move("el", 1, 0.5)
    try:
        steps.throw(CommandRejected("local control held", "local"))
    except StopIteration as done:
        assert done.value == [b"RPRT -9\n"]           # RIG_ERJCTED


class _Port:
    """A remote port whose round trips the test completes by hand."""

    def __init__(self, rot):
        self.rot = rot
        self.asked: list = []
        self.pending: list[asyncio.Future] = []

    def status(self):
        return self.rot.status()

    async def call(self, request):
        self.asked.append(request)
        fut = asyncio.get_running_loop().create_future()
        self.pending.append(fut)
        return await fut


def test_one_session_waits_for_its_reply_while_another_is_answered(bench):
    b = bench("tartu-urc")
    port = _Port(b.rot)
    written: dict[str, list[bytes]] = {"a": [], "b": []}

    async def main() -> None:
        a = SessionRunner(RotctldSession(port), written["a"].append, "a")
        other = SessionRunner(RotctldSession(port), written["b"].append, "b")
        a.feed(b"S\np\n")                             # a stop: a round trip; then a query
        await asyncio.sleep(0)
        assert port.asked == [Stop()] and a.busy and written["a"] == []
        other.feed(b"p\n")                             # answered at once, a still waiting
        assert len(written["b"]) == 1 and written["a"] == []
        port.pending[0].set_result(None)
        for _ in range(10):
            await asyncio.sleep(0)
        assert written["a"][0] == b"RPRT 0\n" and len(written["a"]) == 2 and not a.busy

    asyncio.run(main())


def test_every_command_request_lists_its_fields_in_the_order_its_rotator_method_takes_them():
    """(effects.perform calls the port with the fields in order, as sessions did)"""
    import dataclasses
    import inspect

    from urc.model.messages import COMMANDS
    from urc.rotator.rotator import Rotator

    for cls, method in COMMANDS.items():
        fields = [f.name for f in dataclasses.fields(cls)]
        params = list(inspect.signature(getattr(Rotator, method)).parameters)[1:]
        assert params[:len(fields)] == fields, cls.__name__


class _Buggy:
    """A session with a bug on ``boom``, in a step that acts and in one that only answers,
    and in its hang-up; a tick with no fresh position (UrcError) skips a beat."""

    closed = False
    rotator = None

    def receive(self, data):
        if data == b"boom\n":
            raise TypeError("injected")
        if data == b"act boom\n":
            return self._acts()
        return [b"ok " + data]

    def _acts(self):
        yield from ()
        raise TypeError("injected in a step")

    def tick(self, now_s):
        from urc.errors import UrcError
        raise UrcError("no fresh position")

    def disconnected(self):
        raise TypeError("injected at hang-up")


def test_a_session_bug_costs_its_input_only_and_is_counted(monkeypatch):
    """A session that raises is logged and counted as urc's bug (each of its inputs: bytes,
    a hang-up), that input gets no reply, and the next is answered; a tick that has no
    fresh position to give is no bug."""
    import urc.protocols.base as base

    saved = base.INTERNAL_ERRORS.copy()
    out: list[bytes] = []
    runner = SessionRunner(_Buggy(), out.append, "test")
    try:
        for data in (b"a\n", b"boom\n", b"b\n", b"act boom\n", b"c\n"):
            runner.feed(data)
        runner.tick(1.0)
        assert out == [b"ok a\n", b"ok b\n", b"ok c\n"] and not runner.busy
        assert base.internal_error_count() == sum(saved.values()) + 2
        runner.hang_up()
        assert base.internal_error_count() == sum(saved.values()) + 3 and out == [b"ok a\n", b"ok b\n", b"ok c\n"]
    finally:
        base.INTERNAL_ERRORS.clear()
        base.INTERNAL_ERRORS.update(saved)
