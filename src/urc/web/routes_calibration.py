"""Calibration pages' API: zero, two-point pot, magnetometer, limit-switch homing.

These handlers are ``async`` on purpose: they run on the event loop thread, between
control ticks, so a sensor read and the re-reference that follows are never split by a tick.
The commands are urc.dispatch's (bodies and all); these routes put them on HTTP.
"""

from __future__ import annotations

from typing import Literal

from fastapi import APIRouter, Depends
from pydantic import Field

from ..dispatch.bodies import AxisRequest, HomingRequest, PotApplyRequest, ZeroRequest
from ..model.messages import DescribeSensors
from ..model.effects import call
from .context import WebContext
from .schemas import CONTROL_RESPONSES, Ok


class PotReading(Ok):
    axis: Literal["az", "el"]
    p: float = Field(description="the pot's linearised reading P (averaged)")
    reading_deg: float


class PotApplied(Ok):
    result: dict[str, float | None] = Field(description="M, C and the constants loaded")


class ProcedureState(Ok):
    procedure: dict | None = Field(description="kind, axis, state, step, progress (0..1)")


def router(ctx: WebContext) -> APIRouter:
    r = APIRouter(prefix="/api/calibration")
    # (the routes that act: a sub-router with the control dependency, typed as such; a
    # dict of keyword arguments splatted into each decorator was 112 of mypy's errors)
    ctl = APIRouter(dependencies=[Depends(ctx.control)], responses=CONTROL_RESPONSES)  # (under r's prefix)
    rot = ctx.rotator
    cmd = ctx.dispatch

    @r.get("")
    async def overview() -> dict:
        """Per axis: sensor, constants, procedures that apply; the running procedure."""
        return {"axes": await call(rot, DescribeSensors()), "procedure": ctx.hub.procedure_dict()}

    @ctl.post("/zero")
    async def zero(req: ZeroRequest) -> Ok:
        """Declare where the antenna points now (re-reference)."""
        await cmd.zero(req)
        return Ok()

    @ctl.post("/pot/read")
    async def pot_read(req: AxisRequest) -> PotReading:
        """The pot's linearised reading P here (averaged), for a two-point calibration."""
        read = await cmd.pot_read(req)
        return PotReading(axis=req.axis, p=read.p, reading_deg=read.reading_deg)

    @ctl.post("/pot/apply")
    async def pot_apply(req: PotApplyRequest) -> PotApplied:
        """Compute M and C from two (bearing, P) points and load them."""
        return PotApplied(result=await cmd.pot_apply(req))  # (NaN, a constant never set: null)

    @ctl.post("/magnetometer")
    async def magnetometer() -> ProcedureState:
        """Start the 12-direction hard-iron calibration (the antenna turns all the way round)."""
        await cmd.magnetometer()
        return ProcedureState(procedure=ctx.hub.procedure_dict())

    @ctl.post("/homing")
    async def homing(req: HomingRequest) -> ProcedureState:
        """Start limit-switch homing of one axis (slow jog onto the lower switch)."""
        await cmd.homing(req)
        return ProcedureState(procedure=ctx.hub.procedure_dict())

    @ctl.post("/controller-home")
    async def controller_home() -> Ok:
        """Have a bridged controller (the SatNOGS firmware) home on its own endstops; its
        position is unknown until it answers again (the status says it homes)."""
        await cmd.controller_home()
        return Ok()

    @r.get("/procedure")
    async def procedure() -> ProcedureState:
        return ProcedureState(procedure=ctx.hub.procedure_dict())

    @ctl.post("/procedure/cancel")
    async def cancel() -> ProcedureState:
        await ctx.hub.cancel_procedure()
        return ProcedureState(procedure=ctx.hub.procedure_dict())

    r.include_router(ctl)
    return r
