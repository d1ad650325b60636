"""Build at start, on a thread of its own, what FastAPI builds for each route on the
first request that reaches it (issue 33).

FastAPI (0.16x) analyses a route (its parameters' and answers' pydantic models) the
first time a request is matched against it, on the event loop: the first request for
the page (``/``, routed after every API route) cost ~0.35-0.45 s on a loaded two-core
machine, more on a Raspberry Pi, where the control process stops the axes after 1 s of
the loop's silence. A request for a path no route has, sent through the app's router on
a private event loop here, builds them all (FastAPI guards that work with a lock, and a
request meanwhile waits at most for the route being built). Nothing in the app's state
is touched: the router answers 404 and nothing else runs.
"""

from __future__ import annotations

import asyncio
import logging
import threading
from typing import Any

log = logging.getLogger(__name__)

#: a path no route serves
WARM_UP_PATH = "/urc-warm-up-matches-nothing"


def warm_up_routes(app: Any) -> None:
    """Send one request that matches nothing through ``app.router`` (blocking)."""
    async def one() -> None:
        scope: dict[str, Any] = {
            "type": "http", "asgi": {"version": "3.0"}, "http_version": "1.1", "method": "GET", "scheme": "http",
            "path": WARM_UP_PATH, "raw_path": WARM_UP_PATH.encode(), "query_string": b"", "root_path": "",
            "headers": [], "client": None, "server": None}

        async def receive() -> dict:
            return {"type": "http.request", "body": b"", "more_body": False}

        async def send(_message: dict) -> None:
            pass
        await app.router(scope, receive, send)
    try:
        asyncio.run(one())
    except Exception:  # (a 404 raised, a FastAPI that works otherwise: only a warm-up)
        log.debug("route warm-up ended early", exc_info=True)


def start(app: Any) -> threading.Thread:
    thread = threading.Thread(target=warm_up_routes, args=(app,), name="urc-warm-routes", daemon=True)
    thread.start()
    return thread


__all__ = ["WARM_UP_PATH", "start", "warm_up_routes"]
