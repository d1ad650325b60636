"""Command payloads: parsed strictly, or refused with the id when it can be read."""

from __future__ import annotations

import json

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from urc.mqtt.commands import (
    MAX_PAYLOAD_BYTES,
    BadCommand,
    Goto,
    Stop,
    Track,
    parse_command,
)


def test_commands_parse():
    assert parse_command(b'{"id": "a1", "command": "goto", "az_deg": 120.0, "el_deg": 30}') == \
        Goto(id="a1", command="goto", az_deg=120.0, el_deg=30.0)
    assert parse_command(b'{"command": "stop", "axis": "el"}') == Stop(command="stop", axis="el")
    t = parse_command(b'{"id": 7, "command": "track", "kind": "satellite", "norad": 25544}')
    assert isinstance(t, Track) and t.request() == {"kind": "satellite", "norad": 25544}
    assert parse_command(b'{"command": "track", "kind": "azel", "az_deg": 10, "el_deg": 20}').request() == \
        {"kind": "azel", "az_deg": 10.0, "el_deg": 20.0}


@pytest.mark.parametrize("doc, cmd_id, says", [
    ({"id": "a", "command": "goto", "az_deg": 10, "el_deg": 200}, "a", "el_deg"),
    ({"id": "a", "command": "stop", "axis": "x"}, "a", "axis"),
    ({"id": "a", "command": "park", "now": True}, "a", "unknown field"),
    ({"id": "x" * 65, "command": "park"}, None, "id"),
    ({"id": True, "command": "park"}, None, "id"),
    ({"id": "a", "command": "track", "kind": "point", "lat_deg": 1.0}, "a", "lon_deg"),
    ({"id": "a", "command": "track", "kind": "satellite", "norad": "25544"}, "a", "norad"),
    ({"id": "a", "command": ["goto"]}, "a", "command"),
])
def test_refusals(doc, cmd_id, says):
    with pytest.raises(BadCommand) as err:
        parse_command(json.dumps(doc).encode())
    assert err.value.cmd_id == cmd_id and says in str(err.value), str(err.value)


def test_deep_nesting_and_size():
    with pytest.raises(BadCommand, match="not a JSON object"):
        parse_command(b"[" * 2000 + b"]" * 2000)
    with pytest.raises(BadCommand, match=f"at most {MAX_PAYLOAD_BYTES}"):
        parse_command(b" " * (MAX_PAYLOAD_BYTES + 1))


@settings(max_examples=300, deadline=None)
@given(st.one_of(st.binary(max_size=300),
                 st.recursive(st.none() | st.booleans() | st.floats() | st.integers() | st.text(max_size=20),
                              lambda c: st.lists(c, max_size=4) | st.dictionaries(st.text(max_size=8), c, max_size=4),
                              max_leaves=12).map(lambda d: json.dumps(d).encode())))
def test_anything_is_a_command_or_a_bad_command(payload):
    try:
        cmd = parse_command(payload)
    except BadCommand as exc:
        assert str(exc) and len(str(exc)) < 1000
    else:
        assert cmd.command in ("goto", "stop", "park", "clear_faults", "track", "track_stop")


@pytest.mark.parametrize("payload, cmd_id, says", [
    # json keeps the last: this one moved to 200
    (b'{"id": "d", "command": "goto", "az_deg": 10, "az_deg": 200, "el_deg": 5}', "d", "az_deg"),
    (b'{"id": "d", "command": "goto", "command": "stop", "az_deg": 10}', "d", "command"),
    (b'{"id": "a", "id": "b", "command": "park"}', None, "id"),
    (b'{"id": 3, "command": "track", "kind": "point", "lat_deg": 1, "lat_deg": 2, "lon_deg": 3}', 3, "lat_deg"),
])
def test_a_key_given_twice_is_refused(payload, cmd_id, says):
    with pytest.raises(BadCommand) as err:
        parse_command(payload)
    assert err.value.cmd_id == cmd_id and says in str(err.value) and "more than once" in str(err.value)


def test_a_key_given_twice_is_answered_invalid_and_moves_nothing():
    import asyncio

    from urc.mqtt.commands import CommandHandler

    class Rotator:
        calls: list = []

        def goto(self, *args):
            self.calls.append(args)

    rot = Rotator()
    reply = asyncio.run(CommandHandler(rot).handle(
        b'{"id": "d", "command": "goto", "az_deg": 10, "az_deg": 200, "el_deg": 5}'))
    assert reply == {"id": "d", "ok": False, "error": "az_deg: given more than once", "reason": "invalid"}
    assert rot.calls == []


class _Rotator:
    """An in-process rotator port that records each call (urc.model.effects.perform)."""

    def __init__(self):
        self.calls: list = []

    def __getattr__(self, name):
        if name == "call" or name.startswith("_"):  # (no link: effects.call performs it here)
            raise AttributeError(name)
        return lambda *args: self.calls.append((name, *args))


class _Tracker:
    def __init__(self, fail: Exception | None = None):
        self.fail = fail
        self.calls: list = []

    async def track(self, request):
        self.calls.append(("track", request))
        if self.fail is not None:
            raise self.fail

    async def stop(self):
        self.calls.append(("stop",))
        if self.fail is not None:
            raise self.fail


def test_a_tracker_that_fails_to_stop_cannot_keep_the_stop_from_the_rotator():
    """The stop goes out first (it went last, after the tracker's: a tracker that raised
    left the antenna moving); the tracker's failure is still answered."""
    import asyncio

    from urc.mqtt.commands import CommandHandler

    rot = _Rotator()
    reply = asyncio.run(CommandHandler(rot, _Tracker(RuntimeError("catalog locked"))).handle(
        b'{"id": "s", "command": "stop"}'))
    assert reply == {"id": "s", "ok": False, "error": "catalog locked", "reason": "failed"}
    assert rot.calls == [("stop",)]


def test_replies_of_a_tracker_failure_and_of_no_tracker():
    import asyncio

    from urc.errors import CommandRejected
    from urc.mqtt.commands import CommandHandler

    def ask(handler, payload):
        return asyncio.run(handler.handle(payload))

    assert ask(CommandHandler(_Rotator(), _Tracker(ValueError())), b'{"id": 1, "command": "track", "kind": "sun"}') == \
        {"id": 1, "ok": False, "error": "ValueError", "reason": "failed"}
    assert ask(CommandHandler(_Rotator(), _Tracker(CommandRejected("a pass runs", "busy"))),
               b'{"id": 2, "command": "track", "kind": "sun"}') == \
        {"id": 2, "ok": False, "error": "a pass runs", "reason": "busy"}
    assert ask(CommandHandler(_Rotator()), b'{"id": 3, "command": "track_stop"}') == \
        {"id": 3, "ok": False, "error": "tracking is off: no [station] configured", "reason": "tracking"}
    rot, trk = _Rotator(), _Tracker()
    assert ask(CommandHandler(rot, trk), b'{"id": 4, "command": "track", "kind": "azel", "az_deg": 1, "el_deg": 2}') \
        == {"id": 4, "ok": True}
    assert trk.calls == [("track", {"kind": "azel", "az_deg": 1.0, "el_deg": 2.0})] and rot.calls == []


def test_a_queued_stop_is_answered_as_before():
    """A stop the control process has not confirmed (held up) is sent; MQTT answers it
    as the refusal it always did (reason "fault", the note saying it runs on resume)."""
    import asyncio

    from urc.mqtt.commands import CommandHandler
    from urc.link.client import StopQueued

    class Held(_Rotator):
        def stop(self, *args):
            self.calls.append(("stop", *args))
            raise StopQueued("control process held up: the stop is sent and runs as soon as it resumes")

    rot = Held()
    reply = asyncio.run(CommandHandler(rot).handle(b'{"id": "q", "command": "stop", "axis": "az"}'))
    assert reply == {"id": "q", "ok": False, "reason": "fault",
                     "error": "control process held up: the stop is sent and runs as soon as it resumes"}
    assert rot.calls == [("stop", "az")]


def test_the_track_command_has_the_apis_track_fields():
    """MQTT's track takes its fields strictly typed, then the API's TrackRequest judges
    them: a field the API gains must not be missing here (it would be refused)."""
    from urc.dispatch.bodies import TrackRequest

    assert set(Track.model_fields) - {"id", "command"} == set(TrackRequest.model_fields)
