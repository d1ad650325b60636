"""``/redoc`` without the internet.

fastapi-offline ships ReDoc's bundle, but the bundle's side menu still loads Redocly's
logo from ``cdn.redoc.ly`` (a station's network may have no internet, and a page of
this API should tell no one that it was opened). The bundle is served here with that one
address replaced by an empty ``data:`` image (ReDoc drops an image that fails to load),
and the docs pages get a Content-Security-Policy that allows nothing from elsewhere.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

from fastapi import FastAPI, Header, Request
from fastapi.openapi.docs import get_redoc_html
from fastapi.responses import HTMLResponse, Response

#: the only outside address the bundle fetches (read from redoc.standalone.js)
REDOC_CDN_LOGO = b"https://cdn.redoc.ly/redoc/logo-mini.svg"
REDOC_JS_URL = "/docs-assets/redoc.standalone.js"
#: Swagger UI and ReDoc need inline scripts and styles, and ReDoc a worker from a blob:
#: still nothing from another origin
DOCS_CSP = ("default-src 'self'; script-src 'self' 'unsafe-inline'; style-src 'self' 'unsafe-inline'; "
            "img-src 'self' data:; worker-src 'self' blob:; connect-src 'self'; font-src 'self' data:; "
            "object-src 'none'; base-uri 'none'; frame-ancestors 'none'")


def _offline_bundle() -> bytes:
    import fastapi_offline

    data = (Path(fastapi_offline.__file__).parent / "static" / "redoc.standalone.js").read_bytes()
    return data.replace(REDOC_CDN_LOGO, b"data:,")


def install_redoc(app: FastAPI, static_url: str = "/static-offline-docs") -> None:
    """``/redoc`` (create the app with ``redoc_url=None``) and its patched bundle."""
    bundle = _offline_bundle()
    etag = '"' + hashlib.sha256(bundle).hexdigest()[:20] + '"'

    @app.get("/redoc", include_in_schema=False)
    async def redoc(request: Request) -> HTMLResponse:
        root = request.scope.get("root_path", "")
        return get_redoc_html(openapi_url=f"{root}{app.openapi_url}", title=f"{app.title} - ReDoc",
                              redoc_js_url=f"{root}{REDOC_JS_URL}", with_google_fonts=False,
                              redoc_favicon_url=f"{root}{static_url}/favicon.png")

    @app.get(REDOC_JS_URL, include_in_schema=False)
    async def redoc_js(if_none_match: str | None = Header(None)) -> Response:
        headers = {"ETag": etag, "Cache-Control": "no-cache"}
        if if_none_match == etag:
            return Response(status_code=304, headers=headers)
        return Response(bundle, media_type="text/javascript; charset=utf-8", headers=headers)
