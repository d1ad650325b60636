"""A pass that outlives its I/O process (issue 33): the control process flies on, and the
next ``urc run`` takes it over instead of starting another.

When the I/O process dies (a crash, the OOM killer, systemd's watchdog) while a bounded
motion is in flight (a goto, a park, a pass program: urc.model.program), the control
process does not stop: it flies that motion to its end by its own clock and listens on a
socket named after its state directory. A ``urc run`` for that state directory connects
there before it takes the instance lock; the control process hands over (the message
socket becomes the new link, and the status record and the instance locks cross as
descriptors), and the pass goes on without a pause. Once its motion has ended and no
``urc run`` came within ``ORPHAN_GRACE_S``, it stops in order as before.

The socket is in Linux's abstract namespace (no file to leave behind after a kill -9);
only a process of the same user, or root, may connect (SO_PEERCRED), as only they could
open the state directory. Written here rather than with multiprocessing's Listener: it
needs the peer's credentials and descriptors passed with the answer (SCM_RIGHTS).
"""

from __future__ import annotations

import hashlib
import logging
import os
import socket
import struct
from dataclasses import dataclass
from multiprocessing.connection import Connection
from pathlib import Path
from typing import Any

from . import codec

log = logging.getLogger(__name__)

#: after the motion in flight has ended, how long an orphaned control process waits for a
#: new ``urc run`` (systemd's RestartSec=2 and a start's imports on a Pi) before it stops
ORPHAN_GRACE_S = 15.0
#: how long either side waits for the other's part of the hand-over
HANDSHAKE_S = 5.0


def socket_name(state_dir: Path) -> bytes:
    """The abstract socket an orphaned control process of ``state_dir`` listens on."""
    digest = hashlib.sha256(str(Path(state_dir).resolve()).encode()).hexdigest()[:32]
    return b"\0urc-control-" + digest.encode()


def hardware_digest(cfg: Any) -> str:
    """What a control process was built for (the rotator and its hardware): a ``urc run``
    whose configuration differs there may not take it over. (Settings that can change
    while running — limits, zones, offsets, speeds — are applied after the hand-over.)"""
    text = cfg.rotator.model_dump_json() + cfg.hardware.model_dump_json()
    return hashlib.sha256(text.encode()).hexdigest()


# ------------------------------------------------------------- the orphan's side
class Listener:
    """The orphaned control process's socket (bound while it waits to be taken over)."""

    def __init__(self, state_dir: Path):
        self.sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM | socket.SOCK_CLOEXEC)
        self.sock.bind(socket_name(state_dir))
        self.sock.listen(2)

    def accept(self, timeout_s: float) -> Connection | None:
        """A connection from a process allowed to take over, or None (none came in time,
        or it was refused and closed)."""
        self.sock.settimeout(timeout_s)
        try:
            peer, _ = self.sock.accept()
        except (TimeoutError, socket.timeout):
            return None
        pid, uid, _gid = struct.unpack("3i", peer.getsockopt(socket.SOL_SOCKET, socket.SO_PEERCRED,
                                                             struct.calcsize("3i")))
        if uid not in (0, os.getuid()):
            log.warning("refused a take-over from process %d of user %d (not this process's user)", pid, uid)
            peer.close()
            return None
        peer.setblocking(True)
        return Connection(peer.detach())

    def close(self) -> None:
        self.sock.close()


def hand_over(conn: Connection, digest: str, ready: Any, fds: list[int]) -> tuple[str, str]:
    """Answer a take-over request on ``conn``: ("taken", who) once handed over (``ready``:
    the payload a start's "ready" carries, ``fds``: the status record's then the locks');
    ("other hardware", why) for a ``urc run`` configured for another rotator or hardware,
    refused: the caller stops in order, and that one waits for the lock, then builds its
    own; ("failed", why) for anything else (the caller waits on)."""
    if not conn.poll(HANDSHAKE_S):
        return "failed", "the new urc run said nothing"
    msg = codec.loads(conn.recv_bytes())
    if not (isinstance(msg, tuple) and len(msg) == 3 and msg[0] == "adopt"):
        return "failed", f"not a take-over request: {msg!r:.80}"
    if msg[2] != digest:
        conn.send_bytes(codec.dumps(("refused", "its configuration names another rotator or other hardware")))
        return "other hardware", f"urc run (process {msg[1]}) has another rotator or hardware configured"
    conn.send_bytes(codec.dumps(("adopted", ready)))
    dup = socket.socket(fileno=os.dup(conn.fileno()))
    try:
        socket.send_fds(dup, [b"F"], fds)
    finally:
        dup.close()
    return "taken", f"urc run (process {msg[1]})"


# ------------------------------------------------------------- the new urc run's side
@dataclass
class Adopted:
    """A control process taken over: its link, its "ready" payload, its pid, and the
    descriptors it handed over (the status record, then the instance locks)."""

    conn: Connection
    ready: dict[str, Any]
    pid: int
    record_fd: int
    lock_fds: list[int]


class AdoptionRefused(Exception):
    """An orphaned control process runs for this state directory but would not hand over."""


def adopt(state_dir: Path, cfg: Any) -> Adopted | None:
    """Take over the orphaned control process of ``state_dir`` if one waits; None if none
    does. Raises AdoptionRefused (it then stops in order: wait for the lock)."""
    sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM | socket.SOCK_CLOEXEC)
    try:
        sock.connect(socket_name(state_dir))
    except (ConnectionRefusedError, FileNotFoundError):
        sock.close()
        return None
    conn = Connection(sock.detach())
    try:
        conn.send_bytes(codec.dumps(("adopt", os.getpid(), hardware_digest(cfg))))
        if not conn.poll(HANDSHAKE_S):
            raise AdoptionRefused("the orphaned control process did not answer")
        kind, payload = codec.loads(conn.recv_bytes())
        if kind != "adopted":
            raise AdoptionRefused(str(payload))
        if not conn.poll(HANDSHAKE_S):  # (no timeout on the socket: it would make the link's non-blocking)
            raise AdoptionRefused("the orphaned control process sent no descriptors")
        dup = socket.socket(fileno=os.dup(conn.fileno()))
        try:
            _, fds, _, _ = socket.recv_fds(dup, 1, 16)
        finally:
            dup.close()
    except BaseException:
        conn.close()
        raise
    if not fds:
        conn.close()
        raise AdoptionRefused("the orphaned control process sent no descriptors")
    for fd in fds:
        os.set_inheritable(fd, False)
    return Adopted(conn, payload, int(payload["pid"]), fds[0], list(fds[1:]))
