"""Simulator-only debug endpoints: inject and clear simulated hardware faults.

Refused (403) on any other backend: on real iron there is nothing to inject into. The
commands are urc.dispatch's; these routes put them on HTTP.
"""

from __future__ import annotations

from fastapi import APIRouter, Depends, HTTPException

from ..dispatch.bodies import SimClear, SimFault
from ..dispatch.errors import NotSimulated
from .context import WebContext
from .schemas import CONTROL_RESPONSES, Ok


def router(ctx: WebContext) -> APIRouter:
    r = APIRouter(prefix="/api/sim", dependencies=[Depends(ctx.control)], responses=CONTROL_RESPONSES)

    @r.post("/fault")
    async def inject(req: SimFault) -> Ok:
        """Simulator only: make the simulated hardware fail (the controller is not told)."""
        try:
            await ctx.dispatch.sim_fault(req)
        except NotSimulated as exc:
            raise HTTPException(403, str(exc)) from None
        except ValueError as exc:  # (a fault this rotator cannot have)
            raise HTTPException(409, str(exc)) from None
        return Ok()

    @r.post("/clear")
    async def clear(req: SimClear) -> Ok:
        """Simulator only: repair the simulated hardware (latched faults still need clearing)."""
        try:
            await ctx.dispatch.sim_clear(req)
        except NotSimulated as exc:
            raise HTTPException(403, str(exc)) from None
        return Ok()

    return r
