"""Status building: the immutable :class:`Status` every client reads, made from the
rotator's parts once per tick (and after a command that must show at once).

The sky direction is worked out here from the mechanical axes: the mount offsets, the
wrap turn, a flipped pose (past the zenith) shown as the sky direction it points at, and
the fitted pointing model (Geometry.beam_of): the position reported is where the beam points.
"""

from __future__ import annotations

import math
from typing import Any

from ..control.evolve import construct
from ..control.geometry import wrap360
from .core import Core
from ..model.snapshot import Status
from .timing import LoopHealth


def build_status(core: Core, now_s: float, loop: LoopHealth, loop_dict: dict[str, Any], save_error: str,
                 local_control: tuple[str, ...], searches: tuple[str, ...] = ()) -> Status:
    """``loop_dict``: ``loop.as_dict()`` (LoopTiming.health_dict: rounded once, not every
    tick). ``searches``: the axes in a reference search (homing): their position is no
    number a client may be given (Status.procedures)."""
    az, el = core.axes["az"], core.axes.get("el")
    g = core.geometry
    tgt = core.target_sky
    if el is None:
        # no elevation axis: nothing measured, nothing to report (None, not a 0)
        sky_az, sky_el, flipped, tgt_el = wrap360(az.meas_deg + g.az_offset_deg), None, False, None
    else:
        el_ext = el.meas_deg + g.el_offset_deg
        # within the tolerance past the zenith the antenna stands at its own azimuth,
        # not "flipped" to the other side (a resting antenna at el 90 reads 90.05)
        flipped = el_ext > 90.0 + el.tuning.tolerance_deg
        sky_az = wrap360(az.meas_deg + g.az_offset_deg + (180.0 if flipped else 0.0))
        sky_el = min(el_ext, 180.0 - el_ext)
        if g.pointing_deg:
            sky_az, sky_el = g.beam_of(sky_az, sky_el)
        tgt_el = None if tgt is None else tgt[1]
    # (construct: made every tick, see urc.control.evolve; every field, in their order)
    return construct(
        Status, t_s=now_s, profile=core.caps.name, az_deg=round(sky_az, 4) % 360.0, el_deg=sky_el,
        az=az.status(), el=None if el is None else el.status(),
        target_az_deg=None if tgt is None else tgt[0], target_el_deg=tgt_el,
        flipped=flipped,
        wrap_turns=int(math.floor((az.meas_deg + g.az_offset_deg) / 360.0)),
        moving=core.moving(), parked=core.parked, position_known=not core.position_uncertain(),
        faults=tuple(core.faults), events=tuple(core.events), tick_late_p99_ms=loop.late_p99_ms,
        sim_truth=core.hw.sim_truth(),
        limits={n: ax.limits for n, ax in core.axes.items()},
        offsets={"az": g.az_offset_deg, "el": g.el_offset_deg},
        state_error=save_error, loop=loop_dict,
        local_control=local_control,
        axes=tuple(core.axes),
        procedures={n: "reference search" for n in searches},
        last_stop=core.last_stop,
        program=core.program_view(),
        program_end=core.program_end)

