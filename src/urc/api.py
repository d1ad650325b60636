"""The HTTP control API (FastAPI): what ``urc status/goto/stop/park`` and the web page use.

Reading is open; control needs the configured token when the API listens beyond
loopback (``Authorization: Bearer <token>``). Every command goes through the rotator
service, which validates it; a refusal is HTTP 409 with the reason.
"""

from __future__ import annotations

import hmac
from typing import Literal

from fastapi import Depends, FastAPI, Header, HTTPException
from fastapi.responses import JSONResponse
from pydantic import BaseModel, Field

from . import __version__
from .config import Config
from .errors import CommandRejected
from .service import Rotator


class GotoRequest(BaseModel):
    az_deg: float = Field(allow_inf_nan=False)
    el_deg: float = Field(allow_inf_nan=False)


class MoveRequest(BaseModel):
    axis: Literal["az", "el"]
    direction: Literal[-1, 1]
    speed: float = Field(1.0, gt=0.0, le=1.0, description="fraction of the axis' top speed")


class StopRequest(BaseModel):
    axis: Literal["az", "el"] | None = None


class PositionRequest(BaseModel):
    az_deg: float | None = Field(None, allow_inf_nan=False)
    el_deg: float | None = Field(None, allow_inf_nan=False)


class Accepted(BaseModel):
    ok: bool = True
    route: list[tuple[float, float]] = []


def create_api(rotator: Rotator, cfg: Config) -> FastAPI:
    app = FastAPI(title="urc control API", version=__version__,
                  description="Universal Rotator Controller: status and control")

    def control_allowed(authorization: str | None = Header(None)) -> None:
        if not cfg.api.control_requires_token:
            return
        supplied = (authorization or "").removeprefix("Bearer ").strip()
        if not cfg.api.token or not hmac.compare_digest(supplied, cfg.api.token):
            raise HTTPException(401, "control needs the API token (Authorization: Bearer <token>)")

    @app.exception_handler(CommandRejected)
    async def rejected(_request, exc: CommandRejected) -> JSONResponse:
        return JSONResponse({"ok": False, "error": str(exc), "reason": exc.reason}, status_code=409)

    @app.get("/api/status")
    def status() -> dict:
        return rotator.status().as_dict()

    @app.post("/api/goto", dependencies=[Depends(control_allowed)])
    def goto(req: GotoRequest) -> Accepted:
        return Accepted(route=rotator.goto(req.az_deg, req.el_deg))

    @app.post("/api/park", dependencies=[Depends(control_allowed)])
    def park() -> Accepted:
        return Accepted(route=rotator.park())

    @app.post("/api/stop", dependencies=[Depends(control_allowed)])
    def stop(req: StopRequest | None = None) -> Accepted:
        rotator.stop(req.axis if req else None)
        return Accepted()

    @app.post("/api/move", dependencies=[Depends(control_allowed)])
    def move(req: MoveRequest) -> Accepted:
        rotator.move(req.axis, req.direction, req.speed)
        return Accepted()

    @app.post("/api/set-position", dependencies=[Depends(control_allowed)])
    def set_position(req: PositionRequest) -> Accepted:
        rotator.set_position(req.az_deg, req.el_deg)
        return Accepted()

    @app.post("/api/clear-faults", dependencies=[Depends(control_allowed)])
    def clear_faults() -> Accepted:
        rotator.clear_faults()
        return Accepted()

    return app
