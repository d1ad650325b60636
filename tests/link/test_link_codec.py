"""The link's codec: urc's own message types cross; nothing else is rebuilt on loading."""

from __future__ import annotations

import os
import pickle

import pytest

from urc.link import codec
from urc.model.messages import Envelope, Goto, Reply
from urc.model.snapshot import AxisStatus


def test_messages_and_statuses_cross_unchanged():
    msg = ("request", Envelope(7, 12.5, Goto(100.0, 30.0)))
    assert codec.loads(codec.dumps(msg)) == msg
    reply = ("reply", Reply(7, "error", ValueError("out of range"), None))
    got = codec.loads(codec.dumps(reply))
    assert isinstance(got[1].value, ValueError) and got[1].value.args == ("out of range",)


class _NotAMessage:
    def __init__(self, x):
        self.x = x


@pytest.mark.parametrize("payload", [
    os.system,                       # a function that would run on loading
    _NotAMessage(1),                 # a class of a module outside urc
    pickle.PickleBuffer,             # a standard type not on the list
])
def test_anything_else_is_refused_and_refused_again(payload):
    """Refused every time (a refusal leaves nothing behind that could admit it later)."""
    data = pickle.dumps(("request", payload), protocol=pickle.HIGHEST_PROTOCOL)
    for _ in range(2):
        with pytest.raises(pickle.UnpicklingError, match="the link refuses"):
            codec.loads(data)


def test_an_urc_name_that_is_not_a_data_type_is_refused():
    """Only the registry's data types (dataclasses, enums, named tuples, exceptions,
    models) of its listed modules: not a function such as the codec's own loads."""
    data = pickle.dumps(codec.loads, protocol=pickle.HIGHEST_PROTOCOL)
    with pytest.raises(pickle.UnpicklingError, match="urc.link.codec.loads"):
        codec.loads(data)
    assert codec.allowed_class("urc.model.snapshot", "AxisStatus") is AxisStatus


def test_every_commands_arguments_are_its_fields_in_order():
    """What the control process calls the Rotator method with (its field names are
    looked up once per type): each field by name, in order, for every command, twice."""
    import dataclasses

    from urc.model.messages import COMMANDS

    for cls in COMMANDS:
        fields = dataclasses.fields(cls)
        request = cls(*(f"v{i}" for i in range(len(fields))))
        expected = {f.name: f"v{i}" for i, f in enumerate(fields)}
        assert list(request.arguments().items()) == list(expected.items()), cls
        assert list(cls(*expected.values()).arguments().items()) == list(expected.items()), cls
