"""The pointing model (issue 38 part 4), under /api/calibration/pointing-model: GET shows
the stored model and the one in force; POST .../fit fits one to the stored scans (or to
the scans given) and applies it; DELETE clears it. The model lives in the state
directory (urc.pointing.store) and reaches the control process as the settings'
``pointing_deg``, through the same live reconfigure a settings save uses."""

from __future__ import annotations

import asyncio
from typing import Any

from fastapi import APIRouter
from pydantic import Field

from ..dispatch.bodies import Strict
from ..errors import CommandRejected
from ..pointing import store
from .context import WebContext


class FitRequest(Strict):
    #: the terms to fit (IA IE CA NPAE AN AW TF; the others held at 0); all by default
    terms: list[str] | None = Field(default=None, min_length=1, max_length=7)
    #: the scans to fit (store's form); the stored scans by default
    scans: list[dict[str, Any]] | None = Field(default=None, max_length=10000)


def _state_dir(ctx: WebContext) -> Any:
    if ctx.settings.state_dir is None:
        raise CommandRejected("urc runs without a state directory: no pointing model can be kept", "calibration")
    return ctx.settings.state_dir


def _offsets_now(ctx: WebContext) -> dict[str, float]:
    """The offsets the reports are made with now (the scans' frame: their ``offsets``)."""
    off = ctx.rotator.status().offsets
    return {"az_deg": float(off.get("az", 0.0)), "el_deg": float(off.get("el", 0.0))}


def _summary(doc: dict[str, Any] | None) -> dict[str, Any] | None:
    if doc is None:
        return None
    return {k: v for k, v in doc.items() if k != "scans"} | {"scans": len(doc["scans"])}


def _fit(ctx: WebContext, req: FitRequest) -> dict[str, Any]:
    from ..pointing.model_fit import fit_records  # (numpy: only when a fit is asked for)

    state_dir = _state_dir(ctx)
    if req.scans is not None:
        records = [store.check_scan(r, f"scan {i + 1}") for i, r in enumerate(req.scans)]
        source = f"{len(records)} scans given"
    else:
        path = store.scans_path(state_dir)
        records = store.read_scans(path) if path.exists() else []
        source = f"{len(records)} stored scans ({path.name})"
    doc = fit_records(records, _offsets_now(ctx), req.terms or store.POINTING_TERMS, source=source)
    store.save_model(state_dir, doc)
    return doc


def routes(ctx: WebContext, r: APIRouter, ctl: APIRouter) -> None:
    """Add the model's routes: reads on ``r``, changes on ``ctl`` (control access)."""

    async def apply_live() -> tuple[bool, str]:
        from .routes_settings import _apply_live  # (reads the stored model again)

        return await _apply_live(ctx, ctx.settings.cfg)

    @r.get("/pointing-model")
    async def show() -> dict:
        """The stored model (its scans counted), the terms in force, the scans stored."""
        state_dir, problem, doc = ctx.settings.state_dir, "", None
        if state_dir is not None:
            try:
                doc = store.load_model(state_dir)
            except store.PointingStoreError as exc:
                problem = str(exc)
        path = store.scans_path(state_dir) if state_dir is not None else None
        stored = sum(1 for ln in path.read_text().splitlines() if ln.strip()) if path and path.exists() else 0
        geometry = getattr(ctx.rotator, "geometry", None)
        return {"ok": True, "model": _summary(doc), "problem": problem,
                "in_force": list(getattr(geometry, "pointing_deg", ()) or ()), "terms_order": list(store.POINTING_TERMS),
                "scans_stored": stored}

    @ctl.post("/pointing-model/fit")
    async def fit(req: FitRequest) -> dict:
        """Fit the model to the stored scans (or those given), save it and apply it."""
        doc = await asyncio.to_thread(_fit, ctx, req)
        applied, note = await apply_live()
        return {"ok": True, "model": _summary(doc), "applied_live": applied,
                "messages": [f"saved to {store.model_path(_state_dir(ctx))}", f"pointing model: {note}"]}

    @ctl.delete("/pointing-model")
    async def clear() -> dict:
        """Remove the stored model (the scans stay) and point without it."""
        cleared = store.clear_model(_state_dir(ctx))
        applied, note = await apply_live()
        return {"ok": True, "cleared": cleared, "applied_live": applied,
                "messages": [("pointing model removed" if cleared else "no pointing model was stored") +
                             f"; {note}"]}
