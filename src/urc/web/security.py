"""Who may control, and the headers every response carries.

Viewing is open; control needs ``Authorization: Bearer <token>`` whenever the API listens
beyond loopback (``api.control_requires_token``), and is refused to pages of other sites. The Content-Security-Policy allows only
this origin's own scripts and styles (no inline script, no eval, nothing from elsewhere),
so even a bug that put user text into markup could not run it.
"""

from __future__ import annotations

import hmac
import ipaddress
from typing import Any, Callable
from urllib.parse import urlsplit

from fastapi import Header, HTTPException, Request

from ..config import Config

CSP = ("default-src 'self'; script-src 'self'; style-src 'self'; img-src 'self' data:; "
       "connect-src 'self'; font-src 'self'; object-src 'none'; base-uri 'none'; "
       "frame-ancestors 'none'; form-action 'self'")
#: FastAPI's own API pages load Swagger/ReDoc with inline scripts: no CSP there
NO_CSP_PATHS = ("/docs", "/redoc", "/docs/oauth2-redirect")
HEADERS = [(b"content-security-policy", CSP.encode()), (b"x-content-type-options", b"nosniff"),
           (b"referrer-policy", b"no-referrer"), (b"x-frame-options", b"DENY")]


def _loopback_name(host: str) -> bool:
    name = host.lower()
    if name.startswith("["):
        name = name[1:].split("]")[0]
    elif name.count(":") == 1:
        name = name.split(":")[0]
    if name == "localhost" or name.endswith(".localhost"):
        return True
    try:
        return ipaddress.ip_address(name).is_loopback
    except ValueError:
        return False


def check_browser_origin(cfg: Config, request: Request) -> None:
    """Refuse control sent by a page of another site (CSRF: a loopback API needs no
    token, so any web page could otherwise POST to it) or by a page reached under a
    foreign name that resolves to this machine (DNS rebinding). Browsers always send
    ``Origin`` with a POST; clients without one (the CLI, scripts) are not browsers."""
    origin = request.headers.get("origin")
    if origin is None:
        return
    host = request.headers.get("host", "")
    if urlsplit(origin).netloc.lower() != host.lower():
        raise HTTPException(403, f"control from another site ({origin}) refused")
    if cfg.api.is_loopback and not _loopback_name(host):
        raise HTTPException(403, f"control through the name {host!r} refused: this API listens on loopback only")


def control_guard(cfg: Config) -> Callable[..., None]:
    """A FastAPI dependency: the browser-origin check, then the token when one is required."""

    def control_allowed(request: Request, authorization: str | None = Header(None)) -> None:
        check_browser_origin(cfg, request)
        if not cfg.api.control_requires_token:
            return
        supplied = (authorization or "").removeprefix("Bearer ").strip()
        if not cfg.api.token or not hmac.compare_digest(supplied.encode(), cfg.api.token.encode()):
            raise HTTPException(401, "control needs the API token (Authorization: Bearer <token>)")
    return control_allowed


class SecurityHeaders:
    """Pure ASGI middleware (works for WebSocket scopes too, which it leaves alone)."""

    def __init__(self, app: Any, on_request: Callable[[], None] | None = None):
        self.app = app
        self.on_request = on_request

    async def __call__(self, scope: dict, receive: Any, send: Any) -> None:
        if self.on_request is not None and scope["type"] in ("http", "websocket"):
            self.on_request()
        if scope["type"] != "http" or scope.get("path") in NO_CSP_PATHS:
            await self.app(scope, receive, send)
            return

        async def send_with_headers(message: dict) -> None:
            if message["type"] == "http.response.start":
                names = {k.lower() for k, _ in message.get("headers", [])}
                message.setdefault("headers", [])
                message["headers"] = list(message["headers"]) + [h for h in HEADERS if h[0] not in names]
            await send(message)
        await self.app(scope, receive, send_with_headers)
