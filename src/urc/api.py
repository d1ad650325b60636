"""The HTTP control API (FastAPI): what ``urc status/goto/stop/park`` and the web page use.

On loopback reading is open; listening beyond it, reading needs the control token or
the read-only one and control needs the control token (``Authorization: Bearer
<token>``; :mod:`urc.web.security`). The commands are urc.dispatch's (shared with
MQTT): their bodies are checked there (HTTP 422 naming the field), then the rotator
service validates them; a refusal is HTTP 409 with the reason. The web dashboard
(``urc.web``) is served from ``/`` by the same app, with its live feed on ``/api/ws``.
"""

from __future__ import annotations

import asyncio
import os
from pathlib import Path
from typing import Any, Callable

from fastapi import APIRouter, Depends, FastAPI
from fastapi.responses import JSONResponse
from fastapi_offline import FastAPIOffline
from pydantic import BaseModel

from . import __version__
from .config import Config
from .dispatch import Dispatcher
from .dispatch.bodies import GotoRequest, MoveRequest, PositionRequest, StopRequest
from .errors import CalibrationError, CommandRejected, UrcError
from .model.messages import HardwareInfo
from .model.settings import RotatorSettings
from .rotator.rotator import Rotator
from .servers import loop_lag
from .model.effects import ask
from .web import WebContext, install
from .web import warm_routes
from .web.docs_pages import install_redoc
from .web.live import FRAME_HZ, Hub
from .web.schemas import CONTROL_RESPONSES, Ok, StatusDoc, documented
from .web.security import HostGate, RequestGate, SecurityHeaders, control_guard
from .web.settings_store import SettingsStore


class Accepted(BaseModel):
    ok: bool = True
    route: list[tuple[float, float]] = []
    #: a stop the control process has not confirmed yet (it is held up): sent, and
    #: applied as soon as it resumes; ``note`` says so
    queued: bool = False
    note: str = ""


def create_api(rotator: Rotator, cfg: Config, *,
               settings_of: Callable[[Config, Path | None], RotatorSettings],
               config_path: str | os.PathLike | None = None,
               state_dir: str | os.PathLike | None = None, tracker: Any = None,
               frame_hz: float = FRAME_HZ) -> FastAPI:
    """The app ``urc run`` serves.

    ``settings_of``: a configuration's rotator settings (``urc.assembly.settings_from_config``,
    from the composition root), for saved settings applied while it runs.
    ``config_path``: the file ``urc run`` was started with (the settings page saves
    there; without one it saves to ``<state_dir>/urc.toml``). ``tracker``: the tracking
    service (see ``urc.web.routes_tracking``); None = no tracking endpoints.
    """
    # FastAPIOffline: /docs and /redoc from assets shipped in the package, not from a CDN
    # (a station's network may have no internet)
    app = FastAPIOffline(title="urc control API", version=__version__, redoc_url=None,
                         description="Universal Rotator Controller: status, control, calibration, settings; "
                                     "the dashboard is at /")
    install_redoc(app)  # its bundle without the one address it fetches from a CDN
    if state_dir is None:
        kept_in = ask(rotator, HardwareInfo()).state_dir  # (no round trip: sent once at start)
        state_dir = Path(kept_in) if kept_in else None
    hub = Hub(rotator, tracker, frame_hz)
    control_allowed = control_guard(cfg)
    commands = Dispatcher(rotator, tracker, hub)
    ctx = WebContext(rotator=rotator, cfg=cfg, hub=hub, settings=SettingsStore(cfg, config_path, state_dir),
                     control=control_allowed, settings_of=settings_of, dispatch=commands, tracker=tracker)
    app.state.web = ctx
    app.add_middleware(RequestGate, cfg=cfg)   # inner: auth and body bounds before any parsing
    app.add_middleware(HostGate, cfg=cfg)      # every request, reads too: DNS rebinding
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

    # Handlers are coroutines on the event loop; a command awaits the control process
    # (urc.dispatch, over urc.model.effects.call): it suspends this request, never the loop.
    ctl = APIRouter(dependencies=[Depends(control_allowed)], responses=CONTROL_RESPONSES)

    @app.get("/api/status", **documented(StatusDoc))
    async def status() -> dict:
        """The rotator's snapshot, plus ``tracking`` (null when nothing is tracked)."""
        await hub.fresh_tracking()  # (computed in a worker thread, never on the loop)
        return {**hub.status_dict(), "loop_lag": loop_lag.summary()}

    @ctl.post("/api/goto")
    async def goto(req: GotoRequest) -> Accepted:
        return Accepted(route=await commands.goto(req))

    @ctl.post("/api/park")
    async def park() -> Accepted:
        return Accepted(route=await commands.park())

    @ctl.post("/api/stop")
    async def stop(req: StopRequest | None = None) -> Accepted:
        """Stop. Without an axis: everything — jogs, a calibration, tracking, both axes."""
        stopped = await commands.stop(req)
        return Accepted(queued=stopped.queued, note=stopped.note)

    @ctl.post("/api/move")
    async def move(req: MoveRequest) -> Ok:
        await commands.move(req)
        return Ok()

    @ctl.post("/api/set-position")
    async def set_position(req: PositionRequest) -> Ok:
        await commands.set_position(req)
        return Ok()

    @ctl.post("/api/clear-faults")
    async def clear_faults() -> Ok:
        await commands.clear_faults()
        return Ok()

    app.include_router(ctl)
    install(app, ctx)
    try:  # inside ``urc run``: the routes analysed now, off the loop (tests: as requested)
        asyncio.get_running_loop()
        warm_routes.start(app)
    except RuntimeError:
        pass
    return app
