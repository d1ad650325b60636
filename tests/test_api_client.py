"""The client commands' HTTP request (urc.api_client): plain http on a socket of its own
(http.client's imports were half of `urc status`'s time), https through http.client."""

from __future__ import annotations

import json
import socket
import struct
import threading
import time
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


def test_an_interim_answer_is_passed_over():
    raw = b"HTTP/1.1 100 Continue\r\n\r\nHTTP/1.1 200 OK\r\nContent-Length: 2\r\n\r\nok"
    assert parse_response(raw) == (200, b"ok")


def test_the_same_length_twice_and_chunked_not_last():
    assert parse_response(b"HTTP/1.1 200 OK\r\nContent-Length: 2\r\nContent-Length: 2\r\n\r\nok") == (200, b"ok")
    # (chunked not the last coding: the body runs to the close, RFC 9112 6.3)
    assert parse_response(b"HTTP/1.1 200 OK\r\nTransfer-Encoding: chunked, gzip\r\n\r\n2\r\nxy") == (200, b"2\r\nxy")


def test_header_names_are_case_insensitive():
    assert parse_response(b"HTTP/1.1 200 OK\r\ncontent-LENGTH: 2\r\n\r\nokEXTRA") == (200, b"ok")


@pytest.mark.parametrize("raw,said", [
    (b"", "the connection closed without one"),
    (b"SSH-2.0-OpenSSH_9.2\r\n", "not an HTTP response"),
    (b"HTTP/1.1 200 OK\r\nContent-Length: 5\r\n", "not an HTTP response"),   # the head cut short
    (b"HTTP/1.1 2x0 OK\r\n\r\n", "not an HTTP response"),
    (b"HTTP/1.1 200 OK\r\nContent-Length: 10\r\n\r\nshort", "5 bytes of a body of 10"),
    (b"HTTP/1.1 200 OK\r\nContent-Length: -1\r\n\r\n", "Content-Length \\['-1'\\]"),
    (b"HTTP/1.1 200 OK\r\nContent-Length: 1\xb2\r\n\r\nab", "Content-Length"),          # ('1²': not ASCII)
    (b"HTTP/1.1 200 OK\r\nContent-Length: 2\r\nContent-Length: 3\r\n\r\nabc", "Content-Length"),
    (b"HTTP/1.1 2\xb20 OK\r\n\r\n", "not an HTTP response"),
    (b"HTTP/1.1 2000 OK\r\n\r\n", "not an HTTP response"),
    (b"HTTP/1.1 200 OK\r\nTransfer-Encoding: chunked\r\n\r\n2\r\nabc\r\n0\r\n\r\n", "longer than its size"),
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


def one_shot_server(answer) -> tuple[socket.socket, threading.Thread]:
    """A listening socket whose first connection is handed to ``answer(conn)``."""
    srv = socket.create_server(("127.0.0.1", 0))

    def serve():
        conn, _ = srv.accept()
        answer(conn)
    t = threading.Thread(target=serve, daemon=True)
    t.start()
    return srv, t


def reset(conn: socket.socket) -> None:
    """Closed with a reset (RST), not a FIN: SO_LINGER on, zero seconds."""
    conn.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))
    conn.close()


def test_nothing_listening_is_unreachable():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]   # (bound, never listening: refused)
    with pytest.raises(ClientError, match="cannot reach urc"):
        request(f"http://127.0.0.1:{port}", "GET", "/api/status", timeout_s=2.0)


def test_a_server_that_answers_garbage_is_a_bad_answer():
    """A port that is not urc's (here: it greets like an SSH server, then closes)."""
    def greet(conn):
        conn.recv(1024)
        conn.sendall(b"SSH-2.0-OpenSSH_9.2\r\n")
        conn.close()
    srv, _ = one_shot_server(greet)
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


def test_an_answer_is_taken_when_whole_though_the_server_keeps_the_connection():
    """A server (or proxy) that ignores ``Connection: close``: the answer, at once, not
    NoAnswer after the timeout."""
    release = threading.Event()

    def keep_open(conn):
        conn.recv(65536)
        conn.sendall(b"HTTP/1.1 200 OK\r\nContent-Length: 11\r\n\r\n{\"ok\":true}")
        release.wait(30)
        conn.close()
    srv, _ = one_shot_server(keep_open)
    try:
        assert request(f"http://127.0.0.1:{srv.getsockname()[1]}", "GET", "/api/status", timeout_s=3.0) == {"ok": True}
    finally:
        release.set()
        srv.close()


def test_a_whole_answer_then_a_reset_is_the_answer():
    def answer_then_reset(conn):
        conn.recv(65536)
        conn.sendall(b"HTTP/1.1 200 OK\r\nContent-Type: application/json\r\n\r\n{\"ok\":1}")
        time.sleep(0.2)
        reset(conn)
    srv, _ = one_shot_server(answer_then_reset)
    try:
        # (framed by the close: the reset ends the body as a close would)
        assert request(f"http://127.0.0.1:{srv.getsockname()[1]}", "GET", "/api/status", timeout_s=5.0) == {"ok": 1}
    finally:
        srv.close()


def test_a_refusal_sent_before_the_body_was_read_is_reported():
    """A server that answers a too large body at once (413) and closes with most of it
    unread (the kernel then resets): the refusal, not 'cannot reach'."""
    def refuse_early(conn):
        conn.recv(1024)
        body = b'{"error":"request body larger than 65536 bytes"}'
        conn.sendall(b"HTTP/1.1 413 Content Too Large\r\nContent-Length: %d\r\n\r\n%s" % (len(body), body))
        time.sleep(0.2)
        conn.close()   # (unread data in its buffer: the close goes out as a reset)
    srv, _ = one_shot_server(refuse_early)
    try:
        with pytest.raises(ClientError, match=r"refused \(413\): request body larger than 65536 bytes"):
            request(f"http://127.0.0.1:{srv.getsockname()[1]}", "POST", "/api/goto",
                    {"pad": "x" * 3_000_000}, timeout_s=5.0)
    finally:
        srv.close()


@pytest.mark.parametrize("token", ["secret\r", "sec\nret", "a\x00b"])
def test_a_token_with_a_control_character_is_refused_before_sending(echo, token):
    with pytest.raises(ClientError, match="the token has a control character"):
        request(echo, "GET", "/api/status", token=token, timeout_s=5.0)


def test_a_path_with_a_space_is_refused_before_sending(echo):
    with pytest.raises(ClientError, match="has spaces or control characters"):
        request(echo, "GET", "/api/a b", timeout_s=5.0)


def test_an_ipv6_address():
    if not socket.has_ipv6:
        pytest.skip("no IPv6 on this machine")
    class Server6(ThreadingHTTPServer):
        address_family = socket.AF_INET6

    try:
        server = Server6(("::1", 0), Echo)
    except OSError as exc:
        pytest.skip(f"no IPv6 loopback: {exc}")
    threading.Thread(target=server.serve_forever, daemon=True).start()
    try:
        port = server.server_address[1]
        got = request(f"http://[::1]:{port}", "GET", "/api/status", timeout_s=5.0)
        assert got["headers"]["Host"] == f"[::1]:{port}"
    finally:
        server.shutdown()
        server.server_close()


# ------------------------------------------------------------------ a refusal in words
def _served(code: int, body: bytes):
    def answer(conn):
        conn.recv(65536)
        conn.sendall(b"HTTP/1.1 %d X\r\nContent-Type: application/json\r\nContent-Length: %d\r\n\r\n%s"
                     % (code, len(body), body))
        conn.close()
    return one_shot_server(answer)


@pytest.mark.parametrize("body, said", [
    ({"az_deg": 123, "el_deg": 200}, "el_deg 200 is above 180, the most accepted"),
    ({"az_deg": -400}, "az_deg -400 is below -360, the least accepted"),
    ({"az_deg": 10, "speed": 2}, "speed: no such field"),
    ({"el_deg": 10}, "az_deg is missing"),
    ({"az_deg": "45"}, "az_deg: input should be a valid number, found '45'"),
])
def test_a_422_is_one_sentence_naming_the_field(bench, body, said):
    """`urc goto 123 200` printed FastAPI's 422 as a Python list of dicts (issue 36.11):
    the real API's answer, said as words."""
    from fastapi.testclient import TestClient

    from urc.api import create_api
    from urc.assembly import settings_from_config

    b = bench("berkeley")
    answer = TestClient(create_api(b.rot, b.cfg, settings_of=settings_from_config), base_url="http://127.0.0.1:8080").post("/api/goto", json=body)
    assert answer.status_code == 422
    srv, _ = _served(422, answer.content)
    try:
        with pytest.raises(ClientError) as err:
            request(f"http://127.0.0.1:{srv.getsockname()[1]}", "POST", "/api/goto", body, timeout_s=5.0)
    finally:
        srv.close()
    assert str(err.value) == f"refused (422): {said}"
    assert err.value.code == 422 and err.value.data == answer.json()
