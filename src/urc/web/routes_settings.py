"""Settings: read, validate, save (to the file ``urc run`` was started with) and apply."""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter, Body, Depends, Header, Response
from fastapi.responses import JSONResponse
from pydantic import BaseModel, Field

from ..model.messages import Reconfigure
from ..model.effects import call
from .context import WebContext
from .schemas import CONTROL_RESPONSES
from .settings_store import RESTART_SECTIONS


async def _apply_live(ctx: WebContext, cfg: Any) -> tuple[bool, str]:
    """Hand the new limits, zones, offsets, speeds and park to the rotator, if it can."""
    if getattr(ctx.rotator, "reconfigure", None) is None:
        return False, "this urc cannot change limits/zones/offsets while running: they apply at the next start"
    try:
        # (the stored pointing model kept)
        await call(ctx.rotator, Reconfigure(ctx.settings_of(cfg, ctx.settings.state_dir)))
    except Exception as exc:  # refused (e.g. the antenna sits in a new keep-out zone)
        return False, f"saved, but not applied now: {exc}"
    return True, "applied now"


class SettingError(BaseModel):
    key: str = Field(description="the dotted key of the field, e.g. limits.az.max_deg")
    message: str


class SettingsInvalid(BaseModel):
    ok: bool = False
    errors: list[SettingError]


class Checked(BaseModel):
    ok: bool = True
    errors: list[SettingError] = []
    changed: list[str]


class SaveResult(BaseModel):
    ok: bool = True
    saved_to: str
    changed: list[str]
    restart_needed: list[str] = Field(description="changed sections that take effect at the next start")
    applied_live: bool
    started_without_file: bool
    messages: list[str]
    revision: str = Field(description="the saved document's revision (also its ETag)")


def router(ctx: WebContext) -> APIRouter:
    r = APIRouter()
    store = ctx.settings

    @r.get("/api/settings")
    def get_settings(response: Response) -> dict:
        """The configuration document (without the API token) and where it is saved. Its
        ``ETag`` (also ``revision``) goes back in a save's ``If-Match``."""
        doc = store.document()
        response.headers["ETag"] = doc["revision"]
        return doc

    @r.post("/api/settings/validate", response_model=Checked,
            responses={422: {"model": SettingsInvalid, "description": "each error names its key"},
                       413: CONTROL_RESPONSES[413]})
    def validate(data: Any = Body(...)) -> JSONResponse:
        """Check a configuration document with the same rules as the file; nothing changes."""
        cfg, errors = store.validate(data)
        if errors:
            return JSONResponse({"ok": False, "errors": errors}, status_code=422)
        return JSONResponse({"ok": True, "errors": [], "changed": store.changed_sections(cfg)})

    @r.post("/api/settings", dependencies=[Depends(ctx.control)], response_model=SaveResult,
            responses=CONTROL_RESPONSES | {422: {"model": SettingsInvalid, "description": "each error names its key"},
                                           412: {"model": SettingsInvalid,
                                                 "description": "If-Match is not the current revision: nothing saved"},
                                           500: {"model": SettingsInvalid, "description": "could not save"}})
    async def save(data: Any = Body(...), if_match: str | None = Header(None)) -> JSONResponse:
        """Validate, save (the changed keys only, in place) and apply what can be applied live.

        Send the revision read with the document (its ``ETag``) in ``If-Match``: a save
        made meanwhile (another tab, ``urc settings set``) changed the revision, and this
        one is then refused with 412 and nothing changes. A save without If-Match is
        still taken (scripts written before revisions); ``If-Match: *`` says "whatever
        is there" explicitly."""
        if store.if_match(if_match) is False:
            return JSONResponse({"ok": False, "revision": store.revision, "errors": [
                {"key": "", "message": "the settings were saved by someone else since these were loaded: "
                                       "load them again (your changes can be made on top) and save"}]},
                status_code=412, headers={"ETag": store.revision})
        cfg, errors = store.validate(data)
        if errors:
            return JSONResponse({"ok": False, "errors": errors}, status_code=422)
        changed = store.changed_sections(cfg)
        started_without_file = store.config_path is None
        try:
            path = store.save(cfg)
        except OSError as exc:
            return JSONResponse({"ok": False, "errors": [{"key": "", "message": f"could not save: {exc}"}]},
                                status_code=500)
        # what waits for a restart: compared with what urc run started with, not with the
        # last save (a port changed in one save still waits after the next)
        restart = store.restart_pending()
        live = [k for k in changed if k not in RESTART_SECTIONS]
        applied, note = (await _apply_live(ctx, cfg) if live else (True, "nothing to apply"))
        msgs = [f"saved to {path}"] + ([store.note] if store.note else [])
        if started_without_file:
            msgs.append(f"urc run was started without a configuration file; start it with --config {path} "
                        "to use these settings")
        if live:
            msgs.append(f"{', '.join(live)}: {note}")
        if restart:
            msgs.append(f"{', '.join(restart)}: restart urc run for these to take effect")
        return JSONResponse({"ok": True, "saved_to": str(path), "changed": changed, "restart_needed": restart,
                             "applied_live": applied and bool(live), "started_without_file": started_without_file,
                             "messages": msgs, "revision": store.revision},
                            headers={"ETag": store.revision})

    return r
