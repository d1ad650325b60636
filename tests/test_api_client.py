"""The client commands' HTTP request (urc.api_client): plain http on a socket of its own
(http.client's imports were half of `urc status`'s time), https through http.client."""

from __future__ import annotations

import json
import socket
import threading
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

import pytest

from urc.api_client import ClientError, http, parse_response, request


# ------------------------------------------------------------------ the response's framing
def test_a_body_framed_by_content_length():
    raw = b"HTTP/1.1 200 OK\r\nContent-Type: application/json\r\nContent-Length: 7\r\n\r\n{\"a\":1}"
    assert parse_response(raw) == (200, b'{"a":1}')


def test_a_chunked_body_with_extensions_and_trailers():
    raw = (b"HTTP/1.1 422 Unprocessable Entity\r\nTransfer-Encoding: chunked\r\n\r\n"
           b"4;name=x\r\n{\"a\"\r\n3\r\n:1}\r\n0\r\nX-Trailer: y\r\n\r\n")
    assert parse_response(raw) == (422, b'{"a":1}')


def test_a_body_framed_by_the_close():
    assert parse_response(b"HTTP/1.0 200 OK\r\nServer: x\r\n\r\nhello") == (200, b"hello")


def test_header_names_are_case_insensitive():
    assert parse_response(b"HTTP/1.1 200 OK\r\ncontent-LENGTH: 2\r\n\r\nokEXTRA") == (200, b"ok")


@pytest.mark.parametrize("raw,said", [
    (b"", "not an HTTP response"),
    (b"SSH-2.0-OpenSSH_9.2\r\n", "not an HTTP response"),
    (b"HTTP/1.1 200 OK\r\nContent-Length: 5\r\n", "not an HTTP response"),   # the head cut short
    (b"HTTP/1.1 2x0 OK\r\n\r\n", "not an HTTP response"),
    (b"HTTP/1.1 200 OK\r\nContent-Length: 10\r\n\r\nshort", "5 bytes of a body of 10"),
    (b"HTTP/1.1 200 OK\r\nContent-Length: -1\r\n\r\n", "of a body of -1"),
    (b"HTTP/1.1 200 OK\r\nTransfer-Encoding: chunked\r\n\r\nzz\r\n", "chunk size"),
    (b"HTTP/1.1 200 OK\r\nTransfer-Encoding: chunked\r\n\r\n-5\r\n", "chunk size"),
    (b"HTTP/1.1 200 OK\r\nTransfer-Encoding: chunked\r\n\r\n0x3\r\nabc\r\n0\r\n\r\n", "chunk size"),
    (b"HTTP/1.1 200 OK\r\nTransfer-Encoding: chunked\r\n\r\n10\r\nabc", "cut short in a chunk"),
    (b"HTTP/1.1 200 OK\r\nTransfer-Encoding: chunked\r\n\r\n3\r\nabc\r\n", "cut short in a chunk"),
])
def test_anything_else_is_a_bad_answer(raw, said):
    with pytest.raises(OSError, match=f"bad answer: .*{said}"):
        parse_response(raw)


# ------------------------------------------------------------------ against real servers
class Echo(BaseHTTPRequestHandler):
    """Answers with what it got (method, path, headers, body), chunked when asked."""

    protocol_version = "HTTP/1.1"

    def _answer(self):
        body = self.rfile.read(int(self.headers.get("Content-Length") or 0))
        data = json.dumps({"method": self.command, "path": self.path, "headers": dict(self.headers),
                           "body": body.decode()}).encode()
        self.send_response(201)
        if "chunked" in self.path:
            self.send_header("Transfer-Encoding", "chunked")
            self.end_headers()
            for i in range(0, len(data), 7):
                piece = data[i:i + 7]
                self.wfile.write(b"%x\r\n%s\r\n" % (len(piece), piece))
            self.wfile.write(b"0\r\n\r\n")
        else:
            self.send_header("Content-Length", str(len(data)))
            self.end_headers()
            self.wfile.write(data)

    do_GET = do_POST = _answer  # noqa: N815 - http.server's names

    def log_message(self, *args):
        pass


@pytest.fixture(scope="module")
def echo():
    server = ThreadingHTTPServer(("127.0.0.1", 0), Echo)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    yield f"http://127.0.0.1:{server.server_address[1]}"
    server.shutdown()
    server.server_close()


@pytest.mark.parametrize("path", ["/api/goto?x=1", "/api/goto/chunked"])
def test_a_request_arrives_whole_and_its_answer_is_read(echo, path):
    code, raw = http("POST", echo + path, {"az_deg": 12.5}, {"Authorization": "Bearer t"}, 5.0)
    got = json.loads(raw)
    assert code == 201 and got["method"] == "POST" and got["path"] == path
    assert json.loads(got["body"]) == {"az_deg": 12.5}
    assert got["headers"]["Content-Type"] == "application/json"
    assert got["headers"]["Authorization"] == "Bearer t"
    assert got["headers"]["Host"] == echo.removeprefix("http://")


def test_nothing_listening_is_unreachable():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]   # (bound, never listening: refused)
    with pytest.raises(ClientError, match="cannot reach urc"):
        request(f"http://127.0.0.1:{port}", "GET", "/api/status", timeout_s=2.0)


def test_a_server_that_answers_garbage_is_a_bad_answer():
    """A port that is not urc's (here: it greets like an SSH server, then closes)."""
    srv = socket.create_server(("127.0.0.1", 0))

    def greet():
        conn, _ = srv.accept()
        conn.recv(1024)
        conn.sendall(b"SSH-2.0-OpenSSH_9.2\r\n")
        conn.close()
    threading.Thread(target=greet, daemon=True).start()
    try:
        with pytest.raises(ClientError, match="cannot reach urc .*bad answer: not an HTTP response"):
            request(f"http://127.0.0.1:{srv.getsockname()[1]}", "GET", "/api/status", timeout_s=5.0)
    finally:
        srv.close()


def test_a_silent_server_is_no_answer_not_unreachable():
    srv = socket.create_server(("127.0.0.1", 0))   # (the kernel accepts; nobody answers)
    try:
        with pytest.raises(ClientError, match="took the request but gave no answer within 0.3 s"):
            request(f"http://127.0.0.1:{srv.getsockname()[1]}", "GET", "/api/status", timeout_s=0.3)
    finally:
        srv.close()
