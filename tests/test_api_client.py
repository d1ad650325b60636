"""The client commands' HTTP exchange (urc.api_client): one HTTP/1.0 request on a
socket, its answer read by Content-Length or to the close."""

from __future__ import annotations

import json
import socket
import threading

import pytest

from urc.api_client import NoAnswer, _parse_answer, http


def test_an_answer_is_read_by_its_content_length():
    raw = b"HTTP/1.1 200 OK\r\nContent-Type: application/json\r\ncontent-length: 2\r\n\r\n{}trailing"
    assert _parse_answer(raw) == (200, b"{}")


def test_an_answer_without_a_length_ends_at_the_close():
    assert _parse_answer(b"HTTP/1.0 404 Not Found\r\nServer: x\r\n\r\nnot here") == (404, b"not here")


@pytest.mark.parametrize("raw", [
    b"",                                                              # closed without a word
    b"SSH-2.0-OpenSSH_9.6\r\n",                                       # not HTTP at all
    b"HTTP/1.1 OK\r\n\r\n{}",                                         # no code
    b"HTTP/1.1 200 OK\r\nContent-Length: 10\r\n\r\n{}",               # cut short
    b"HTTP/1.1 200 OK\r\nContent-Length: x\r\n\r\n{}",
    b"HTTP/1.1 200 OK\r\nTransfer-Encoding: chunked\r\n\r\n2\r\n{}\r\n0\r\n\r\n",
])
def test_what_is_not_a_whole_http_answer_is_refused(raw):
    with pytest.raises(OSError, match="bad answer"):
        _parse_answer(raw)


@pytest.mark.parametrize("url", ["ftp://127.0.0.1/x", "http://127.0.0.1:abc/x", "http://127.0.0.1:99999/x",
                                 "http:///x", "http://127.0.0.1/a b", "http://127.0.0.1/\u00e9"])
def test_an_address_that_is_not_http_is_refused_before_connecting(url):
    with pytest.raises(OSError, match="not an http"):
        http("GET", url, None, {}, 5.0)


class OneShotServer:
    """Accepts one connection, records the request, answers ``reply`` and then keeps the
    connection open (as a keep-alive server or proxy may) until closed."""

    def __init__(self, reply: bytes):
        self.reply, self.request = reply, b""
        self.listener = socket.create_server(("127.0.0.1", 0))
        self.port = self.listener.getsockname()[1]
        self.done = threading.Event()
        self.thread = threading.Thread(target=self._serve, daemon=True)
        self.thread.start()

    def _serve(self) -> None:
        conn, _ = self.listener.accept()
        with conn:
            while b"\r\n\r\n" not in self.request:
                self.request += conn.recv(4096)
            head, _, body = self.request.partition(b"\r\n\r\n")
            length = next((int(line.split(b":")[1]) for line in head.split(b"\r\n")
                           if line.lower().startswith(b"content-length:")), 0)
            while len(body) < length:
                body += conn.recv(4096)
            self.request = head + b"\r\n\r\n" + body
            conn.sendall(self.reply)
            self.done.wait(60)

    def close(self) -> None:
        self.done.set()
        self.thread.join(10)
        self.listener.close()


def test_a_post_sends_its_body_and_reads_an_answer_without_waiting_for_the_close():
    """With a Content-Length the answer is whole without the close: a server that keeps
    the connection open would otherwise hold the command for its whole timeout and then
    be reported as silent (NoAnswer)."""
    server = OneShotServer(b'HTTP/1.1 200 OK\r\nContent-Length: 12\r\n\r\n{"ok": true}')
    try:
        code, body = http("POST", f"http://127.0.0.1:{server.port}/api/goto?x=1", {"az_deg": 10.0},
                          {"Authorization": "Bearer t"}, 30.0)
    finally:
        server.close()
    assert (code, json.loads(body)) == (200, {"ok": True})
    head, _, sent = server.request.partition(b"\r\n\r\n")
    lines = head.split(b"\r\n")
    assert lines[0] == b"POST /api/goto?x=1 HTTP/1.0"
    assert {b"Host: 127.0.0.1:%d" % server.port, b"Authorization: Bearer t", b"Content-Type: application/json",
            b"Content-Length: %d" % len(sent)} <= set(lines[1:])
    assert json.loads(sent) == {"az_deg": 10.0}


def test_a_server_that_takes_the_request_and_says_nothing_is_no_answer():
    server = OneShotServer(b"")
    try:
        with pytest.raises(NoAnswer):
            http("GET", f"http://127.0.0.1:{server.port}/api/status", None, {}, 0.3)
    finally:
        server.close()


def test_a_header_with_a_line_break_is_not_sent():
    with pytest.raises(OSError, match="control character"):
        http("GET", "http://127.0.0.1:1/api/status", None, {"Authorization": "Bearer x\r\nX-Evil: 1"}, 5.0)
