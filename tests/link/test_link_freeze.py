"""A held-up control process holds up no client (issue 19): a real ``urc run`` whose
control process is SIGSTOPped while a set waits on one rotctld connection."""

from __future__ import annotations

import os
import signal
import socket

import pytest

from urc_process import HTTP, UrcProcess, free_port, process_gone, wait_until

#: generous: the point is what answers before the pending set does, not how fast
ANSWER_TIMEOUT_S = 30.0


def line(sock: socket.socket, end: bytes = b"\n") -> bytes:
    got = b""
    while not got.endswith(end):
        chunk = sock.recv(256)
        if not chunk:
            break
        got += chunk
    return got


@pytest.fixture
def frozen_setup(tmp_path):
    rotctld_port, gs232_port = free_port(), free_port()
    # (the I/O process's takeover of a frozen control process off: this is about the link)
    u = UrcProcess(tmp_path, profile="tartu-urc", extra="[faults]\ncontrol_takeover_s = 0\n", serve=[
        {"protocol": "rotctld", "tcp": f"127.0.0.1:{rotctld_port}"},
        {"protocol": "gs232b", "tcp": f"127.0.0.1:{gs232_port}"}]).start()
    conns = [socket.create_connection(("127.0.0.1", p), timeout=ANSWER_TIMEOUT_S)
             for p in (rotctld_port, rotctld_port, gs232_port)]
    pid = u.control_pid()
    yield u, conns, pid
    try:
        os.kill(pid, signal.SIGCONT)
    except ProcessLookupError:
        pass
    for c in conns:
        c.close()
    u.kill()  # (the stop judged here is the dashboard's STOP, not the process's)


def test_a_stopped_control_process_blocks_no_other_client_and_a_stop_waits_for_it(frozen_setup):
    u, (setter, poller, gs232), pid = frozen_setup
    assert u.post("/api/goto", {"az_deg": 300, "el_deg": 60}).status_code == 200
    u.wait(lambda s: s["moving"])
    poller.sendall(b"p\n")
    live = line(poller).split()
    assert len(live) == 2 and float(live[0]) >= 0  # a position while the process runs

    os.kill(pid, signal.SIGSTOP)
    setter.sendall(b"P 100 45\n")  # waits for a control process that does not answer
    setter.setblocking(False)
    # (once its status is a second old, the process counts as silent; a set sent after
    # that is refused at once: only positions known to be current are checked against)
    u.wait(lambda s: any(f["kind"] == "control" for f in s["faults"]), timeout_s=ANSWER_TIMEOUT_S)

    # every other client is served meanwhile, each told that no position is current
    poller.sendall(b"p\n")
    assert line(poller) == b"RPRT -9\n"
    gs232.sendall(b"C2\r")
    assert line(gs232, b"\r\n") == b"?>\r\n"
    status = HTTP.get(u.url + "/api/status", timeout=ANSWER_TIMEOUT_S).json()
    assert any(f["kind"] == "control" and "silent" in f["reason"] for f in status["faults"])
    with pytest.raises(BlockingIOError):
        setter.recv(64)  # ... all while the set still waits

    stop = u.post("/api/stop")  # the dashboard's STOP: sent, confirmed once the process runs
    assert stop.status_code == 200 and stop.json()["queued"], stop.text
    setter.setblocking(True)
    assert line(setter) == b"RPRT -9\n"  # the set timed out: refused, and never applied

    os.kill(pid, signal.SIGCONT)
    # the queued stop runs once the process does (its first statuses after the thaw can
    # come before it: the loop holds the motors after a stall, the target still 300)
    s = u.wait(lambda s: s["target_az_deg"] is None and not s["moving"]
               and not any(f["kind"] == "control" for f in s["faults"]), timeout_s=ANSWER_TIMEOUT_S)
    assert abs(s["az_deg"] - 100) > 5, "the set that timed out did not run later"
    poller.sendall(b"p\n")
    assert len(line(poller).split()) == 2  # positions again
    wait_until(lambda: not u.status()["moving"], ANSWER_TIMEOUT_S, "standing")


def test_after_a_takeover_clients_keep_their_connection_and_the_control_process_comes_back(tmp_path):
    """Issue 33: after a takeover `urc run` exited, resetting every rotctld client and
    refusing it until a restart. Now the I/O process holds the outputs safe, starts the
    control process again (after a back-off) and the same connection is answered
    meanwhile with the protocol's error, then with the position again."""
    port = free_port()
    u = UrcProcess(tmp_path, profile="g5500", serve=[{"protocol": "rotctld", "tcp": f"127.0.0.1:{port}"}]).start()
    try:
        client = socket.create_connection(("127.0.0.1", port), timeout=ANSWER_TIMEOUT_S)
        client.sendall(b"p\n")
        assert len(line(client).split()) == 2
        pid = u.control_pid()
        os.kill(pid, signal.SIGSTOP)   # frozen for good: taken over after control_takeover_s
        wait_until(lambda: process_gone(pid), 30.0, "the frozen control process killed")
        client.sendall(b"p\n")
        assert line(client) == b"RPRT -9\n"   # the same connection: the protocol's error
        s = u.wait(lambda s: any("started again" in e for e in s["events"]), timeout_s=60)
        assert not any(f["kind"] == "control" for f in s["faults"]), s["faults"]
        assert u.control_pid() != pid and u.proc.poll() is None
        client.sendall(b"p\n")
        # g5500's potentiometers are absolute: the position is known again at once
        assert len(line(client).split()) == 2 and s["position_known"]
        client.close()
    finally:
        u.kill()
