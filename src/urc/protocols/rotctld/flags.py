"""Which of Hamlib's rotator status flags (``rot_status_t``, rotctld's ``u``) a snapshot
shows. Their names and wire text are :mod:`urc.wire.rotctld`'s; reading them off a
:class:`~urc.model.snapshot.Status` is the server's, so the codec stays below it.
"""

from __future__ import annotations

from ...model.snapshot import AxisStatus, Status

#: an axis turning faster than this (deg/s) counts as moving even with the motor off (coasting)
MOVING_RATE_DEG_PER_S = 0.5


def _axis_motion(ax: AxisStatus) -> tuple[bool, int]:
    """(moving, direction -1/0/+1) of one axis from its snapshot."""
    driving = ax.mode in ("driving", "releasing")
    if not driving and abs(ax.rate_deg_per_s) <= MOVING_RATE_DEG_PER_S:
        return False, 0
    toward = ax.duty or ax.rate_deg_per_s or \
        (0.0 if ax.target_deg is None else ax.target_deg - ax.pos_deg)
    return True, (toward > 0) - (toward < 0)


def status_flags(st: Status, az_offset_deg: float = 0.0) -> list[str]:
    """rot_status_t names for a snapshot, in the mechanical sense of the axes (RIGHT =
    clockwise, UP = elevation angle increasing), like ``M``'s directions."""
    flags = []
    if st.faults:
        flags.append("BUSY")  # motion commands are refused until faults are cleared
    if st.moving:
        flags.append("MOVING")
        for ax, name, minus, plus in ((st.az, "AZ", "LEFT", "RIGHT"), (st.el, "EL", "DOWN", "UP")):
            if ax is None:  # no elevation axis
                continue
            moving, sign = _axis_motion(ax)
            if moving:
                flags.append("MOVING_" + name)
                if sign:
                    flags.append("MOVING_" + (plus if sign > 0 else minus))
    for ax, lo, hi in ((st.az, "LEFT", "RIGHT"), (st.el, "DOWN", "UP")):
        if ax is None:
            continue
        if ax.limit_min:
            flags.append("LIMIT_" + lo)
        if ax.limit_max:
            flags.append("LIMIT_" + hi)
    az = st.az.pos_deg + az_offset_deg  # past 0 or 360 in the cable-wrap overlap
    if az < 0.0:
        flags.append("OVERLAP_LEFT")
    elif az > 360.0:
        flags.append("OVERLAP_RIGHT")
    return flags
