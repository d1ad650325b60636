"""Poses in the *extended* frame, shared by the sessions that speak it (Tartu, G4JNT,
SPID, GS-232, SARCNET's monitor).

The extended frame is what a controller's own display and encoders show and what
``Rotator.goto`` accepts back: azimuth with its cable-wrap turns (e.g. 400 on a 450 deg
rotator, -10 on a -180..540 one), elevation past 90 when flipped over the top.

* :func:`extended_pose_deg` / :func:`extended_targets_deg`: a status in that frame.
* :class:`ExtendedTarget`: single-axis gotos in that frame (the other axis keeps its
  target in that frame, which the service's sky target cannot say).

Pure, no I/O.
"""

from __future__ import annotations

import math

from ..errors import CommandRejected
from ..model.messages import Goto, GotoAz, GotoEl, GotoPose, Move, Stop
from ..model.effects import Effects
from ..model.snapshot import Status
from .base import RotatorPort
from .single_axis import wire_el_axis, wire_el_deg
from ..angles import wrap180_deg


class PositionUnknown(CommandRejected):
    """A position query while a procedure (the BIG-RAS homing) runs: the axis counts
    in the procedure's own frame, so no number may be given as where it points. Each
    protocol answers it in its own error form."""

    def __init__(self, st: Status):
        what = ", ".join(f"{axis} ({name})" for axis, name in st.procedures.items())
        super().__init__(f"position unknown: {what} running", "uncertain")


def require_known(st: Status) -> Status:
    """``st``, or :class:`PositionUnknown` while a procedure runs on any axis."""
    if getattr(st, "procedures", None):
        raise PositionUnknown(st)
    return st


def frame_offsets_deg(st: Status) -> tuple[float, float]:
    """(az, el) to add to a mechanical angle (``st.az.pos_deg``, ``target_deg``) to get
    the extended frame: the mount offsets, from the snapshot (``Status.offsets``) or,
    where a snapshot lacks them, recovered from its sky and mechanical angles."""
    offsets = getattr(st, "offsets", None)
    if offsets and "az" in offsets and "el" in offsets:
        return float(offsets["az"]), float(offsets["el"])
    az_m, el_m = st.az.pos_deg, wire_el_axis(st).pos_deg
    el_off = ((180.0 - wire_el_deg(st)) if st.flipped else wire_el_deg(st)) - el_m
    az_sky_base = st.az_deg - 180.0 if st.flipped else st.az_deg
    az_off = wrap180_deg(az_sky_base - az_m)
    # a mount offset beyond +-180 deg: put the azimuth on the wrap turn the service says
    ext = az_m + az_off
    turns = math.floor(ext / 360.0)
    near_boundary = abs(ext - 360.0 * round(ext / 360.0)) < 1e-3
    if turns != st.wrap_turns and not near_boundary:
        az_off += 360.0 * (st.wrap_turns - turns)
    return az_off, el_off


def extended_pose_deg(st: Status) -> tuple[float, float]:
    """Where the axes are, in the frame a controller shows: azimuth including the wrap
    (e.g. 400.0, or -10.0 on a -180..540 rotator), elevation past 90 when flipped.
    Equals (st.az_deg, st.el_deg) for a rotator sitting in its first turn, unflipped.
    PositionUnknown while a procedure runs (:func:`require_known`)."""
    return shown_pose_deg(require_known(st))


def shown_pose_deg(st: Status) -> tuple[float, float]:
    """:func:`extended_pose_deg` unchecked: for a display that marks an unknown axis
    itself (:meth:`Status.position_unknown`)."""
    az_off, el_off = frame_offsets_deg(st)
    return st.az.pos_deg + az_off, wire_el_axis(st).pos_deg + el_off


def readback_pose_deg(st: Status) -> tuple[float, float]:
    """The position a compass-frame client (rotctld ``p``) reads back: the sky direction,
    except while the antenna is flipped over the top. Then it is the pose as such a client
    commands it (``P 10 120`` for the sky direction az 190, el 60) and as a controller
    with 0..180 deg elevation shows it: the azimuth axis' heading 0..360 and the
    elevation past 90. Hamlib's own dummy rotator reads back what was set, and Gpredict
    with flip compares ``p`` with what it sent: the sky direction, 180 deg away, made it
    re-send ``P`` every cycle."""
    require_known(st)
    if not st.flipped:
        return st.az_deg, wire_el_deg(st)
    az, el = extended_pose_deg(st)
    return az % 360.0, el


def extended_targets_deg(st: Status) -> tuple[float | None, float | None]:
    """The axes' present setpoints (where each axis is heading now) in the extended
    frame; None for an axis that holds no setpoint (idle, stopped)."""
    az_off, el_off = frame_offsets_deg(st)
    az_t, el_t = st.az.target_deg, wire_el_axis(st).target_deg
    return (None if az_t is None else az_t + az_off, None if el_t is None else el_t + el_off)


def _sky(az_deg: float, el_deg: float) -> tuple[float, float]:
    """The sky direction an extended (az, el) names (what the service keeps as target)."""
    if el_deg > 90.0:
        az_deg, el_deg = az_deg + 180.0, 180.0 - el_deg
    return az_deg % 360.0, el_deg


def _is_target(asked: tuple[float, float], st: Status) -> bool:
    """Is the service's sky target the direction ``asked`` names?"""
    if st.target_az_deg is None or st.target_el_deg is None:
        return False
    az, el = _sky(*asked)
    return abs(wrap180_deg(az - st.target_az_deg)) < 1e-6 and abs(el - st.target_el_deg) < 1e-6


def goto_named_axes(az_deg: float | None, el_deg: float | None) -> Effects[None]:
    """Go to whichever of az/el the command named; the other axis keeps its target."""
    if az_deg is not None and el_deg is not None:
        yield Goto(az_deg, el_deg)
    elif az_deg is not None:
        yield GotoAz(az_deg)
    elif el_deg is not None:
        yield GotoEl(el_deg)


def goto_extended(rotator: RotatorPort, az_deg: float, el_deg: float) -> Effects[None]:
    """Go to (az, el) in the extended frame as a protocol that speaks the controller's
    own azimuth means it: an azimuth within the rotator's range names that pose, the
    wrap turn included (``W000`` from 370 unwinds to 0; ``W010`` from 360 goes back to
    10, not on to 370), an elevation past 90 the flipped pose. Outside the range the
    service's rule applies (a negative down to -180 is a compass bearing, anything else
    is refused). Raises CommandRejected (at its ``yield``)."""
    yield extended_goto(rotator.status(), az_deg, el_deg)


def extended_goto(st: Status, az_deg: float, el_deg: float) -> Goto | GotoPose:
    """The command :func:`goto_extended` gives, from the status ``st`` (for a protocol
    command that sends it with others in one round trip)."""
    az_off, el_off = frame_offsets_deg(st)
    az_m = az_deg - az_off
    lo, hi = st.limits.get("az", (-math.inf, math.inf)) if st.limits else (-math.inf, math.inf)
    if not (math.isfinite(az_deg) and math.isfinite(el_deg)) or not lo - 1e-6 <= az_m <= hi + 1e-6:
        return Goto(az_deg, el_deg)
    el_m = el_deg - el_off
    el_limits = (st.limits or {}).get("el")
    if el_limits is not None and not el_limits[0] - 1e-6 <= el_m <= el_limits[1] + 1e-6:
        return Goto(az_deg, el_deg)  # the service refuses it in its own words
    return GotoPose(az_m, el_m)


class ExtendedTarget:
    """Gotos in the extended frame where a command names one axis only (Tartu GOAZ/GOEL,
    G4JNT ``G<az>``, Rot1Prog sets): the other axis keeps its target, in that frame.

    ``Rotator.goto_az``/``goto_el`` keep the other axis' *sky* target, which cannot
    tell elevation 60 from 120 over the top, or azimuth 20 from 380 in the overlap:
    handing it back would unflip or unwind the axis the command leaves alone. So this
    keeps the session's own last request, in its frame, for as long as the service
    still holds it (the service's status shows a new target only after its next tick:
    until then the session's own word stands). Otherwise the service decides, as for
    ``goto_az``: its target, or where the axes are after a stop, a move or a fault.
    """

    def __init__(self, rotator: RotatorPort, named: bool = False) -> None:
        """``named``: the protocol speaks the controller's own azimuth, so a set names
        its pose (:func:`goto_extended`); else 0..360 is a compass bearing."""
        self.rotator = rotator
        self.named = named
        #: (status t_s when asked, extended (az, el) asked, or None: stopped / moved)
        self._asked: tuple[float, tuple[float, float] | None] | None = None

    def goto(self, az: float | None, el: float | None) -> Effects[None]:
        """A goto with None = that axis keeps its target (raises CommandRejected)."""
        st = self.rotator.status()
        keep_az, keep_el = self._kept(st)
        az = keep_az if az is None else az
        el = keep_el if el is None else el
        if self.named:
            yield from goto_extended(self.rotator, az, el)
        else:
            yield Goto(az, el)
        self._asked = (st.t_s, (az, el))

    def stop(self, axis: str | None = None) -> Effects[None]:
        """A stop: like the service, no target from now on (either axis)."""
        st = self.rotator.status()
        yield Stop(axis)
        self._asked = (st.t_s, None)

    def move(self, axis: str, direction: int, speed_frac: float = 1.0) -> Effects[None]:
        st = self.rotator.status()
        yield Move(axis, direction, speed_frac)
        self._asked = (st.t_s, None)

    def forget(self) -> None:
        """After a re-reference (set_position): the service's word only."""
        self._asked = None

    def _kept(self, st: Status) -> tuple[float, float]:
        if self._asked is not None:
            t_s, asked = self._asked
            if t_s == st.t_s:                       # no tick since: the session's word stands
                return extended_pose_deg(st) if asked is None else asked
            if asked is not None and _is_target(asked, st):
                return asked                        # still the service's target
            self._asked = None                      # superseded: the service decides
        if st.target_az_deg is None or st.target_el_deg is None:
            return extended_pose_deg(st)
        if self.named:
            # the axes' own goals, on their turn (the sky target names none: kept as
            # a pose it would unwind an axis the command leaves alone)
            pose = extended_pose_deg(st)
            goals = extended_targets_deg(st)
            return (pose[0] if goals[0] is None else goals[0], pose[1] if goals[1] is None else goals[1])
        return st.target_az_deg, st.target_el_deg
