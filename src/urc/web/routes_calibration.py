"""Calibration pages' API: zero, two-point pot, magnetometer, limit-switch homing.

These handlers are ``async`` on purpose: they run on the event loop thread, between
control ticks, so a sensor read and the re-reference that follows are never split by a tick.
"""

from __future__ import annotations

import asyncio
import math
from typing import Literal

from fastapi import APIRouter, Depends
from pydantic import Field

from ..model.messages import ControllerHome, DescribeSensors, PotApply, PotUnits, SetPosition
from ..model.effects import call
from .context import WebContext
from .schemas import CONTROL_RESPONSES, AzDeg, Deg, ElDeg, Ok, Strict


class ZeroRequest(Strict):
    az_deg: AzDeg | None = None
    el_deg: ElDeg | None = None


class AxisRequest(Strict):
    axis: Literal["az", "el"]


class PotPoint(Strict):
    bearing_deg: AzDeg
    p: float = Field(strict=True, allow_inf_nan=False)


class PotApplyRequest(Strict):
    axis: Literal["az", "el"]
    points: list[PotPoint] = Field(min_length=2, max_length=2)


class HomingRequest(Strict):
    axis: Literal["az", "el"]
    speed_frac: float | None = Field(None, strict=True, gt=0.0, le=1.0, allow_inf_nan=False)
    switch_deg: Deg | None = None


class PotReading(Ok):
    axis: Literal["az", "el"]
    p: float = Field(description="the pot's linearised reading P (averaged)")
    reading_deg: float


class PotApplied(Ok):
    result: dict[str, float | None] = Field(description="M, C and the constants loaded")


class ProcedureState(Ok):
    procedure: dict | None = Field(description="kind, axis, state, step, progress (0..1)")


def _load_calibration():
    from ..procedures import calibration

    return calibration


async def _calibration():
    """urc.procedures.calibration, imported at the first command that needs it and on a
    worker thread (lazy: its numpy would cost every start, and the event loop ~0.15 s)."""
    return await asyncio.to_thread(_load_calibration)


def router(ctx: WebContext) -> APIRouter:
    r = APIRouter(prefix="/api/calibration")
    # (the routes that act: a sub-router with the control dependency, typed as such; a
    # dict of keyword arguments splatted into each decorator was 112 of mypy's errors)
    ctl = APIRouter(dependencies=[Depends(ctx.control)], responses=CONTROL_RESPONSES)  # (under r's prefix)
    rot = ctx.rotator

    @r.get("")
    async def overview() -> dict:
        """Per axis: sensor, constants, procedures that apply; the running procedure."""
        return {"axes": await call(rot, DescribeSensors()), "procedure": ctx.hub.procedure_dict()}

    @ctl.post("/zero")
    async def zero(req: ZeroRequest) -> Ok:
        """Declare where the antenna points now (re-reference)."""
        await call(rot, SetPosition(req.az_deg, req.el_deg))  # (calibration.zero's request)
        return Ok()

    @ctl.post("/pot/read")
    async def pot_read(req: AxisRequest) -> PotReading:
        """The pot's linearised reading P here (averaged), for a two-point calibration."""
        p = await call(rot, PotUnits(req.axis))
        status = rot.status()  # (the reply's: read with P)
        return PotReading(axis=req.axis, p=p,
                          reading_deg=getattr(status, req.axis).pos_deg + status.offsets.get(req.axis, 0.0))

    @ctl.post("/pot/apply")
    async def pot_apply(req: PotApplyRequest) -> PotApplied:
        """Compute M and C from two (bearing, P) points and load them."""
        result = await call(rot, PotApply(req.axis, tuple((p.bearing_deg, p.p) for p in req.points)))
        # JSON has no NaN (an old constant that was never set): null
        return PotApplied(result={k: v if math.isfinite(v) else None for k, v in result.items()})

    @ctl.post("/magnetometer")
    async def magnetometer() -> ProcedureState:
        """Start the 12-direction hard-iron calibration (the antenna turns all the way round)."""
        cal = await _calibration()
        ctx.hub.start_procedure(await ctx.hub.procedure_step(cal.MagnetometerCalibration, rot))
        return ProcedureState(procedure=ctx.hub.procedure_dict())

    @ctl.post("/homing")
    async def homing(req: HomingRequest) -> ProcedureState:
        """Start limit-switch homing of one axis (slow jog onto the lower switch)."""
        cal = await _calibration()
        ctx.hub.start_procedure(await ctx.hub.procedure_step(cal.LimitSwitchHoming, rot, req.axis, req.speed_frac,
                                                                req.switch_deg))
        return ProcedureState(procedure=ctx.hub.procedure_dict())

    @ctl.post("/controller-home")
    async def controller_home() -> Ok:
        """Have a bridged controller (the SatNOGS firmware) home on its own endstops; its
        position is unknown until it answers again (the status says it homes)."""
        await call(rot, ControllerHome())
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
