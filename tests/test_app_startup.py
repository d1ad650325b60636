"""`urc run` refuses a start it cannot complete before anything is started or written
(issue 21): a busy protocol port, a state directory holding a FIFO."""

from __future__ import annotations

import fcntl
import os
import socket
import subprocess

import pytest

from urc_process import URC, UrcProcess, free_port


def run_urc(u: UrcProcess) -> subprocess.CompletedProcess:
    # the timeout is a hang guard, not a measurement
    return subprocess.run(URC + ["run", "--config", str(u.config), "--state-dir", str(u.state_dir)],
                          capture_output=True, text=True, timeout=60)


@pytest.mark.parametrize("kind", ["tcp", "udp"])
def test_a_busy_protocol_port_refuses_the_start_before_the_control_process_and_state(tmp_path, kind):
    """The rotctld port in use was found only after the control process had started
    and a fresh state directory had been marked initialised."""
    port = free_port(socket.SOCK_STREAM if kind == "tcp" else socket.SOCK_DGRAM)
    entry = {"protocol": "rotctld", kind: f"127.0.0.1:{port}"}
    if kind == "udp":
        entry = {"protocol": "easycomm2", "udp": f"127.0.0.1:{port}", "reply_port": free_port()}
    u = UrcProcess(tmp_path, serve=[entry])
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM if kind == "tcp" else socket.SOCK_DGRAM) as busy:
        busy.bind(("127.0.0.1", port))
        if kind == "tcp":
            busy.listen()
        r = run_urc(u)
    assert r.returncode == 3, r.stdout + r.stderr
    assert f"{kind} 127.0.0.1:{port}" in r.stderr, r.stderr
    assert "control loop in process" not in r.stdout
    made = {p.name for p in u.state_dir.iterdir()} if u.state_dir.exists() else set()
    assert not made & {"state.json", "urc-initialised", "heartbeat"}, made


def test_a_fifo_in_place_of_the_state_file_is_refused_at_once(tmp_path):
    """A FIFO as state.json: `urc run` printed nothing and hung; its control process
    then ignored SIGTERM, kept the lock, and the next start named the wrong holder."""
    u = UrcProcess(tmp_path)
    u.state_dir.mkdir()
    os.mkfifo(u.state_dir / "state.json")
    r = run_urc(u)
    assert r.returncode == 3, r.stdout + r.stderr
    assert "state.json is a FIFO, not a regular file" in r.stderr, r.stderr
    lock = u.state_dir / "urc.lock"
    if lock.exists():  # nobody holds it: no control process was left behind
        with open(lock) as fh:
            fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
    (u.state_dir / "state.json").unlink()
    u.start()  # with the FIFO gone it starts
    assert u.status()["position_known"]
    u.stop()


@pytest.mark.parametrize("protocol, options, said", [
    ("pstrotator", {"reply_port": 12002}, "reply_port is a key of the [[serve]] entry itself"),
    ("urc", {"variant": "xyz"}, "variant must be one of"),
])
def test_a_bad_serve_option_refuses_the_start_before_the_control_process_and_state(tmp_path, protocol, options,
                                                                                    said):
    """Issue 36.15: `options = { reply_port = ... }` on PstRotator was found when the
    servers started, about 20 s in, after the control process; now as a busy port is."""
    entry = {"protocol": protocol, "udp" if protocol == "pstrotator" else "tcp": f"127.0.0.1:{free_port()}",
             "options": options}
    u = UrcProcess(tmp_path, serve=[entry])
    r = run_urc(u)
    assert r.returncode != 0, r.stdout + r.stderr
    assert "serve[0]" in r.stderr and said in r.stderr, r.stderr
    assert "control loop in process" not in r.stdout + r.stderr
    made = {p.name for p in u.state_dir.iterdir()} if u.state_dir.exists() else set()
    assert not made & {"state.json", "urc-initialised", "heartbeat"}, made


def test_config_check_finds_a_bad_serve_option(tmp_path):
    cfg = tmp_path / "urc.toml"
    cfg.write_text('[[serve]]\nprotocol = "pstrotator"\nudp = "127.0.0.1:12000"\noptions = { reply_port = 12002 }\n')
    r = subprocess.run(URC + ["config", "check", str(cfg)], capture_output=True, text=True, timeout=60)
    assert r.returncode != 0 and "reply_port is a key of the [[serve]] entry itself" in r.stderr, r.stdout + r.stderr


def test_a_config_file_holding_a_token_readable_by_others_is_warned_of(tmp_path):
    """Issue 36.8: a configuration file with the API token, readable by others, is said
    by `urc config check` and at `urc run`'s start (here a start refused right after, by
    a bad serve option: the warning comes first)."""
    cfg = tmp_path / "urc.toml"
    cfg.write_text('[api]\ntoken = "s3cret"\n')
    cfg.chmod(0o644)
    r = subprocess.run(URC + ["config", "check", str(cfg)], capture_output=True, text=True, timeout=60)
    assert r.returncode == 0 and f"warning: {cfg} holds the API token" in r.stdout and "chmod 600" in r.stdout, \
        r.stdout + r.stderr
    cfg.chmod(0o600)
    r = subprocess.run(URC + ["config", "check", str(cfg)], capture_output=True, text=True, timeout=60)
    assert "warning" not in r.stdout, r.stdout
    cfg.write_text('[api]\ntoken = "s3cret"\n[[serve]]\nprotocol = "pstrotator"\nudp = "127.0.0.1:12000"\n'
                   'options = { reply_port = 12002 }\n')
    cfg.chmod(0o640)
    r = subprocess.run(URC + ["run", "--config", str(cfg), "--state-dir", str(tmp_path / "state")],
                       capture_output=True, text=True, timeout=60)
    assert r.returncode != 0 and "holds the API token" in r.stderr and "chmod 600" in r.stderr, r.stderr
