"""Simulator-only debug endpoints: inject and clear simulated hardware faults.

Refused (403) on any other backend: on real iron there is nothing to inject into.
"""

from __future__ import annotations

from typing import Literal

from fastapi import APIRouter, Depends, HTTPException
from pydantic import Field

from ..dispatch.bodies import Deg, Strict
from ..ipc.messages import HardwareInfo
from ..ipc.messages import SimClear as ClearQuery
from ..ipc.messages import SimFault as FaultQuery
from ..service.effects import call
from ..service.queries import ask
from .context import WebContext
from .schemas import CONTROL_RESPONSES, Ok

FaultKind = Literal["sensor_stuck", "sensor_jump", "sensor_dead", "jam", "runaway", "limit_switch",
                    "reverse_wiring", "slow_read"]


class SimFault(Strict):
    axis: Literal["az", "el"]
    kind: FaultKind
    deg: Deg | None = Field(None, description="sensor_jump: offset of the reading")
    duty: float | None = Field(None, strict=True, allow_inf_nan=False, ge=-1.0, le=1.0,
                               description="runaway: stuck duty")
    which: Literal["min", "max", "both"] | None = Field(None, description="limit_switch: which one")
    delay_s: float | None = Field(None, strict=True, allow_inf_nan=False, ge=0.0, le=10.0,
                                  description="slow_read: how long each slow read blocks")
    reads: int | None = Field(None, strict=True, ge=0, le=1000, description="slow_read: how many reads")


class SimClear(Strict):
    axis: Literal["az", "el"]
    kind: FaultKind | None = None


def router(ctx: WebContext) -> APIRouter:
    r = APIRouter(prefix="/api/sim", dependencies=[Depends(ctx.control)], responses=CONTROL_RESPONSES)

    def simulated() -> None:
        # the simulator, or the gpio backend on emulated parts (the faults reach them)
        if not ask(ctx.rotator, HardwareInfo()).simulator:
            raise HTTPException(403, "fault injection exists only on the simulator (sim, or gpio emulated)")

    @r.post("/fault")
    async def inject(req: SimFault) -> Ok:
        """Simulator only: make the simulated hardware fail (the controller is not told)."""
        kw = {k: v for k, v in (("deg", req.deg), ("duty", req.duty), ("which", req.which),
                                ("delay_s", req.delay_s), ("reads", req.reads)) if v is not None}
        try:
            simulated()
            await call(ctx.rotator, FaultQuery(req.axis, req.kind, kw))
        except ValueError as exc:
            raise HTTPException(409, str(exc)) from None
        return Ok()

    @r.post("/clear")
    async def clear(req: SimClear) -> Ok:
        """Simulator only: repair the simulated hardware (latched faults still need clearing)."""
        simulated()
        await call(ctx.rotator, ClearQuery(req.axis, req.kind))
        return Ok()

    return r
