"""urc.dispatch.errors: a body parsed or refused naming its fields (the text MQTT answers)."""

from __future__ import annotations

import pytest
from pydantic import TypeAdapter, ValidationError

from urc.dispatch.bodies import GotoRequest, TrackRequest
from urc.dispatch.errors import Invalid, describe, parse


def errors_of(model, data):
    with pytest.raises(ValidationError) as err:
        TypeAdapter(model).validate_python(data)
    return err.value.errors(include_url=False)


def test_parse_takes_a_model_as_it_is_and_checks_anything_else():
    body = GotoRequest(az_deg=1.0)
    assert parse(GotoRequest, body) is body
    assert parse(GotoRequest, {"az_deg": 1.0}) == body
    with pytest.raises(Invalid) as err:
        parse(GotoRequest, {"az_deg": 1.0, "az": 2})
    assert str(err.value) == "az: unknown field" and err.value.reason == "invalid"


def test_describe_names_each_field_and_what_was_found_at_most_three():
    text = describe(errors_of(GotoRequest, {"az_deg": "x", "el_deg": 500.0, "a": 1, "b": 2}))
    assert text.startswith("az_deg: Input should be a valid number, found 'x'; el_deg: ")
    assert text.count(";") == 2 and "found 500.0" in text


def test_a_rule_over_several_fields_is_said_of_the_command():
    assert describe(errors_of(TrackRequest, {"kind": "point", "lat_deg": 1.0})).startswith(
        "command: Value error, kind 'point' needs lon_deg")


def test_describe_a_tagged_union_lists_the_commands():
    from typing import Annotated, Literal

    from pydantic import BaseModel, Field

    class A(BaseModel):
        command: Literal["a"]

    class B(BaseModel):
        command: Literal["b"]
        x: int

    union = Annotated[A | B, Field(discriminator="command")]
    assert describe(errors_of(union, {"command": "c"}), ("a", "b")) == "command: expected one of a, b, found 'c'"
    assert describe(errors_of(union, {}), ("a", "b")) == "command: missing (one of a, b)"
    assert describe(errors_of(union, {"command": "b", "x": "one"}), ("a", "b")).startswith("x: ")
