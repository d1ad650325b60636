"""A schedule of passes: highest priority first, no two passes competing for the antenna."""

from __future__ import annotations

from dataclasses import dataclass

from .passes import Pass

#: time between one pass's LOS and the next AOS needed to slew and settle
DEFAULT_SETUP_S = 60.0


@dataclass(frozen=True)
class Request:
    norad_id: int
    priority: int = 0  # larger wins


def build_schedule(passes: list[Pass], requests: list[Request], setup_s: float = DEFAULT_SETUP_S
                   ) -> tuple[list[Pass], list[tuple[Pass, Pass]]]:
    """Choose passes greedily by (priority, max elevation); a pass that overlaps one already
    chosen (with the setup gap) is dropped. Returns (schedule by AOS, [(dropped, winner)])."""
    prio = {r.norad_id: r.priority for r in requests}
    wanted = [p for p in passes if p.norad_id in prio]
    order = sorted(wanted, key=lambda p: (-prio[p.norad_id], -p.max_el_deg, p.aos_unix_s))
    chosen: list[Pass] = []
    dropped: list[tuple[Pass, Pass]] = []
    for p in order:
        clash = next((c for c in chosen if p.aos_unix_s < c.los_unix_s + setup_s
                      and c.aos_unix_s < p.los_unix_s + setup_s), None)
        if clash is None:
            chosen.append(p)
        else:
            dropped.append((p, clash))
    return sorted(chosen, key=lambda p: p.aos_unix_s), dropped
