"""evolve: the control law's fast dataclasses.replace, equal to it on its state records
(the law's, the fault monitor's and its limits, which a bridged axis widens each tick)."""

from __future__ import annotations

import dataclasses

import pytest

from urc.control.evolve import evolve
from urc.control.faults import FaultLimits, MonitorState
from urc.control.law import AxisState


@pytest.mark.parametrize("record,changes", [
    (AxisState(), {"mode": "driving", "ref_deg": 12.5, "coast_deg": (0.1, 0.2)}),
    (AxisState(seq=3, arrived=True), {"arrived": False}),
    (MonitorState(), {"prev_deg": 4.0, "unreadable_ticks": 2, "running_a": 0.7}),
    (FaultLimits("az", 0.0, 360.0, 10.0, 1.0, 0.1, 0.01),
     {"sensor_jump_deg": 9.0, "runaway_deg": 3.0, "stall_timeout_s": 4.5}),
])
def test_evolve_equals_replace(record, changes):
    before = dataclasses.replace(record)
    new = evolve(record, **changes)
    assert new == dataclasses.replace(record, **changes) and new is not record
    assert hash(new) == hash(dataclasses.replace(record, **changes))
    assert record == before   # the original is untouched
    with pytest.raises(dataclasses.FrozenInstanceError):
        setattr(new, next(iter(changes)), None)


def test_evolve_refuses_a_name_that_is_not_a_field():
    with pytest.raises(TypeError, match="no field ref_dge"):
        evolve(AxisState(), ref_dge=1.0)


@pytest.mark.parametrize("cls", [AxisState, MonitorState, FaultLimits])
def test_the_state_records_are_plain_frozen_dataclasses(cls):
    """What evolve relies on: no __post_init__, every field in __init__, no __slots__."""
    assert cls.__dataclass_params__.frozen and not hasattr(cls, "__post_init__")
    assert all(f.init for f in dataclasses.fields(cls)) and "__slots__" not in cls.__dict__
