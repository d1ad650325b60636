"""Calibration scans (issue 38): POST /api/calibration/scan starts a cross scan around the
Sun, the Moon or a beacon as the hub's procedure (its progress in
/api/calibration/procedure); GET /api/calibration/scan gives the last scan's result with
every sample (offset, power) to plot; POST /api/calibration/scan/apply saves the offsets
it found as the new [offsets], through the settings' own save."""

from __future__ import annotations

import asyncio
import time
from typing import Any, Literal

from fastapi import APIRouter, Depends
from fastapi.responses import JSONResponse

from ..dispatch.bodies import AzDeg, ElDeg, Strict
from ..errors import CommandRejected
from .context import WebContext
from .schemas import CONTROL_RESPONSES


class ScanRequest(Strict):
    target: Literal["sun", "moon", "beacon"]
    az_deg: AzDeg | None = None
    el_deg: ElDeg | None = None


def _build(ctx: WebContext, req: ScanRequest) -> Any:
    """The procedure (on a worker thread: the Sun's first position reads the ephemeris)."""
    from ..peaking import procedure as pp

    cfg = ctx.settings.cfg  # (the settings as last saved: [pointing] applies without a restart)
    try:
        sky = pp.make_sky(req.target, cfg.station, req.az_deg, req.el_deg)
        source = pp.make_source(cfg.pointing, cfg.hardware.sim.pointing_error, sky, seed=cfg.hardware.sim.seed,
                                az_zero_deg=cfg.rotator.zero_offset_deg)
        proc = pp.ScanCalibration(ctx.rotator, sky, source, fwhm_deg=cfg.pointing.beamwidth_deg,
                                  dwell_s=cfg.pointing.dwell_s, samples_per_point=cfg.pointing.samples_per_point,
                                  target=req.target, record=_recorder(ctx))
        sky.position(time.time())
    except pp.ScanSetupError as exc:
        raise CommandRejected(str(exc), "calibration") from None
    return proc


def _recorder(ctx: WebContext) -> Any:
    """Each finished scan kept in the state directory: what a pointing model is fitted to."""
    from functools import partial

    from ..pointing.store import append_scan
    return None if ctx.settings.state_dir is None else partial(append_scan, ctx.settings.state_dir)


def router(ctx: WebContext) -> APIRouter:
    r = APIRouter(prefix="/api/calibration")
    ctl = APIRouter(dependencies=[Depends(ctx.control)], responses=CONTROL_RESPONSES)
    last: dict[str, Any] = {}

    def scan_proc() -> Any:
        proc = ctx.hub.procedure
        return proc if getattr(proc, "kind", None) == "scan" else last.get("proc")

    @ctl.post("/scan")
    async def start(req: ScanRequest) -> dict:
        """Start a cross scan around the target; its progress is the hub's procedure."""
        proc = await asyncio.to_thread(_build, ctx, req)
        ctx.hub.start_procedure(proc)
        last["proc"] = proc
        return {"ok": True, "procedure": ctx.hub.procedure_dict()}

    @r.get("/scan")
    async def result() -> dict:
        """The last scan: state, the offset found (or why refused) and its samples."""
        proc = scan_proc()
        if proc is None:
            return {"ok": True, "scan": None}
        return {"ok": True, "scan": proc.report()}

    @ctl.post("/scan/apply")
    async def apply() -> JSONResponse:
        """Save the offsets the last scan found as [offsets] (and apply them now)."""
        proc = scan_proc()
        if proc is None or proc.state != "done":
            raise CommandRejected("no finished scan with an offset to apply", "calibration")
        if proc.result.get("applied"):
            raise CommandRejected("this scan's offsets are applied already: scan again", "calibration")
        from .routes_settings import _apply_live

        store = ctx.settings
        doc = store.cfg.to_dict()
        doc["offsets"] = dict(doc.get("offsets", {}), **proc.result["offsets_suggested"])
        cfg, errors = store.validate(doc)
        if errors or cfg is None:
            return JSONResponse({"ok": False, "errors": errors}, status_code=422)
        try:
            path = store.save(cfg)
        except OSError as exc:
            return JSONResponse({"ok": False, "errors": [{"key": "", "message": f"could not save: {exc}"}]},
                                status_code=500)
        applied, note = await _apply_live(ctx, cfg)
        proc.result["applied"] = True
        return JSONResponse({"ok": True, "saved_to": str(path), "offsets": proc.result["offsets_suggested"],
                             "applied_live": applied, "messages": [f"saved to {path}", f"offsets: {note}"]})

    from .routes_pointing_model import routes as model_routes
    model_routes(ctx, r, ctl)  # /pointing-model: show, fit, clear
    r.include_router(ctl)
    return r
