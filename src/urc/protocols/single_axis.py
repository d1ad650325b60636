"""What a protocol session sees of a single-axis (azimuth only) rotator.

The service reports such a rotator's elevation as absent (``Status.el is None``): it
measures none. On the wire, though, the original single-axis controllers still answer
the elevation fields of their replies, with 0: a GS-232A on an azimuth rotator answers
``C2`` with ``+0aaa+0000``, Hamlib's azimuth-only backends (GS-232A azimuth, Rot1Prog,
Rotor-EZ) read back el 0.000000 and report ``min_el = max_el = 0``, ``rot_type=Az``. So
every session gets a :class:`SingleAxisPort`: the rotator, with a status whose elevation
is that wire value (standing, no target, limits 0..0). Commands go straight through:
the service ignores the elevation of a two-axis goto and refuses elevation-only commands
(reason "no_axis"), which each protocol answers in its own form.

Pure, no I/O.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

from ..model.snapshot import AxisStatus, Status
from .base import RotatorPort

#: what a single-axis controller answers for elevation
WIRE_EL_DEG = 0.0

#: (holding: an absent axis is always where it is, so "both axes on target" follows the azimuth)
_STANDING = AxisStatus(pos_deg=WIRE_EL_DEG, rate_deg_per_s=0.0, target_deg=None, mode="holding", duty=0.0,
                       brake_released=False, uncertainty_deg=0.0, limit_min=False, limit_max=False,
                       current_a=0.0)


def wire_el_axis(st: Status) -> AxisStatus:
    """The elevation axis a session reads: the rotator's, or the standing one the wire
    shows for a single-axis rotator (as :func:`wire_status` puts in the status)."""
    return _STANDING if st.el is None else st.el


def wire_el_deg(st: Status) -> float:
    """The elevation a session reads: the rotator's, or the wire's 0 (single-axis)."""
    return WIRE_EL_DEG if st.el_deg is None else st.el_deg


def wire_status(st: Status) -> Status:
    """``st`` with the elevation a single-axis controller puts on the wire (unchanged
    for a rotator that has elevation)."""
    if st.el is not None:
        return st
    return replace(st, el_deg=WIRE_EL_DEG, el=_STANDING,
                   target_el_deg=None if st.target_az_deg is None else WIRE_EL_DEG,
                   limits={**st.limits, "el": (WIRE_EL_DEG, WIRE_EL_DEG)},
                   offsets={**st.offsets, "el": 0.0})


class SingleAxisPort:
    """A rotator as sessions see it (:func:`wire_status`); everything else passes on."""

    def __init__(self, rotator: RotatorPort) -> None:
        self._rotator = rotator

    def status(self) -> Status:
        return wire_status(self._rotator.status())

    def __getattr__(self, name: str) -> Any:
        return getattr(self._rotator, name)


def session_port(rotator: RotatorPort) -> RotatorPort:
    """The port to hand a session: wrapped when the rotator has no elevation axis."""
    if isinstance(rotator, SingleAxisPort):
        return rotator
    try:
        has_el = rotator.status().el is not None
    except Exception:  # a stand-in without a status yet: as it is
        return rotator
    return rotator if has_el else SingleAxisPort(rotator)


def has_elevation(rotator: Any) -> bool:
    """Does the rotator behind a session's port have an elevation axis?"""
    return not isinstance(rotator, SingleAxisPort)
