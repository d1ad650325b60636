"""State records: written off the control tick, retried when they fail, and motion held
to what the record on disk promises (issue 9.2, 9.7)."""

import errno
import threading

import pytest

from conftest import bounded
from urc.assembly import build_rotator
from urc.clock import RealClock
from urc.config import Config
from urc.errors import CommandRejected
from urc.persistence import StateStore


class GatedStore(StateStore):
    """A disk whose writes block until the test lets them through."""

    def __init__(self, path):
        super().__init__(path, durable=False)
        self.gate = threading.Event()
        self.entered = threading.Event()

    def save(self, payload):
        self.entered.set()
        assert self.gate.wait(10.0), "never released"
        super().save(payload)


class FailingStore(StateStore):
    """A full disk until ``full`` is cleared."""

    def __init__(self, path):
        super().__init__(path, durable=False)
        self.full = False
        self.attempts = 0

    def save(self, payload):
        self.attempts += 1
        if self.full:
            raise OSError(errno.ENOSPC, "No space left on device")
        super().save(payload)


def test_background_writer_never_blocks_the_caller(tmp_path):
    from urc.rotator.state_writer import StateWriter
    store = GatedStore(tmp_path / "state.json")
    w = StateWriter(store, background=True)
    w.submit({"n": 1})
    assert store.entered.wait(5.0)
    w.submit({"n": 2})  # the disk is stuck in the first write: this must not wait
    w.submit({"n": 3})  # and only the newest waits behind it
    rep = w.report()
    assert rep.pending and rep.durable is None
    store.gate.set()
    assert w.flush(5.0)
    assert w.report().durable == {"n": 3} and store.load() == {"n": 3}
    assert w.report().writes == 2
    w.close()


def test_failed_write_is_retried_and_reported(tmp_path):
    from urc.rotator.state_writer import StateWriter
    store = FailingStore(tmp_path / "state.json")
    t = [0.0]
    w = StateWriter(store, background=False, now_s=lambda: t[0], retry_s=1.0)
    store.full = True
    w.submit({"n": 1})
    rep = w.report()
    assert "No space" in rep.error and rep.pending and rep.durable is None
    t[0] = 0.5
    w.report()
    assert store.attempts == 1, "retries are paced"
    store.full = False
    t[0] = 1.1
    rep = w.report()
    assert rep.error == "" and not rep.pending and rep.durable == {"n": 1}
    assert store.load() == {"n": 1}


def test_tick_does_not_wait_for_a_stuck_disk(tmp_path):
    """Issue 9.7: a slow fsync must not delay the control tick (writes go to a thread)."""
    from urc.rotator.state_writer import StateWriter
    cfg = Config.from_dict({"rotator": {"profile": "tartu-urc"}, "hardware": {"sim": {"wind": False}}})
    rot = build_rotator(cfg, RealClock(), tmp_path / "state", durable_state=False)
    store = GatedStore(rot.store.path)
    rot.store = store
    rot._records.writer = StateWriter(store, background=True)
    rot.goto(90.0, 20.0)
    rot.tick()  # the goto starts: a record is handed to the writer thread
    assert store.entered.wait(5.0), "a record is being written"
    for _ in range(5):
        rot.tick()  # returns although the disk write is still stuck
    assert not store.gate.is_set()
    store.gate.set()
    rot.shutdown()
    rot.hw.close()


class DiskFull:
    """Make the rotator's own state store fail with ENOSPC while ``full`` is set."""

    def __init__(self, store):
        self.full = False
        real_save = store.save

        def save(payload):
            if self.full:
                raise OSError(errno.ENOSPC, "No space left on device")
            real_save(payload)
        store.save = save


@pytest.mark.parametrize("profile", ["tartu-urc", "bigras"])
def test_full_disk_stops_motion_shows_a_fault_and_recovers(bench, profile):
    """Issue 9.2: no silent drive on a full disk, and no 150 deg old record trusted later."""
    b = bench(profile, exact=True)
    b.rot.goto(30.0, 10.0)
    b.settle()
    store = DiskFull(b.rot.store)
    store.full = True
    start = b.rot.status().az.pos_deg
    b.rot.goto(180.0, 10.0)
    b.run(30.0)
    s = b.rot.status()
    assert "No space" in s.state_error
    assert any(f.kind == "state" for f in s.faults), s.faults
    assert abs(s.az.pos_deg - start) < 3.0, "the axis stays where the record on disk says"
    with pytest.raises(CommandRejected, match="fault"):
        b.rot.goto(100.0, 10.0)
    # space comes back: the retried write lands, the fault clears itself
    store.full = False
    b.run(2.0)
    s = b.rot.status()
    assert s.state_error == "" and not s.faults
    b.rot.goto(180.0, 10.0)
    b.settle()
    # a kill now restarts where the antenna is, not where it stood before
    b = b.restart(clean=False)
    s = b.rot.status()
    assert s.position_known
    assert s.az.pos_deg == pytest.approx(s.sim_truth["az"]["deg"], abs=1.0)


def test_failing_disk_while_moving_never_restarts_known_far_away(bench):
    b = bench("tartu-urc", exact=True)
    store = DiskFull(b.rot.store)
    b.rot.goto(200.0, 10.0)
    b.run(2.0)
    store.full = True
    b.run(60.0)
    b = b.restart(clean=False)
    assert bounded(b.rot.status(), "az", slack_deg=0.5)


@pytest.mark.parametrize("how", ["goto", "move", "park"])
def test_moving_commands_are_refused_while_the_state_cannot_be_saved(bench, how):
    """Issue 21: goto answered ok while the state fault (a full disk) blocked all
    motion: with the fault cleared but the disk still full, every moving command is
    refused (HTTP 409 / the protocol's error), not accepted and then held."""
    b = bench("tartu-urc", exact=True)
    store = DiskFull(b.rot.store)
    store.full = True
    b.rot.goto(100.0, 10.0)
    b.run(5.0)
    assert any(f.kind == "state" for f in b.rot.status().faults)
    b.rot.clear_faults()
    b.run(1.0)
    s = b.rot.status()
    assert not s.faults and "No space" in s.state_error
    start = s.az.pos_deg
    with pytest.raises(CommandRejected, match="state not saved") as refused:
        {"goto": lambda: b.rot.goto(200.0, 10.0), "move": lambda: b.rot.move("az", +1),
         "park": b.rot.park}[how]()
    assert refused.value.reason == "state"
    b.run(3.0)
    assert abs(b.rot.status().az.pos_deg - start) < 0.5
    store.full = False  # space again: the retried write lands and motion is allowed
    b.run(3.0)
    assert b.rot.status().state_error == ""
    b.rot.goto(120.0, 10.0)


def answer(b, request, tick=True):
    """What the control process replies to ``request``: ControlServer._answer on a
    thread of its own (as the control process's reading thread runs it), while this one
    ticks the bench's loop on virtual time (``tick=False``: no tick, the reply must not wait for one). Returns
    the reply's value or raises its error."""
    from urc.link import codec
    from urc.model.messages import Envelope
    from urc.link.control_process import ControlServer
    from urc.link.client import exception_from_wire

    class Conn:
        def __init__(self):
            self.sent = []

        def send_bytes(self, data):
            self.sent.append(codec.loads(data))
    server = ControlServer(Conn(), None, b.rot.store.path.parent, [])
    server.rot = b.rot
    thread = threading.Thread(target=server._answer, args=(Envelope(1, None, request),), daemon=True)
    thread.start()
    for _ in range(10_000):  # (a reply that never comes fails below, not hangs)
        if not thread.is_alive():
            break
        if tick:
            b.run(0.02)
        thread.join(0.001)
    assert not thread.is_alive(), "no reply"
    (kind, reply), = server.conn.sent
    assert kind == "reply"
    if reply.outcome == "error":
        raise exception_from_wire(reply.value)
    return reply.value


def test_the_first_goto_after_the_disk_fails_standing_is_refused_not_answered_ok(bench):
    """Issue 36.19: standing still, urc writes nothing, so a disk that has just failed is
    not known; the next goto was answered ok, then its first record failed, the state
    fault latched and nothing moved. Now its reply waits for that record: refused with
    reason "state", and the refused goto never flies once the disk works again."""
    from urc.model.messages import Goto

    b = bench("tartu-urc", exact=True)
    b.rot.goto(30.0, 10.0)
    b.settle()
    b.run(30.0)                       # standing: the record on disk is up to date
    store = DiskFull(b.rot.store)
    store.full = True
    start = b.rot.status().az.pos_deg
    with pytest.raises(CommandRejected) as refused:
        answer(b, Goto(200.0, 10.0))  # the disk's failure is not known yet
    assert refused.value.reason == "state" and "No space" in str(refused.value)
    b.run(10.0)
    s = b.rot.status()
    assert abs(s.az.pos_deg - start) < 0.5, "nothing moves"
    assert [f.kind for f in s.faults] == ["state"] and "No space" in s.state_error
    with pytest.raises(CommandRejected) as again:  # (the state fault latched: "state" too)
        answer(b, Goto(200.0, 10.0))
    assert again.value.reason == "state"
    store.full = False                # space again: the fault clears itself ...
    b.run(5.0)
    s = b.rot.status()
    assert not s.faults and s.state_error == ""
    assert abs(s.az.pos_deg - start) < 0.5, "... and the refused goto does not fly"
    answer(b, Goto(200.0, 10.0))
    b.settle()
    assert b.rot.status().az.pos_deg == pytest.approx(200.0, abs=1.0)


def test_a_gotos_reply_comes_once_its_first_record_is_on_disk(bench, monkeypatch):
    """The reply to a goto from standing waits for the record written ahead of its
    motion (off the tick, on the thread that runs the command); a card slower than
    FIRST_RECORD_WAIT_S gets an ok all the same, and the goto flies once its record
    lands. A status read never waits."""
    from urc.model.messages import Goto, OvershootQuery
    from urc.link import control_process
    from urc.rotator.state_writer import StateWriter

    b = bench("tartu-urc", exact=True)
    b.run(1.0)
    store = GatedStore(b.rot.store.path)
    b.rot._records.writer = StateWriter(store, background=True)
    monkeypatch.setattr(control_process, "FIRST_RECORD_WAIT_S", 60.0)
    reply: list = []
    waiting = threading.Thread(target=lambda: reply.append(answer(b, Goto(20.0, 10.0))), daemon=True)
    waiting.start()
    for _ in range(3000):
        if store.entered.wait(0.01) or not waiting.is_alive():
            break
    assert waiting.is_alive() and not reply, "no reply before the record is on disk"
    assert store.entered.is_set(), "the goto's first record is being written"
    # (a query does not wait, though the disk is stuck)
    assert answer(b, OvershootQuery("az"), tick=False) >= 0.0
    store.gate.set()
    waiting.join(30.0)
    assert reply and reply[0], "ok, with its route"
    assert store.load()["axes"]["az"]["moving"]
    # a card slower than the bound: ok all the same; held until its record lands
    b.settle()
    store.gate.clear()
    store.entered.clear()
    monkeypatch.setattr(control_process, "FIRST_RECORD_WAIT_S", 0.2)
    start = b.rot.status().az.pos_deg
    assert answer(b, Goto(60.0, 10.0))
    assert store.entered.is_set() and abs(b.rot.status().az.pos_deg - start) < 0.5
    store.gate.set()
    b.settle()
    assert b.rot.status().az.pos_deg == pytest.approx(60.0, abs=1.0)
    b.rot._records.writer.close()


def test_the_readme_names_the_refusals_a_failing_disk_gives(bench):
    """Issue 36.19: the README said a refusal while writes fail is 409 `reason: state`;
    with the state fault latched it was `fault` (and `state` once that fault was cleared
    by hand). Now it is `state` both ways, as the README says."""
    from pathlib import Path

    readme = (Path(__file__).resolve().parents[2] / "README.md").read_text()
    b = bench("tartu-urc", exact=True)
    store = DiskFull(b.rot.store)
    store.full = True
    b.rot.goto(100.0, 10.0)
    b.run(5.0)
    reasons = []
    for _ in range(2):
        with pytest.raises(CommandRejected) as refused:
            b.rot.goto(200.0, 10.0)
        reasons.append(refused.value.reason)
        b.rot.clear_faults()
        b.run(1.0)
    assert reasons == ["state", "state"]
    said = " ".join(readme.split())
    assert "While writes fail a moving command is refused with HTTP 409 `reason: state`" in said
    assert "whether that fault is latched (its kind `state` in `faults`" in said
    assert "or was cleared by hand" in said


def test_urc_run_answers_the_first_goto_after_the_disk_fails_with_409_state(urc_processes):
    """Issue 36.19 end to end: a real ``urc run`` standing at park, its state dir no longer
    taking writes (``state.json.tmp`` a directory), answers the next goto on the web API
    with HTTP 409 ``reason: state``, not ``{"ok": true}``."""
    u = urc_processes().start()
    (u.state_dir / "state.json.tmp").mkdir()
    r = u.post("/api/goto", {"az_deg": 60.0, "el_deg": 40.0})
    assert r.status_code == 409, r.text
    assert r.json()["reason"] == "state" and "directory" in r.json()["error"]
    s = u.wait(lambda s: s["faults"])
    assert [f["kind"] for f in s["faults"]] == ["state"]


def test_a_goto_while_moving_with_its_records_on_disk_answers_without_a_tick(bench, monkeypatch):
    """The first-record wait is for a command from standing, when nothing has been
    written for a while: a P while the antenna drives with its newest record on disk
    (Gpredict's every second while tracking) answers at once, no tick needed; a failed
    write still makes the next one wait (and be refused)."""
    from urc.link import control_process
    from urc.model.messages import Goto

    monkeypatch.setattr(control_process, "FIRST_RECORD_WAIT_S", 60.0)  # (a wait would show)
    b = bench("tartu-urc", exact=True)
    b.rot.goto(200.0, 10.0)
    b.run(2.0)                          # on its way, records written ahead of it
    assert b.rot.status().moving
    assert answer(b, Goto(210.0, 10.0), tick=False), "ok at once, without a tick"
    store = DiskFull(b.rot.store)
    store.full = True
    for _ in range(500):                # until a record fails
        b.run(0.02)
        if b.rot.status().state_error:
            break
    assert "No space" in b.rot.status().state_error
    with pytest.raises(CommandRejected) as refused:
        answer(b, Goto(220.0, 10.0))
    assert refused.value.reason == "state"
