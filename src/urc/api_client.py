"""One request to a running urc's HTTP API, as the client commands (``urc status``,
``urc goto`` ...) make it.

Standard library only: a client command starts in a fraction of what an HTTP client
library's imports take (httpx: trio, rich and certifi, 0.1-1 s; a Pi Zero is ~10x
slower), and ``urc status`` runs without click (issue 19).
"""

from __future__ import annotations

import json
import socket

DEFAULT_URL = "http://127.0.0.1:8080"

#: how long a client command waits for urc's answer. Generous: a loaded controller (a
#: Pi at full CPU) answers late, and giving up early reported "cannot reach urc" while it
#: was in fact doing what was asked. Connecting is separate and quick to fail.
CLIENT_TIMEOUT_S = 60.0
CONNECT_TIMEOUT_S = 5.0


class ClientError(Exception):
    """The request failed: urc unreachable, silent, or it refused. The message is what the
    command prints after ``Error:``; ``code`` and ``data`` are a refusal's status and
    decoded answer (0 and None when there was none)."""

    def __init__(self, message: str, code: int = 0, data: object = None):
        super().__init__(message)
        self.code, self.data = code, data


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
    from urllib.parse import urlsplit

    parts = urlsplit(url)
    if parts.scheme not in ("http", "https") or not parts.hostname:
        raise OSError(f"not an http(s) address: {url!r}")
    target = (parts.path or "/") + (f"?{parts.query}" if parts.query else "")
    data = None if body is None else json.dumps(body).encode()
    if data is not None:
        headers = {**headers, "Content-Type": "application/json"}
    if parts.scheme == "https":
        return _https(parts.hostname, parts.port, method, target, data, headers, timeout_s)
    return _plain_http(parts.hostname, parts.port or 80, method, target, data, headers, timeout_s)


def _https(host: str, port: int | None, method: str, target: str, data: bytes | None,
           headers: dict[str, str], timeout_s: float) -> tuple[int, bytes]:
    """Through the standard library's client (it needs ssl anyway)."""
    import http.client

    conn = http.client.HTTPSConnection(host, port, timeout=min(CONNECT_TIMEOUT_S, timeout_s))
    try:
        conn.connect()  # (OSError: nothing listens, no route, no answer to connect)
        assert conn.sock is not None
        conn.sock.settimeout(timeout_s)
        try:
            conn.request(method, target, body=data, headers=headers)
            resp = conn.getresponse()
            return resp.status, resp.read()
        except TimeoutError:
            raise NoAnswer() from None
        except http.client.HTTPException as exc:
            raise OSError(f"bad answer: {exc!r}") from None
    finally:
        conn.close()


def _plain_http(host: str, port: int, method: str, target: str, data: bytes | None,
                headers: dict[str, str], timeout_s: float) -> tuple[int, bytes]:
    """One HTTP/1.1 request on a socket of its own.

    By hand, not http.client: importing http.client loads ssl and the email package,
    about half of `urc status`'s time (issue 19's target is 80 ms; a Pi Zero is ~10x
    slower). One request per connection (``Connection: close``) needs only the request
    line and headers out, and back the status line, the headers and the body's framing
    (RFC 9112: chunked, Content-Length, or the close): :func:`parse_response`. The answer
    is taken as soon as it is whole, whether or not the server then closes or resets."""
    request = _request_head(method, target, host, port, headers, len(data or b"")) + (data or b"")
    sock = socket.create_connection((host, port), timeout=min(CONNECT_TIMEOUT_S, timeout_s))
    try:
        sock.settimeout(timeout_s)
        received = b""
        send_error: OSError | None = None
        try:
            try:
                sock.sendall(request)
            except (BrokenPipeError, ConnectionResetError) as exc:
                send_error = exc  # (it may have answered before it stopped reading: a refusal of a large body)
            while chunk := _recv(sock):
                received += chunk
                answer = _parse(received, at_eof=False)
                if answer is not None:
                    return answer
        except TimeoutError:
            if send_error is None:
                raise NoAnswer() from None
        except OSError:
            if send_error is None:
                raise
        if send_error is not None and not received:
            raise send_error
        return parse_response(received)
    finally:
        sock.close()


def _recv(sock: socket.socket) -> bytes:
    """The next bytes, or b"" at the end: a reset after the answer ends it as a close does."""
    try:
        return sock.recv(65536)
    except ConnectionResetError:
        return b""


def _request_head(method: str, target: str, host: str, port: int, headers: dict[str, str],
                  length: int) -> bytes:
    """The request line and headers; a CR, LF or other control character in a value (a
    token read from a file with Windows line ends) would cut the request, so it is refused."""
    if not target.isprintable() or " " in target:
        raise ClientError(f"the address's path {target!r} has spaces or control characters")
    authority = f"[{host}]:{port}" if ":" in host else f"{host}:{port}"  # (an IPv6 address)
    fields = {"Host": authority, "Connection": "close", "Accept": "application/json",
              "Content-Length": str(length), **headers}
    for name, value in fields.items():
        if not value.isprintable() or not name.isprintable() or ":" in name:
            what = "the token" if name == "Authorization" else f"header {name!r}"
            raise ClientError(f"{what} has a control character (a line end?): {value!r}")
    lines = [f"{method} {target} HTTP/1.1", *(f"{k}: {v}" for k, v in fields.items())]
    return "\r\n".join(lines).encode("latin-1") + b"\r\n\r\n"


def parse_response(raw: bytes) -> tuple[int, bytes]:
    """(status code, body) of a whole HTTP/1.1 response read to the connection's close;
    OSError("bad answer: ...") for anything else (not HTTP, cut short, bad framing)."""
    answer = _parse(raw, at_eof=True)
    assert answer is not None
    return answer


def _digits(text: str) -> bool:
    return text.isascii() and text.isdigit()


def _parse(raw: bytes, at_eof: bool) -> tuple[int, bytes] | None:
    """The answer in ``raw``; None while it may still be coming (``at_eof`` False)."""
    while True:
        head, sep, rest = raw.partition(b"\r\n\r\n")
        if not sep:
            if at_eof:
                raise OSError(f"bad answer: not an HTTP response: {raw[:40]!r}" if raw else
                              "bad answer: the connection closed without one")
            return None
        status_line, *header_lines = head.decode("latin-1").split("\r\n")
        version, _, code_text = status_line.partition(" ")
        code = code_text[:3]
        if not version.startswith("HTTP/1.") or not _digits(code) or code_text[3:4] not in ("", " "):
            raise OSError(f"bad answer: not an HTTP response: {raw[:40]!r}")
        if code[0] != "1":
            status = int(code)
            break
        raw = rest  # (an interim answer, 100 Continue or 103 Early Hints: the real one follows)
    fields: dict[str, list[str]] = {}
    for line in header_lines:
        name, colon, value = line.partition(":")
        if colon:
            fields.setdefault(name.strip().lower(), []).append(value.strip())
    codings = [c.strip().lower() for v in fields.get("transfer-encoding", []) for c in v.split(",")]
    if codings:
        if codings[-1] == "chunked":
            body = _unchunk(rest, at_eof)
            return None if body is None else (status, body)
        return (status, rest) if at_eof else None  # (another coding last: framed by the close)
    lengths = set(fields.get("content-length", []))
    if not lengths:
        return (status, rest) if at_eof else None  # (framed by the close)
    length = lengths.pop()
    if lengths or not _digits(length):
        raise OSError(f"bad answer: Content-Length {fields['content-length']}")
    if len(rest) < int(length):
        if at_eof:
            raise OSError(f"bad answer: {len(rest)} bytes of a body of {length}")
        return None
    return status, rest[: int(length)]


def _unchunk(data: bytes, at_eof: bool) -> bytes | None:
    """The body of a chunked message; None while more may come."""
    body: list[bytes] = []
    while True:
        size_line, sep, data = data.partition(b"\r\n")
        if not sep:
            break
        size_text = size_line.split(b";")[0].strip()
        if not size_text or size_text.strip(b"0123456789abcdefABCDEF"):
            raise OSError(f"bad answer: chunk size {size_line[:20]!r}")
        size = int(size_text, 16)
        if size == 0:
            return b"".join(body)  # (any trailer fields after it are not needed)
        if len(data) < size + 2:
            break
        if data[size:size + 2] != b"\r\n":
            raise OSError("bad answer: a chunk longer than its size")
        body.append(data[:size])
        data = data[size + 2:]
    if at_eof:
        raise OSError("bad answer: cut short in a chunk")
    return None


def request(url: str, method: str, path: str, body: dict | None = None, *, token: str = "",
            timeout_s: float = CLIENT_TIMEOUT_S, headers: dict[str, str] | None = None) -> dict:
    """The answer of ``method path`` at the API ``url``, decoded (a body that is not
    JSON comes back as ``{"error": text}``). Raises ClientError with the message the
    command prints. ``headers``: more request headers (a settings save's If-Match)."""
    headers = {**(headers or {}), **({"Authorization": f"Bearer {token}"} if token else {})}
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
        elif isinstance(data, dict) and invalid_fields(data):
            detail = "; ".join(invalid_sentence(e) for e in invalid_fields(data)[:3])
        else:
            detail = data.get("error") or data.get("detail") or data
        raise ClientError(f"refused ({code}): {detail}", code, data)
    return data


#: a range check's words (pydantic's error types in FastAPI's 422 ``detail`` entries)
_BOUNDS = {"less_than_equal": ("le", "is above {}, the most accepted"), "less_than": ("lt", "must be below {}"),
           "greater_than_equal": ("ge", "is below {}, the least accepted"), "greater_than": ("gt", "must be above {}")}


def invalid_fields(data: dict) -> list[dict]:
    """The entries of a 422 answer's ``detail`` (one per field), or []."""
    detail = data.get("detail")
    if not isinstance(detail, list):
        return []
    return [e for e in detail if isinstance(e, dict) and isinstance(e.get("loc"), list)]


def field_name(entry: dict) -> str:
    return ".".join(str(x) for x in entry["loc"] if x != "body") or "body"


def invalid_sentence(entry: dict) -> str:
    """One 422 entry as words: ``el_deg 200 is above 180, the most accepted``."""
    name, kind, found = field_name(entry), entry.get("type"), entry.get("input")
    ctx = entry.get("ctx")
    key, words = _BOUNDS.get(str(kind), ("", ""))
    limit = ctx.get(key) if key and isinstance(ctx, dict) else None
    if isinstance(found, (int, float)) and isinstance(limit, (int, float)):
        return f"{name} {found:g} " + words.format(f"{limit:g}")
    if kind == "extra_forbidden":
        return f"{name}: no such field"
    if kind == "missing":
        return f"{name} is missing"
    said = str(entry.get("msg") or "invalid")
    return f"{name}: {said[:1].lower() + said[1:]}" + (f", found {found!r}" if "input" in entry else "")
