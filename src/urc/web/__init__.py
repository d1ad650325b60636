"""The web dashboard: static page (``static/``), live WebSocket feed, settings and
calibration APIs. :func:`install` adds it all to the control API's FastAPI app."""

from __future__ import annotations

import hashlib
from importlib import resources
from pathlib import Path

from fastapi import FastAPI, Header
from fastapi.responses import Response

from .context import WebContext

STATIC_DIR = Path(str(resources.files(__package__).joinpath("static")))


class PageFiles:
    """The page's files, read once into memory: served without a thread or a disk access
    (a dozen small files; the first paint waits on them), revalidated by ETag."""

    TYPES = {".html": "text/html; charset=utf-8", ".css": "text/css; charset=utf-8",
             ".js": "text/javascript; charset=utf-8", ".geojson": "application/geo+json"}

    def __init__(self, root: Path):
        self.files: dict[str, tuple[bytes, str, str]] = {}
        for path in sorted(root.rglob("*")):
            if path.is_file() and path.suffix in self.TYPES:
                data = path.read_bytes()
                etag = '"' + hashlib.sha256(data).hexdigest()[:20] + '"'
                self.files[path.relative_to(root).as_posix()] = (data, self.TYPES[path.suffix], etag)

    def response(self, name: str, if_none_match: str | None) -> Response:
        entry = self.files.get(name)
        if entry is None:
            return Response("not found", status_code=404, media_type="text/plain")
        data, media_type, etag = entry
        headers = {"ETag": etag, "Cache-Control": "no-cache"}  # revalidate after an upgrade
        if if_none_match == etag:
            return Response(status_code=304, headers=headers)
        return Response(data, media_type=media_type, headers=headers)


def install(app: FastAPI, ctx: WebContext) -> None:
    from . import routes_calibration, routes_live, routes_pointing, routes_settings, routes_sim, routes_tracking

    app.include_router(routes_live.router(ctx))
    app.include_router(routes_settings.router(ctx))
    app.include_router(routes_calibration.router(ctx))
    app.include_router(routes_pointing.router(ctx))
    app.include_router(routes_sim.router(ctx))
    if ctx.tracker is not None:
        app.include_router(routes_tracking.router(ctx))

    static = PageFiles(STATIC_DIR)

    @app.get("/", include_in_schema=False)
    async def index(if_none_match: str | None = Header(None)) -> Response:
        return static.response("index.html", if_none_match)

    @app.get("/static/{name:path}", include_in_schema=False)
    async def static_file(name: str, if_none_match: str | None = Header(None)) -> Response:
        return static.response(name, if_none_match)


__all__ = ["STATIC_DIR", "WebContext", "install"]
