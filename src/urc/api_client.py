"""One request to a running urc's HTTP API, as the client commands (``urc status``,
``urc goto`` ...) make it.

Standard library only: a client command starts in a fraction of what an HTTP client
library's imports take (httpx: trio, rich and certifi, 0.1-1 s; a Pi Zero is ~10x
slower), and ``urc status`` runs without click (issue 19).
"""

from __future__ import annotations

import json

DEFAULT_URL = "http://127.0.0.1:8080"

#: how long a client command waits for urc's answer. Generous: a loaded controller (a
#: Pi at full CPU) answers late, and giving up early reported "cannot reach urc" while it
#: was in fact doing what was asked. Connecting is separate and quick to fail.
CLIENT_TIMEOUT_S = 60.0
CONNECT_TIMEOUT_S = 5.0


class ClientError(Exception):
    """The request failed: urc unreachable, silent, or it refused. The message is what the
    command prints after ``Error:``."""


class NoAnswer(Exception):
    """Connected and sent, but no answer in time: urc may be doing it."""


def base_url(url: str | None, port: int | None) -> str:
    """The API address from ``--url`` or ``--port`` (at most one is given)."""
    if url is not None:
        return url
    return DEFAULT_URL if port is None else f"http://127.0.0.1:{port}"


def http(method: str, url: str, body: dict | None, headers: dict[str, str], timeout_s: float) -> tuple[int, bytes]:
    """(status code, body) of one request. Raises OSError when urc cannot be reached,
    NoAnswer when it took the request and did not answer in ``timeout_s``."""
    import http.client
    from urllib.parse import urlsplit

    parts = urlsplit(url)
    if parts.scheme not in ("http", "https") or not parts.hostname:
        raise OSError(f"not an http(s) address: {url!r}")
    kind = http.client.HTTPSConnection if parts.scheme == "https" else http.client.HTTPConnection
    conn = kind(parts.hostname, parts.port, timeout=min(CONNECT_TIMEOUT_S, timeout_s))
    try:
        conn.connect()  # (OSError: nothing listens, no route, no answer to connect)
        assert conn.sock is not None
        conn.sock.settimeout(timeout_s)
        data = None if body is None else json.dumps(body).encode()
        if data is not None:
            headers = {**headers, "Content-Type": "application/json"}
        try:
            conn.request(method, (parts.path or "/") + (f"?{parts.query}" if parts.query else ""), body=data,
                         headers=headers)
            resp = conn.getresponse()
            return resp.status, resp.read()
        except TimeoutError:
            raise NoAnswer() from None
        except http.client.HTTPException as exc:
            raise OSError(f"bad answer: {exc!r}") from None
    finally:
        conn.close()


def request(url: str, method: str, path: str, body: dict | None = None, *, token: str = "",
            timeout_s: float = CLIENT_TIMEOUT_S) -> dict:
    """The answer of ``method path`` at the API ``url``, decoded (a body that is not
    JSON comes back as ``{"error": text}``). Raises ClientError with the message the
    command prints."""
    headers = {"Authorization": f"Bearer {token}"} if token else {}
    try:
        code, raw = http(method, url.rstrip("/") + path, body, headers, timeout_s)
    except NoAnswer:
        # it took the request: it may well be doing it (a refusal would have come back)
        raise ClientError(f"urc at {url} took the request but gave no answer within "
                          f"{timeout_s:g} s (busy?); it may have done it: see `urc status` "
                          "(--timeout waits longer)") from None
    except OSError as exc:
        raise ClientError(f"cannot reach urc at {url}: {exc} (is `urc run` running?)") from None
    text = raw.decode("utf-8", "replace")
    try:
        data = json.loads(text)
    except ValueError:
        data = {"error": text}
    if code >= 400:
        errors = data.get("errors") if isinstance(data, dict) else None
        if errors:  # the settings' checks: one problem per key
            detail = "; ".join(f"{e.get('key') or '-'}: {e.get('message')}" for e in errors)
        else:
            detail = data.get("error") or data.get("detail") or data
        raise ClientError(f"refused ({code}): {detail}")
    return data
