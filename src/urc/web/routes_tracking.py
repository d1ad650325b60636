"""Tracking endpoints, served when ``urc run`` hands the API a tracker.

The tracker contract (duck-typed; methods may be plain or ``async``)::

    passes(hours: float, min_el_deg: float) -> list[{"norad", "name", "aos", "tca", "los",
                                                     "max_el_deg", "aos_az_deg", "los_az_deg"}]
    track(request: dict) -> Any            # {"kind": "sun"|"moon"|"satellite"|"point"|"azel", ...}
    track_pass(norad: int, aos: datetime) -> Any
    stop() -> None
    status() -> None | {"target", "az_deg", "el_deg", "plan": {...}, "ground_track", ...}

``footprint_km`` in the status is the footprint's ground radius (sub-satellite point to
the edge where the satellite sets). ``passes`` runs in a worker thread; ``status`` is
called about once a second from a worker thread too (it is expensive), the commands on
the event loop's thread: a command that waits for anything (a catalog read, the control
process) must be ``async``, as TrackingService's are.

Without a tracker these routes do not exist (404): the page then hides its pass list
and track buttons.
"""

from __future__ import annotations

import asyncio
import inspect
import json
from typing import Any

from fastapi import APIRouter, Depends, Query, Response
from pydantic import BaseModel, Field

from ..dispatch.bodies import PassRequest, TrackRequest
from .context import WebContext
from .pass_search import MAX_HOURS, PassSearch
from .schemas import CONTROL_RESPONSES, Ok, Problem


class PassInfo(BaseModel):
    norad: int
    name: str
    aos: str = Field(description="acquisition of signal (UTC, ISO 8601): rising above min_el")
    tca: str
    los: str
    max_el_deg: float
    aos_az_deg: float
    los_az_deg: float


def _sync_call(fn: Any, **kw: Any) -> Any:
    """In a worker thread: a plain call, or an async tracker method run to completion."""
    out = fn(**kw)
    return asyncio.run(out) if inspect.iscoroutine(out) else out


def router(ctx: WebContext) -> APIRouter:
    r = APIRouter()
    # (the commands: a sub-router carrying the control dependency, typed as such, rather
    # than a dict of keyword arguments splatted into each decorator)
    ctl = APIRouter(dependencies=[Depends(ctx.control)], responses=CONTROL_RESPONSES)
    trk = ctx.tracker

    # encoded once per search in the worker thread and served as bytes: every open
    # dashboard asks for the same list, and validating and encoding a few hundred passes
    # per request kept the event loop busy and the control thread waiting for the GIL
    search = PassSearch(lambda hours, min_el_deg: json.dumps(
        _sync_call(trk.passes, hours=hours, min_el_deg=min_el_deg)).encode())

    @r.get("/api/passes", response_model=list[PassInfo],
           responses={503: {"model": Problem, "description": "the pass search is busy or took too long"}})
    async def passes(hours: float = Query(24.0, gt=0.0, le=MAX_HOURS),
                     min_el: float | None = Query(None, ge=0.0, le=90.0,
                                                  description="default: the tracker's tracking.min_el_deg")
                     ) -> Response:
        """Passes of the catalog's satellites over the station in the next ``hours``.
        AOS and LOS are where the pass crosses ``min_el`` (by default the elevation the
        tracker flies passes from, so this list and a pass's plan agree)."""
        return Response(await search.get(hours, ctx.cfg.tracking.min_el_deg if min_el is None else min_el),
                        media_type="application/json")

    # (the commands: urc.dispatch, shared with MQTT; a tracker's failure is a 409 with
    # reason "tracking", the page shows it)
    @ctl.post("/api/track")
    async def track(req: TrackRequest) -> Ok:
        await ctx.dispatch.track(req)
        return Ok()

    @ctl.post("/api/track/pass")
    async def track_pass(req: PassRequest) -> Ok:
        await ctx.dispatch.track_pass(req)
        return Ok()

    @ctl.post("/api/track/stop")
    async def track_stop() -> Ok:
        await ctx.dispatch.track_stop()
        return Ok()

    r.include_router(ctl)
    return r
