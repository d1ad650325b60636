"""The floor under urc's rotctld ``P``: the least a set can cost in urc's shape.

urc answers ``P`` only after the control process (another Python process) has taken the
command and replied. This server does nothing else: an asyncio TCP server that, for each
``P`` line, sends a small pickled request over a Unix socket (multiprocessing's framing,
as urc's link) to a child process, which unpickles it and replies at once; the server
then writes ``RPRT 0``. No parsing beyond the first byte, no rotator, no status.

Two ways to take the reply in the server, as urc could:
* ``thread``: a reader thread receives it and resolves the waiting future with
  ``call_soon_threadsafe`` (what urc's ControlLink does);
* ``loop``: the event loop reads the socket itself (``add_reader``): one hop fewer.

``p`` is answered at once (urc answers it from the newest status without a round trip).
rotctld_bench.py runs this next to urc and Hamlib's ``rotctld -m 1``: urc's ``P`` minus
this floor is what urc's own code costs; this floor over Hamlib's is what two Python
processes cost, whatever urc does.

Usage (started by rotctld_bench.py): python bench/link_floor.py PORT {thread|loop}
"""

from __future__ import annotations

import asyncio
import os
import pickle
import socket
import struct
import sys
import threading
from multiprocessing.connection import Connection


def child(fd: int) -> None:
    conn = Connection(fd)
    while True:
        try:
            rid, _request = pickle.loads(conn.recv_bytes())
        except EOFError:
            return
        conn.send_bytes(pickle.dumps((rid, "ok"), protocol=pickle.HIGHEST_PROTOCOL))


class Link:
    def __init__(self, conn: Connection, mode: str, loop: asyncio.AbstractEventLoop):
        self.conn, self.loop = conn, loop
        self.pending: dict[int, asyncio.Future] = {}
        self.next_id = 0
        if mode == "thread":
            threading.Thread(target=self._read_thread, daemon=True).start()
        else:
            self.sock = socket.socket(fileno=os.dup(conn.fileno()))
            self.buf = bytearray()
            loop.add_reader(self.sock.fileno(), self._read_loop)

    def call(self, request: object) -> asyncio.Future:
        self.next_id += 1
        fut = self.pending[self.next_id] = self.loop.create_future()
        self.conn.send_bytes(pickle.dumps((self.next_id, request), protocol=pickle.HIGHEST_PROTOCOL))
        return fut

    def _settle(self, reply: tuple) -> None:
        fut = self.pending.pop(reply[0], None)
        if fut is not None and not fut.done():
            fut.set_result(reply[1])

    def _read_thread(self) -> None:
        while True:
            self.loop.call_soon_threadsafe(self._settle, pickle.loads(self.conn.recv_bytes()))

    def _read_loop(self) -> None:
        self.buf += self.sock.recv(65536, socket.MSG_DONTWAIT)
        while len(self.buf) >= 4:
            (size,) = struct.unpack("!i", self.buf[:4])
            if len(self.buf) < 4 + size:
                return
            self._settle(pickle.loads(bytes(self.buf[4:4 + size])))
            del self.buf[:4 + size]


class Session(asyncio.Protocol):
    def __init__(self, link: Link):
        self.link = link

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        assert isinstance(transport, asyncio.Transport)
        self.transport = transport
        transport.get_extra_info("socket").setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)

    def data_received(self, data: bytes) -> None:
        for line in data.splitlines():
            if line.startswith(b"P"):
                self.link.call(("goto", line)).add_done_callback(lambda _f: self.transport.write(b"RPRT 0\n"))
            else:
                self.transport.write(b"0.000000\n0.000000\n")


async def serve(port: int, mode: str) -> None:
    ours, theirs = socket.socketpair()
    pid = os.fork()
    if pid == 0:
        ours.close()
        child(theirs.detach())
        os._exit(0)
    theirs.close()
    loop = asyncio.get_running_loop()
    link = Link(Connection(ours.detach()), mode, loop)
    server = await loop.create_server(lambda: Session(link), "127.0.0.1", port, reuse_address=True)
    async with server:
        await server.serve_forever()


if __name__ == "__main__":
    asyncio.run(serve(int(sys.argv[1]), sys.argv[2]))
