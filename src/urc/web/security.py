"""Who may read and control, and the headers every response carries.

On loopback reading is open. An API that listens beyond loopback (an exposed instance)
serves its page's files to anyone, but every read of ``/api/`` (status, settings with the
station's coordinates and the whole configuration, the live feed) needs a token: the
control token (``api.token``) or the read-only one (``api.read_token``, for a wall
display), as ``Authorization: Bearer <token>``, or for the live feed (a browser's
WebSocket sends no such header) as the subprotocol ``urc.bearer.<base64url token>``
beside ``urc``. Control needs ``api.token`` whenever the API listens beyond loopback
(``api.control_requires_token``), and is refused to pages of other sites.
An API that listens on loopback answers nothing (page, reads, live feed or control) asked
for under a host name that is not a loopback one: a page of another site whose name was
re-pointed at 127.0.0.1 (DNS rebinding) would otherwise read the station's position and
settings. The Content-Security-Policy allows only this origin's own scripts and styles
(no inline script, no eval, nothing from elsewhere), so even a bug that put user text into
markup could not run it.
"""

from __future__ import annotations

import base64
import binascii
import hmac
import ipaddress
import json
import logging
import math
from typing import Any, Callable
from urllib.parse import urlsplit

from fastapi import Depends, HTTPException
from fastapi.security import HTTPAuthorizationCredentials, HTTPBearer
from starlette.datastructures import Headers
from starlette.requests import HTTPConnection

from ..config import Config
from ..protocols.base import RateLimitedLog
from .docs_pages import DOCS_CSP

log = logging.getLogger(__name__)
#: refusals by host name: a page retrying in a loop must not flood the log
refusal_log = RateLimitedLog(log)

#: the largest request body accepted (the settings document is a few KiB): bigger is 413
#: before any of it is parsed, so no POST can hold the event loop in a JSON parser
MAX_BODY_BYTES = 64 * 1024
#: the only POST that needs no control right (it checks a settings document, changes nothing)
OPEN_POSTS = frozenset({"/api/settings/validate"})
#: documents the control token in the OpenAPI description; the check itself is check_control
BEARER = HTTPBearer(auto_error=False, scheme_name="token",
                    description="the API token (`api.token`), needed for control when the API "
                                "listens beyond loopback")

CSP = ("default-src 'self'; script-src 'self'; style-src 'self'; img-src 'self' data:; "
       "connect-src 'self'; font-src 'self'; object-src 'none'; base-uri 'none'; "
       "frame-ancestors 'none'; form-action 'self'")
#: FastAPI's own API pages load Swagger/ReDoc with inline scripts: a policy of their own
DOCS_PATHS = ("/docs", "/redoc", "/docs/oauth2-redirect")
OTHER_HEADERS = [(b"x-content-type-options", b"nosniff"), (b"referrer-policy", b"no-referrer"),
                 (b"x-frame-options", b"DENY")]
HEADERS = [(b"content-security-policy", CSP.encode()), *OTHER_HEADERS]
DOCS_HEADERS = [(b"content-security-policy", DOCS_CSP.encode()), *OTHER_HEADERS]


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


def check_host(cfg: Config, headers: Headers) -> None:
    """Refuse any request to a loopback API made under a name that is not a loopback
    one: only a page whose name was re-pointed at this machine (DNS rebinding) or a
    proxy passing a public name on asks that way. (No Host at all: HTTP/1.0 tools.)"""
    host = headers.get("host")
    if cfg.api.is_loopback and host is not None and not _loopback_name(host):
        raise HTTPException(403, f"requests through the name {host!r} refused: this API listens on "
                                 "loopback only (use localhost or 127.0.0.1)")


def check_browser_origin(cfg: Config, request: HTTPConnection | Headers) -> None:
    """Refuse control sent by a page of another site (CSRF: a loopback API needs no
    token, so any web page could otherwise POST to it) or by a page reached under a
    foreign name that resolves to this machine (DNS rebinding). Browsers always send
    ``Origin`` with a POST; clients without one (the CLI, scripts) are not browsers."""
    headers = request if isinstance(request, Headers) else request.headers
    check_host(cfg, headers)
    origin = headers.get("origin")
    if origin is None:
        return
    host = headers.get("host", "")
    if urlsplit(origin).netloc.lower() != host.lower():
        raise HTTPException(403, f"control from another site ({origin}) refused")


def bearer_token(authorization: str | None) -> str | None:
    """The credentials of ``Authorization: Bearer <token>``; the scheme's name is
    case-insensitive (RFC 7235 section 2.1). None without that scheme: a bare token is
    not a bearer token."""
    scheme, _, credentials = (authorization or "").strip().partition(" ")
    if scheme.lower() != "bearer" or not credentials.strip():
        return None
    return credentials.strip()


def check_token(cfg: Config, authorization: str | None) -> None:
    if not cfg.api.control_requires_token:
        return
    supplied = bearer_token(authorization)
    if supplied is None or not cfg.api.token or \
            not hmac.compare_digest(supplied.encode(), cfg.api.token.encode()):
        raise HTTPException(401, "control needs the API token (Authorization: Bearer <token>)")


#: the live feed's subprotocol (the page offers it with its token's, below)
WS_PROTOCOL = "urc"
WS_TOKEN_PREFIX = "urc.bearer."


def ws_token(headers: Headers) -> str | None:
    """The token a WebSocket handshake offers as the subprotocol ``urc.bearer.<base64url>``."""
    for offered in (headers.get("sec-websocket-protocol") or "").split(","):
        offered = offered.strip()
        if offered.startswith(WS_TOKEN_PREFIX):
            code = offered[len(WS_TOKEN_PREFIX):]
            try:
                return base64.urlsafe_b64decode(code + "=" * (-len(code) % 4)).decode()
            except (binascii.Error, ValueError):
                return None
    return None


def _same(supplied: str, expected: str) -> bool:
    return bool(expected) and hmac.compare_digest(supplied.encode(), expected.encode())


def check_read(cfg: Config, headers: Headers, websocket: bool = False) -> None:
    """An exposed instance's reads need the control token or the read-only one."""
    if not cfg.api.reads_require_token:
        return
    supplied = bearer_token(headers.get("authorization"))
    if supplied is None and websocket:
        supplied = ws_token(headers)
    if supplied is None or not (_same(supplied, cfg.api.token) or _same(supplied, cfg.api.read_token)):
        raise HTTPException(401, "reading needs a token: this API listens beyond loopback "
                                 "(Authorization: Bearer <api.token or api.read_token>)")


def check_control(cfg: Config, headers: Headers) -> None:
    """The browser-origin check, then the token when one is required."""
    check_browser_origin(cfg, headers)
    check_token(cfg, headers.get("authorization"))


def control_guard(cfg: Config) -> Callable[..., None]:
    """A FastAPI dependency for the control routes. :class:`RequestGate` has checked the
    same before the body was read; this repeats it per route (a route mounted elsewhere
    stays guarded) and puts the bearer scheme into the OpenAPI description."""

    def control_allowed(conn: HTTPConnection,
                        _bearer: HTTPAuthorizationCredentials | None = Depends(BEARER)) -> None:
        check_control(cfg, conn.headers)
    return control_allowed


async def _send_json(send: Any, status: int, body: dict) -> None:
    data = json.dumps(body).encode()
    await send({"type": "http.response.start", "status": status,
                "headers": [(b"content-type", b"application/json"), (b"content-length", str(len(data)).encode())]})
    await send({"type": "http.response.body", "body": data})


#: the deepest body accepted: a settings document nests 4 deep; Python's parser and the
#: code after it recurse, so a body of 30 000 brackets must be refused before them (400)
MAX_BODY_DEPTH = 32


class BodyProblem(ValueError):
    def __init__(self, status: int, loc: list[str | int], kind: str, msg: str):
        super().__init__(msg)
        self.status, self.loc, self.kind = status, loc, kind


def check_body(doc: Any) -> None:
    """BodyProblem for a body nested deeper than MAX_BODY_DEPTH (400) or holding a number
    that is not finite (422 naming its field): ``1e999`` parses to inf, and a validation
    error echoing it could not be written as JSON (a 500)."""
    stack: list[tuple[Any, list[str | int]]] = [(doc, ["body"])]
    while stack:
        value, loc = stack.pop()
        if len(loc) > MAX_BODY_DEPTH:
            raise BodyProblem(400, ["body"], "too_deep", f"nested deeper than {MAX_BODY_DEPTH} levels")
        if isinstance(value, dict):
            stack.extend((v, [*loc, k]) for k, v in value.items())
        elif isinstance(value, list):
            stack.extend((v, [*loc, i]) for i, v in enumerate(value))
        elif isinstance(value, float) and not math.isfinite(value):
            raise BodyProblem(422, loc, "finite_number",
                              f"{value} is not a finite number (angles and values must be finite)")


class HostGate:
    """Pure ASGI middleware in front of everything (page, reads, live feed, control):
    :func:`check_host`, and an exposed instance's reads :func:`check_read`. A refused
    WebSocket is closed before its handshake (HTTP 403)."""

    def __init__(self, app: Any, cfg: Config):
        self.app = app
        self.cfg = cfg

    async def __call__(self, scope: dict, receive: Any, send: Any) -> None:
        if scope["type"] in ("http", "websocket"):
            try:
                headers = Headers(scope=scope)
                check_host(self.cfg, headers)
                # an exposed instance's reads (what may change is RequestGate's)
                if str(scope.get("path", "")).startswith("/api/") and \
                        (scope["type"] == "websocket" or scope["method"] in RequestGate.SAFE):
                    check_read(self.cfg, headers, websocket=scope["type"] == "websocket")
            except HTTPException as exc:
                refusal_log.warning("refused: %s", exc.detail)
                if scope["type"] == "http":
                    await _send_json(send, exc.status_code, {"detail": exc.detail})
                else:
                    await send({"type": "websocket.close", "code": 1008, "reason": str(exc.detail)[:120]})
                return
        await self.app(scope, receive, send)


class RequestGate:
    """Pure ASGI middleware in front of every request that may change something (any
    method but GET/HEAD/OPTIONS): Origin and token are checked from the headers alone,
    then the body is read with a size bound (413) and must be JSON no deeper than
    MAX_BODY_DEPTH (400) whose numbers are finite (NaN, Infinity, 1e999: 422 naming the
    field) — all before a route parses anything. Without this, FastAPI reads and
    parses a body before the route's dependencies run: a 40 MB POST from a foreign page
    was parsed on the event loop before being refused."""

    SAFE = frozenset({"GET", "HEAD", "OPTIONS"})

    def __init__(self, app: Any, cfg: Config, max_body_bytes: int = MAX_BODY_BYTES):
        self.app = app
        self.cfg = cfg
        self.max_body_bytes = max_body_bytes

    async def __call__(self, scope: dict, receive: Any, send: Any) -> None:
        if scope["type"] != "http" or scope["method"] in self.SAFE:
            await self.app(scope, receive, send)
            return
        headers = Headers(scope=scope)
        try:
            if scope.get("path") in OPEN_POSTS:
                check_browser_origin(self.cfg, headers)
            else:
                check_control(self.cfg, headers)
        except HTTPException as exc:
            await _send_json(send, exc.status_code, {"detail": exc.detail})
            return
        too_big = {"detail": f"request body larger than {self.max_body_bytes} bytes"}
        try:
            declared = int(headers.get("content-length") or 0)
        except ValueError:
            declared = 0
        if declared > self.max_body_bytes:
            await _send_json(send, 413, too_big)
            return
        chunks, size = [], 0
        while True:
            message = await receive()
            if message["type"] == "http.disconnect":
                return
            chunk = message.get("body", b"")
            size += len(chunk)
            if size > self.max_body_bytes:
                await _send_json(send, 413, too_big)
                return
            chunks.append(chunk)
            if not message.get("more_body", False):
                break
        body = b"".join(chunks)
        if body.strip():
            try:
                check_body(json.loads(body))
            except BodyProblem as exc:
                await _send_json(send, exc.status, {"detail": [{"loc": exc.loc, "type": exc.kind, "msg": str(exc)}]})
                return
            except RecursionError:
                await _send_json(send, 400, {"detail": [{"loc": ["body"], "type": "too_deep",
                                                         "msg": f"nested deeper than {MAX_BODY_DEPTH} levels"}]})
                return
            except ValueError as exc:
                await _send_json(send, 422, {"detail": [{"loc": ["body"], "type": "json_invalid",
                                                         "msg": f"not valid JSON: {exc}"}]})
                return
        delivered = False

        async def replay() -> dict:
            nonlocal delivered
            if not delivered:
                delivered = True
                return {"type": "http.request", "body": body, "more_body": False}
            return await receive()
        await self.app(scope, replay, send)


class SecurityHeaders:
    """Pure ASGI middleware (works for WebSocket scopes too, which it leaves alone)."""

    def __init__(self, app: Any, on_request: Callable[[], None] | None = None):
        self.app = app
        self.on_request = on_request

    async def __call__(self, scope: dict, receive: Any, send: Any) -> None:
        if self.on_request is not None and scope["type"] in ("http", "websocket"):
            self.on_request()
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        extra = DOCS_HEADERS if scope.get("path") in DOCS_PATHS else HEADERS

        async def send_with_headers(message: dict) -> None:
            if message["type"] == "http.response.start":
                names = {k.lower() for k, _ in message.get("headers", [])}
                message.setdefault("headers", [])
                message["headers"] = list(message["headers"]) + [h for h in extra if h[0] not in names]
            await send(message)
        await self.app(scope, receive, send_with_headers)
