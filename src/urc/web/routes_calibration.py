"""Calibration pages' API: zero, two-point pot, magnetometer, limit-switch homing.

These handlers are ``async`` on purpose: they run on the event loop thread, between
control ticks, so a sensor read and the re-reference that follows are never split by a tick.
"""

from __future__ import annotations

from typing import Literal

from fastapi import APIRouter, Depends
from pydantic import BaseModel, Field

from ..service import calibration as cal
from .context import WebContext


class ZeroRequest(BaseModel):
    az_deg: float | None = Field(None, allow_inf_nan=False)
    el_deg: float | None = Field(None, allow_inf_nan=False)


class AxisRequest(BaseModel):
    axis: Literal["az", "el"]


class PotPoint(BaseModel):
    bearing_deg: float = Field(allow_inf_nan=False, ge=-360.0, le=720.0)
    p: float = Field(allow_inf_nan=False)


class PotApplyRequest(BaseModel):
    axis: Literal["az", "el"]
    points: list[PotPoint] = Field(min_length=2, max_length=2)


class HomingRequest(BaseModel):
    axis: Literal["az", "el"]
    speed_frac: float | None = Field(None, gt=0.0, le=1.0)
    switch_deg: float | None = Field(None, allow_inf_nan=False)


def router(ctx: WebContext) -> APIRouter:
    r = APIRouter(prefix="/api/calibration")
    control = [Depends(ctx.control)]
    rot = ctx.rotator

    @r.get("")
    async def overview() -> dict:
        """Per axis: sensor, constants, procedures that apply; the running procedure."""
        return {"axes": cal.describe_sensors(rot), "procedure": ctx.hub.procedure_dict()}

    @r.post("/zero", dependencies=control)
    async def zero(req: ZeroRequest) -> dict:
        """Declare where the antenna points now (re-reference)."""
        cal.zero(rot, req.az_deg, req.el_deg)
        return {"ok": True}

    @r.post("/pot/read", dependencies=control)
    async def pot_read(req: AxisRequest) -> dict:
        """The pot's linearised reading P here (averaged), for a two-point calibration."""
        sensor = rot.hw.axis(req.axis).sensor
        status = rot.status()
        return {"ok": True, "axis": req.axis, "p": cal.pot_units(sensor),
                "reading_deg": getattr(status, req.axis).pos_deg + status.offsets.get(req.axis, 0.0)}

    @r.post("/pot/apply", dependencies=control)
    async def pot_apply(req: PotApplyRequest) -> dict:
        """Compute M and C from two (bearing, P) points and load them."""
        result = cal.pot_apply(rot, req.axis, [(p.bearing_deg, p.p) for p in req.points])
        return {"ok": True, "result": result}

    @r.post("/magnetometer", dependencies=control)
    async def magnetometer() -> dict:
        """Start the 12-direction hard-iron calibration (the antenna turns all the way round)."""
        ctx.hub.start_procedure(cal.MagnetometerCalibration(rot))
        return {"ok": True, "procedure": ctx.hub.procedure_dict()}

    @r.post("/homing", dependencies=control)
    async def homing(req: HomingRequest) -> dict:
        """Start limit-switch homing of one axis (slow jog onto the lower switch)."""
        ctx.hub.start_procedure(cal.LimitSwitchHoming(rot, req.axis, req.speed_frac, req.switch_deg))
        return {"ok": True, "procedure": ctx.hub.procedure_dict()}

    @r.get("/procedure")
    async def procedure() -> dict:
        return {"procedure": ctx.hub.procedure_dict()}

    @r.post("/procedure/cancel", dependencies=control)
    async def cancel() -> dict:
        if ctx.hub.procedure is not None:
            ctx.hub.procedure.cancel()
        return {"ok": True, "procedure": ctx.hub.procedure_dict()}

    return r
