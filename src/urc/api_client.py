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


#: an answer longer than this is not urc's (a status is a few kB)
MAX_ANSWER_BYTES = 16 * 1024 * 1024


def http(method: str, url: str, body: dict | None, headers: dict[str, str], timeout_s: float) -> tuple[int, bytes]:
    """(status code, body) of one request. Raises OSError when urc cannot be reached,
    NoAnswer when it took the request and did not answer in ``timeout_s``.

    One HTTP/1.0 exchange on a socket rather than http.client: importing http.client
    (email's parser and ssl come with it) took 33-55 ms, more than everything else
    `urc status` does after the interpreter has started. HTTP/1.0 keeps the answer simple
    to read: the server closes the connection after it, and never sends it in chunks."""
    import socket
    from urllib.parse import urlsplit

    parts = urlsplit(url)
    try:
        port = parts.port or (443 if parts.scheme == "https" else 80)
    except ValueError:  # a port that is not a number or out of range
        port = 0
    name = parts.hostname
    if parts.scheme not in ("http", "https") or not name or not port:
        raise OSError(f"not an http(s) address: {url!r}")
    target = (parts.path or "/") + (f"?{parts.query}" if parts.query else "")
    if not (target.isascii() and target.isprintable()) or " " in target:
        raise OSError(f"not an http(s) address: {url!r}")
    data = b"" if body is None else json.dumps(body).encode()
    lines = [f"{method} {target} HTTP/1.0", f"Host: {parts.netloc.rpartition('@')[2]}",
             "Accept: application/json", *(f"{k}: {v}" for k, v in headers.items())]
    if body is not None:
        lines += ["Content-Type: application/json", f"Content-Length: {len(data)}"]
    if any(not line.isprintable() for line in lines):  # (a line break in a token: a forged header)
        raise OSError("a header holds a control character (URC_TOKEN?)")
    try:
        request = "\r\n".join(lines).encode("latin-1") + b"\r\n\r\n" + data
    except UnicodeEncodeError as exc:
        raise OSError(f"a header is not latin-1 text: {exc}") from None
    # (OSError: nothing listens, no route, no answer to connect)
    sock = socket.create_connection((name, port), timeout=min(CONNECT_TIMEOUT_S, timeout_s))
    try:
        if parts.scheme == "https":
            import ssl

            sock = ssl.create_default_context().wrap_socket(sock, server_hostname=name)
        sock.settimeout(timeout_s)
        try:
            sock.sendall(request)
            answer = bytearray()
            while not _whole(answer) and (chunk := sock.recv(65536)):
                answer += chunk
                if len(answer) > MAX_ANSWER_BYTES:
                    raise OSError(f"bad answer: longer than {MAX_ANSWER_BYTES} bytes")
        except TimeoutError:
            raise NoAnswer() from None
    finally:
        sock.close()
    return _parse_answer(bytes(answer))


def _whole(answer: bytearray) -> bool:
    """Whether the answer so far is all its Content-Length says (a server that keeps the
    connection open after it need not be waited for); without one, the close ends it."""
    head, sep, rest = bytes(answer).partition(b"\r\n\r\n")
    if not sep:
        return False
    length = _headers(head).get(b"content-length", b"").strip()
    return length.isdigit() and len(rest) >= int(length)


def _headers(head: bytes) -> dict[bytes, bytes]:
    """The header fields of an answer's head, by lower-case name."""
    fields = {}
    for line in head.split(b"\r\n")[1:]:
        name, _, value = line.partition(b":")
        fields[name.strip().lower()] = value.strip()
    return fields


def _parse_answer(answer: bytes) -> tuple[int, bytes]:
    """(status code, body) of a whole HTTP/1.x answer; OSError if it is not one."""
    head, sep, rest = answer.partition(b"\r\n\r\n")
    version, _, code = head.split(b"\r\n", 1)[0].partition(b" ")
    code = code[:3]
    if not (sep and version.startswith(b"HTTP/1.") and code.isdigit() and len(code) == 3):
        raise OSError(f"bad answer: {answer[:80]!r}")
    fields = _headers(head)
    if fields.get(b"transfer-encoding", b"identity").lower() != b"identity":
        raise OSError("bad answer: sent in chunks to an HTTP/1.0 request")
    if b"content-length" not in fields:
        return int(code), rest  # (ended by the close)
    length = fields[b"content-length"]
    if not (length.isdigit() and int(length) <= len(rest)):
        raise OSError(f"bad answer: {len(rest)} bytes of Content-Length {length.decode('latin-1')}")
    return int(code), rest[: int(length)]


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
