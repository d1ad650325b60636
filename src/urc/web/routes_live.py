"""Live view: the WebSocket feed, chart history, press-and-hold jogging, page info."""

from __future__ import annotations

import dataclasses
import logging
import os
from typing import Literal

from fastapi import APIRouter, Depends, HTTPException, Query, WebSocket
from pydantic import Field

from ..dispatch.bodies import MoveRequest, StopRequest
from ..model.messages import HardwareInfo
from ..model.effects import ask
from .. import __version__
from ..profiles import PROFILES
from ..protocols.registry import PROTOCOLS
from .context import WebContext
from .live import JOG_LEASE_S
from .schemas import CONTROL_RESPONSES, HistoryDoc, InfoDoc, Ok, documented
from .security import WS_PROTOCOL, check_browser_origin

log = logging.getLogger(__name__)


class JogLease(Ok):
    lease_s: float = Field(description="the jog stops unless renewed within this time")


def router(ctx: WebContext) -> APIRouter:
    r = APIRouter()
    control = [Depends(ctx.control)]

    @r.websocket("/api/ws")
    async def live(ws: WebSocket) -> None:
        """Status frames (JSON) about ten times a second. On an exposed instance it
        needs a token (the read-only one will do; a page offers it as the subprotocol
        ``urc.bearer.<base64url token>`` beside ``urc``); a page of another site (or one
        reached through a rebinding host name) gets no feed, as it gets no control:
        closed before the handshake (HTTP 403)."""
        try:
            check_browser_origin(ctx.cfg, ws)
        except HTTPException as exc:
            log.warning("live feed refused: %s", exc.detail)
            await ws.close(code=1008, reason=str(exc.detail)[:120])
            return
        offered = [p.strip() for p in (ws.headers.get("sec-websocket-protocol") or "").split(",")]
        await ctx.hub.serve(ws, WS_PROTOCOL if WS_PROTOCOL in offered else None)

    @r.get("/api/info", **documented(InfoDoc))
    def info() -> dict:
        rot = ctx.rotator
        caps = rot.caps
        status = rot.status()
        hardware = ask(rot, HardwareInfo())  # (no round trip: sent once at start)

        def axis(name: str) -> dict:
            a = caps.axis(name)
            return {"min_deg": a.min_deg, "max_deg": a.max_deg, "park_deg": a.park_deg,
                    "max_rate_deg_per_s": a.max_rate_deg_per_s, "min_rate_deg_per_s": a.min_rate_deg_per_s,
                    "sensor": a.sensor.kind, "resolution_deg": a.sensor.resolution_deg,
                    "limit_switches": a.limit_switches}
        st = ctx.cfg.station
        station = ({"lat_deg": st.lat_deg, "lon_deg": st.lon_deg, "alt_m": st.alt_m, "name": st.name}
                   if st.lat_deg is not None and st.lon_deg is not None else None)
        return {"version": __version__, "profile": caps.name, "description": caps.description,
                "backend": hardware.backend, "simulator": hardware.simulator,
                "control_requires_token": ctx.cfg.api.control_requires_token,
                "token_configured": bool(ctx.cfg.api.token),
                "can_flip": caps.can_flip, "caps": {n: axis(n) for n in caps.axes},
                # ["az"]: a single-axis rotator (the page shows no elevation controls)
                "axes": list(caps.axes),
                "limits": status.limits, "offsets": status.offsets,
                # what the rotator enforces now (the settings page may have changed it live)
                "keepout": [dataclasses.asdict(z) for z in rot.settings.zones],
                "restart_pending": ctx.settings.restart_pending(),
                "station": station,
                "tracking_min_el_deg": ctx.cfg.tracking.min_el_deg,
                "frame_hz": round(1.0 / ctx.hub.period_s, 3), "jog_lease_s": JOG_LEASE_S,
                "tracking_available": ctx.tracker is not None,
                "profiles": {n: c.description for n, c in PROFILES.items()},
                "protocols": list(PROTOCOLS),
                # urc run: the control loop's own process and the priority it was given
                "control": {"pid": getattr(rot, "pid", os.getpid()),
                            "priority": getattr(rot, "priority", "") or "in this process"}}

    @r.get("/api/history", **documented(HistoryDoc))
    def history(which: Literal["recent", "current", "last"] = "recent",
                seconds: float | None = Query(None, gt=0, le=86_400),
                since: float | None = Query(None, description="only samples after this wall time (s)"),
                max_points: int = Query(3000, ge=10, le=50_000)) -> dict:
        """Position, setpoint and pointing error over time, as arrays (for the charts)."""
        ctx.hub.ensure_started()
        return ctx.hub.history.select(which, seconds=seconds, since_wall_s=since, max_points=max_points)

    @r.post("/api/jog", dependencies=control, responses=CONTROL_RESPONSES)
    async def jog(req: MoveRequest) -> JogLease:
        """Start or renew a press-and-hold jog. It stops by itself unless renewed within
        ``jog_lease_s`` (the page renews while the button is held)."""
        await ctx.hub.jog(req.axis, req.direction, req.speed)
        return JogLease(lease_s=JOG_LEASE_S)

    @r.post("/api/jog/release", dependencies=control, responses=CONTROL_RESPONSES)
    async def jog_release(req: StopRequest | None = None) -> Ok:
        await ctx.hub.release(req.axis if req else None)
        return Ok()

    return r
