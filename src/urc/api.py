"""The HTTP control API (FastAPI): what ``urc status/goto/stop/park`` and the web page use.

Reading is open; control needs the configured token when the API listens beyond
loopback (``Authorization: Bearer <token>``). Every command goes through the rotator
service, which validates it; a refusal is HTTP 409 with the reason. The web dashboard
(``urc.web``) is served from ``/`` by the same app, with its live feed on ``/api/ws``.
"""

from __future__ import annotations

import asyncio
import os
from typing import Any

from fastapi import Depends, FastAPI
from fastapi.responses import JSONResponse
from pydantic import BaseModel, Field

from . import __version__
from .config import Config
from .errors import CommandRejected, UrcError
from .service import Rotator
from .service.calibration import CalibrationError
from .web import WebContext, install
from .web.live import FRAME_HZ, Hub
from .web.routes_live import MoveRequest, StopRequest
from .web.security import SecurityHeaders, control_guard
from .web.settings_store import SettingsStore


class GotoRequest(BaseModel):
    az_deg: float = Field(allow_inf_nan=False)
    el_deg: float = Field(allow_inf_nan=False)


class PositionRequest(BaseModel):
    az_deg: float | None = Field(None, allow_inf_nan=False)
    el_deg: float | None = Field(None, allow_inf_nan=False)


class Accepted(BaseModel):
    ok: bool = True
    route: list[tuple[float, float]] = []


def create_api(rotator: Rotator, cfg: Config, *, config_path: str | os.PathLike | None = None,
               state_dir: str | os.PathLike | None = None, tracker: Any = None,
               frame_hz: float = FRAME_HZ) -> FastAPI:
    """The app ``urc run`` serves.

    ``config_path``: the file ``urc run`` was started with (the settings page saves
    there; without one it saves to ``<state_dir>/urc.toml``). ``tracker``: the tracking
    service (see ``urc.web.routes_tracking``); None = no tracking endpoints.
    """
    app = FastAPI(title="urc control API", version=__version__,
                  description="Universal Rotator Controller: status, control, calibration, settings; "
                              "the dashboard is at /")
    if state_dir is None and getattr(rotator, "store", None) is not None:
        state_dir = rotator.store.path.parent
    hub = Hub(rotator, tracker, frame_hz)
    control_allowed = control_guard(cfg)
    ctx = WebContext(rotator=rotator, cfg=cfg, hub=hub, settings=SettingsStore(cfg, config_path, state_dir),
                     control=control_allowed, tracker=tracker)
    app.state.web = ctx
    app.add_middleware(SecurityHeaders, on_request=hub.ensure_started)
    try:  # inside ``urc run`` the loop runs already: record history from the start
        asyncio.get_running_loop()
        hub.ensure_started()
    except RuntimeError:
        pass  # tests: started by the first request instead

    @app.exception_handler(CommandRejected)
    async def rejected(_request, exc: CommandRejected) -> JSONResponse:
        return JSONResponse({"ok": False, "error": str(exc), "reason": exc.reason}, status_code=409)

    @app.exception_handler(CalibrationError)
    async def calibration_failed(_request, exc: CalibrationError) -> JSONResponse:
        return JSONResponse({"ok": False, "error": str(exc), "reason": "calibration"}, status_code=409)

    @app.exception_handler(UrcError)
    async def refused(_request, exc: UrcError) -> JSONResponse:
        return JSONResponse({"ok": False, "error": str(exc), "reason": type(exc).__name__}, status_code=409)

    # Handlers are coroutines: they run on the event loop thread, like the control loop,
    # so commands reach the rotator service from its own thread (FastAPI would run plain
    # functions in a thread pool).
    @app.get("/api/status")
    async def status() -> dict:
        """The rotator's snapshot, plus ``tracking`` (null when nothing is tracked)."""
        return hub.status_dict()

    @app.post("/api/goto", dependencies=[Depends(control_allowed)])
    async def goto(req: GotoRequest) -> Accepted:
        return Accepted(route=rotator.goto(req.az_deg, req.el_deg))

    @app.post("/api/park", dependencies=[Depends(control_allowed)])
    async def park() -> Accepted:
        return Accepted(route=rotator.park())

    @app.post("/api/stop", dependencies=[Depends(control_allowed)])
    async def stop(req: StopRequest | None = None) -> Accepted:
        """Stop. Without an axis: everything — jogs, a calibration, tracking, both axes."""
        axis = req.axis if req else None
        hub.release(axis)
        if axis is None:
            if hub.procedure is not None:
                hub.procedure.cancel()
            trk_stop = getattr(tracker, "stop", None)
            if trk_stop is not None:
                out = trk_stop()
                if asyncio.iscoroutine(out):
                    await out
                await hub.refresh_tracking()
        rotator.stop(axis)
        return Accepted()

    @app.post("/api/move", dependencies=[Depends(control_allowed)])
    async def move(req: MoveRequest) -> Accepted:
        rotator.move(req.axis, req.direction, req.speed)
        return Accepted()

    @app.post("/api/set-position", dependencies=[Depends(control_allowed)])
    async def set_position(req: PositionRequest) -> Accepted:
        rotator.set_position(req.az_deg, req.el_deg)
        return Accepted()

    @app.post("/api/clear-faults", dependencies=[Depends(control_allowed)])
    async def clear_faults() -> Accepted:
        rotator.clear_faults()
        return Accepted()

    install(app, ctx)
    return app
