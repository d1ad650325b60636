"""evolve: the control law's fast dataclasses.replace, equal to it on its state records
(the law's, the fault monitor's and its limits, which a bridged axis widens each tick);
construct: the same for the records the tick makes afresh (status, monitor inputs, the
law's output, the filter's estimate)."""

from __future__ import annotations

import dataclasses

import pytest

from urc.control.evolve import construct, evolve
from urc.control.faults import FaultLimits, MonitorInputs, MonitorState
from urc.control.estimator import Estimate
from urc.control.law import AxisOutput, AxisState
from urc.model.snapshot import AxisStatus, Status
from urc.rotator.state_writer import WriterReport


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


def _construct_cases():
    axis = AxisStatus(pos_deg=1.5, rate_deg_per_s=-0.25, target_deg=None, mode="holding", duty=0.0,
                      brake_released=False, uncertainty_deg=0.0, limit_min=False, limit_max=True, current_a=0.4)
    status = Status(t_s=2.0, profile="tartu-urc", az_deg=10.0, el_deg=None, az=axis, el=None, target_az_deg=None,
                    target_el_deg=None, flipped=False, wrap_turns=0, moving=False, parked=True,
                    position_known=True, faults=(), events=("x",), tick_late_p99_ms=0.5, axes=("az",))
    return [axis, status, MonitorInputs(now_s=1.0, meas_deg=None, current_a=float("inf")),
            WriterReport(durable=None, pending=True, error="", writes=1, failures=0),
            AxisOutput(duty=-0.5, brake_released=True, driving=True), Estimate(pos_deg=3.0, rate_deg_per_s=-1.0)]


@pytest.mark.parametrize("record", _construct_cases(), ids=lambda r: type(r).__name__)
def test_construct_equals_the_dataclass_own_init(record):
    """construct (the status snapshots and the monitor's inputs, made every tick) builds
    what the class' own __init__ does, and they are plain frozen dataclasses as it needs."""
    cls = type(record)
    values = {f.name: getattr(record, f.name) for f in dataclasses.fields(cls)}
    new = construct(cls, **values)
    assert new == cls(**values) and repr(new) == repr(record) and type(new) is cls
    assert list(vars(new)) == list(values)
    with pytest.raises(dataclasses.FrozenInstanceError):
        setattr(new, next(iter(values)), None)
    assert cls.__dataclass_params__.frozen and not hasattr(cls, "__post_init__")
    assert all(f.init for f in dataclasses.fields(cls)) and "__slots__" not in cls.__dict__


def test_construct_refuses_a_missing_or_unknown_field_and_takes_any_order():
    with pytest.raises(TypeError, match="failures$"):
        construct(WriterReport, durable=None, pending=False, error="", writes=0)
    with pytest.raises(TypeError, match="failure, failures$"):
        construct(WriterReport, durable=None, pending=False, error="", writes=0, failure=0)
    # (the class' order is only the fast path: a call in another order makes the same record)
    assert construct(WriterReport, durable=None, pending=False, error="", failures=2, writes=1) == \
        WriterReport(durable=None, pending=False, error="", writes=1, failures=2)
