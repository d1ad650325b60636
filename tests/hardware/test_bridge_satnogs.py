"""The bridge's ``satnogs`` dialect: its codec byte by byte, the emulated SatNOGS firmware
(urc.testing.satnogs_firmware, written from the firmware's source) and urc's rotator
driving it on the virtual clock: status and errors shown, no target while it reports an
error, homing (its silence) shown as homing and ended by its first answer."""

from __future__ import annotations

import pytest

from urc.model.messages import ControllerHome
from urc.model.effects import ask
from hypothesis import given
from hypothesis import strategies as st

from urc.clock import VirtualClock
from urc.errors import CommandRejected
from urc.hardware.bridge import BridgeClient, ClientOptions, bridge_axes, make_dialect
from urc.hardware.bridge.dialects import ControllerError, ControllerStatus, ReplyError
from urc.hardware.interfaces import Hardware
from urc.wire import satnogs as sn
from urc.testing.bridged_rig import SimLink
from urc.testing.satnogs_firmware import SatnogsFirmware

D = make_dialect("satnogs")


# ------------------------------------------------------------------ codec, byte by byte
REPLIES = [(D.poll(), b"AZ123.4 EL-0.5\n", (123.4, -0.5)),
           (D.stop(), b"AZ0.0 EL90.0\n", (0.0, 90.0)),
           (D.home(False), b"AZ359.9 EL180.0\n", (359.9, 180.0)),
           (D.status(), b"GS4\n", ControllerStatus(4, "pointing", False)),
           (D.status(), b"GS8\n", ControllerStatus(8, "error", True)),
           (D.error_query(), b"GE4\n", ControllerError(4, sn.ERROR_TEXT[4])),
           (D.error_query(), b"GE16\n", ControllerError(16, sn.ERROR_TEXT[16]))]


@pytest.mark.parametrize("ex, data, value", REPLIES)
def test_each_reply_is_framed_at_its_last_byte_and_parsed_whole(ex, data, value):
    for i in range(len(data)):
        assert ex.reply.complete(data[:i]) is None, (data, i)
    n = ex.reply.complete(data + b"AZ1.0 EL2.0\n")
    assert n == len(data)
    assert ex.parse(data) == value
    assert ex.parse(data[:-1] + b"\r\n") == value or data.startswith(b"G")   # (a CR before it is harmless)


def test_requests_are_the_forms_the_firmware_matches():
    """easycomm.h:64-66 wants ``AZ EL`` as the first five bytes; ``SA SE`` likewise."""
    assert D.poll().request == b"AZ EL\n"
    assert D.goto(123.45, 7.0).request == b"AZ123.5 EL7.0\n"
    assert D.goto(-3.0, 181.0).request == b"AZ-3.0 EL181.0\n"
    assert D.stop().request == b"SA SE\n"
    assert (D.status().request, D.error_query().request) == (b"GS\n", b"GE\n")
    assert D.home(False).request == b"RESET\n" and D.home(True).request == b"RB\n"
    assert D.home(True).reply is None                   # a reboot answers nothing
    assert D.move("az", 1, 1.0) is None                 # no ML..MD: a jog is a goto
    assert D.az_modulo_deg is None                      # step counts, not compass azimuth


@pytest.mark.parametrize("ex, data", [(D.poll(), b"AZ123.4\n"), (D.poll(), b"AZ123.45 EL1.0\n"),
                                      (D.poll(), b"AZ1.0 EL2.0 junk\n"), (D.poll(), b"GS1\n"),
                                      (D.poll(), b"AZ1.0  EL2.0\n"), (D.status(), b"GS\n"),
                                      (D.status(), b"GE1\n"), (D.status(), b"GS1x\n"),
                                      (D.error_query(), b"GE-1\n")])
def test_anything_else_is_refused(ex, data):
    with pytest.raises(ReplyError):
        ex.parse(data)


@given(st.binary(max_size=40))
def test_fuzzed_replies_raise_only_reply_errors(data):
    for ex in (D.poll(), D.status(), D.error_query()):
        try:
            ex.parse(data)
        except ReplyError:
            pass


# ------------------------------------------------------------------ the emulated firmware
def test_firmware_quirks_from_its_source():
    fw = SatnogsFirmware(phys_deg=(10.0, 5.0))
    fw.feed(b"AZ EL\nGS\nGE\nVE\n")
    assert fw.take_output() == b"AZ10.0 EL5.0\nGS1\nGE1\nVESatNOGS-v2.2\n"
    fw.feed(b"AZ\n")                                     # Hamlib 4.6's query: a set to az 0
    fw.advance(2.0)
    assert fw.take_output() == b"" and fw.position_deg()[0] < 10.0
    fw.feed(b"RST\n")                                    # the firmware hangs: the watchdog
    fw.advance(2.1)
    fw.feed(b"AZ EL\nGS\nGE\n")
    assert fw.take_output() == b"GS8\nGE16\n"            # only GS/GE (and RB) answered
    fw.feed(b"RB\n")
    fw.advance(2.1)                                      # restarted: it homes, silent
    fw.feed(b"GS\n")
    fw.advance(0.1)
    assert fw.state == "homing" and fw.take_output() == b""


# ------------------------------------------------------------------ urc on the virtual clock
class FirmwareSession:
    """The firmware as SimLink's device: what it wrote before a request is discarded (the
    link flushes its input before each exchange)."""

    def __init__(self, fw: SatnogsFirmware):
        self.fw = fw

    def receive(self, data: bytes) -> list[bytes]:
        self.fw.take_output()
        self.fw.feed(data)
        return [self.fw.take_output()]


class Rig:
    def __init__(self, tmp_path, **fw_args):
        from urc.assembly import settings_from_config
        from urc.config import Config
        from urc.persistence import StateStore
        from urc.rotator.rotator import Rotator

        self.clock = VirtualClock(0.0)
        fw_args.setdefault("home_delay_s", 3.0)
        self.fw = SatnogsFirmware(**fw_args)
        cfg = {"rotator": {"profile": "satnogs-v3"},
               "hardware": {"backend": "bridge", "bridge": {"protocol": "satnogs", "serial": "/dev/null"}}}
        settings = settings_from_config(Config.from_dict(cfg))
        self.client = BridgeClient(make_dialect("satnogs"), ClientOptions())
        self.link = SimLink(self.client, FirmwareSession(self.fw), baud=19200)
        self.az, el = bridge_axes(self.client, self.clock)
        for _ in range(100):
            self.step()
            if self.client._pos is not None:
                break
        self.rot = Rotator(settings, Hardware("bridge", self.az, el), self.clock,
                           StateStore(tmp_path / "state.json", durable=False))

    def step(self):
        self.clock.advance(0.02)
        self.fw.advance(0.02)
        self.link.step(self.clock.now_s())

    def run(self, duration_s: float, until=None):
        s = self.rot.status()
        for _ in range(round(duration_s / 0.02)):
            self.step()
            s = self.rot.tick()
            if until is not None and until(s):
                break
        return s

    def sent(self, since: int = 0) -> list[bytes]:
        return [req for _t, req in self.link.sent[since:]]


def settled(s) -> bool:
    return not s.moving and s.az.mode == "holding" and s.el.mode == "holding"


def test_goto_and_stop_through_the_firmware(tmp_path):
    rig = Rig(tmp_path, phys_deg=(0.0, 0.0))
    rig.rot.goto(100.0, 45.0)
    s = rig.run(30.0, until=settled)
    assert settled(s) and not s.faults, (s.faults, s.events[-3:])
    assert rig.fw.true_deg() == pytest.approx((100.0, 45.0), abs=0.1)
    assert s.az_deg == pytest.approx(100.0, abs=0.15) and s.el_deg == pytest.approx(45.0, abs=0.15)
    assert b"AZ100.0 EL45.0\n" in rig.sent()
    assert rig.client.counts["statuses"] > 0 and rig.client.counts["garbage"] == 0
    rig.rot.goto(10.0, 10.0)
    rig.run(2.0)
    mark = len(rig.link.sent)
    rig.rot.stop()
    rig.run(8.0)      # it brakes past that point and comes back (AccelStepper's moveTo)
    assert b"SA SE\n" in rig.sent(mark)
    # SA SE made its setpoints where it was then (easycomm.h:144-145): it ends there
    assert rig.fw.true_deg() == pytest.approx(tuple(rig.fw.setpoint), abs=0.01)
    assert 10.5 < rig.fw.true_deg()[0] < 95.0                          # stopped mid-move
    assert not [r for r in rig.sent(mark) if r.startswith(b"AZ") and r != b"AZ EL\n"]   # no target after it


def test_an_error_it_reports_is_a_fault_in_its_words_and_no_target_goes_out(tmp_path):
    """A homing error (its endstop never found): urc latches a fault that says so, refuses
    motion with that reason, and sends no target however its faults are cleared, while
    the controller still reports the error."""
    rig = Rig(tmp_path, phys_deg=(5.0, 5.0), seek_deg=(10.0, 10.0))
    with_fw = rig.fw
    with_fw.break_endstop("az")
    rig.client.request_home()
    s = rig.run(20.0, until=lambda s: any(f.kind == "driver" for f in s.faults))
    driver = [f for f in s.faults if f.kind == "driver"]
    assert driver and "the controller reports homing error: an endstop was not found" in driver[0].reason, s.faults
    assert "(status 8, error 4)" in driver[0].reason
    mark = len(rig.link.sent)
    with pytest.raises(CommandRejected) as exc:
        rig.rot.goto(50.0, 20.0)
    assert "homing error" in str(exc.value)
    rig.rot.clear_faults()
    rig.client.post("az", 50.0)       # (straight to the client: past the rotator's refusal)
    rig.client.post("el", 20.0)
    rig.run(3.0)
    assert not any(req.startswith(b"AZ") and req != b"AZ EL\n" for req in rig.sent(mark)), rig.sent(mark)
    assert rig.client.counts["withheld"] >= 1
    assert any(f.kind == "driver" for f in rig.rot.status().faults)   # latched again


def test_homing_is_shown_and_ends_at_its_first_answer(tmp_path):
    """RESET: the firmware homes without reading input; urc shows the axes unreadable
    because it homes (not a lost link), sends nothing but a status question now and
    then, and takes up again at the home position once it answers."""
    rig = Rig(tmp_path, phys_deg=(4.0, 3.0), home_delay_s=5.0)   # (time to brake and come back)
    rig.rot.goto(6.0, 5.0)
    rig.run(10.0, until=settled)
    ask(rig.rot, ControllerHome())    # (what the API's POST /api/calibration/controller-home asks)
    s = rig.run(3.0, until=lambda s: bool(s.faults))
    assert rig.fw.state == "homing"
    assert "controller homing" in s.az.sensor_error and "until it has found its endstops" in s.az.sensor_error
    assert {f.kind for f in s.faults} == {"sensor_dead"}
    mark = len(rig.link.sent)
    s = rig.run(4.0)      # its status question at 3 s goes unanswered: still homing, no failure
    assert rig.fw.state == "homing" and "controller homing (4 s so far)" in s.az.sensor_error, s.az.sensor_error
    s = rig.run(20.0, until=lambda s: not s.faults)
    assert not s.faults and rig.fw.state == "run" and rig.fw.homings == 1, (s.faults, rig.fw.state)
    assert any("link fault cleared" in e for e in s.events)
    during = rig.sent(mark)
    assert set(during[:2]) <= {b"GS\n"}, during                  # silence meant homing, no poll flood
    assert rig.client.counts["reconnects"] == 0
    assert s.az_deg == pytest.approx(0.0, abs=0.2) and s.el_deg == pytest.approx(0.0, abs=0.2)
    assert rig.fw.true_deg() == pytest.approx((0.0, 0.0), abs=0.05)


def test_a_rotator_without_a_controller_to_home_refuses_to(bench):
    with pytest.raises(CommandRejected, match="no controller to home"):
        ask(bench("g5500").rot, ControllerHome())


def test_a_controller_that_reports_an_error_is_rebooted_to_home(tmp_path):
    """RESET cannot clear its homing error (ino:100): homing it then is RB."""
    rig = Rig(tmp_path, phys_deg=(5.0, 5.0), seek_deg=(10.0, 10.0))
    rig.fw.break_endstop("el")
    rig.client.request_home()
    rig.run(20.0, until=lambda s: rig.client.controller_fault() != "")
    rig.fw.break_endstop("el", False)          # the wire mended
    mark = len(rig.link.sent)
    rig.client.request_home()
    rig.run(25.0, until=lambda s: rig.fw.homings == 2 and rig.fw.state == "run" and not rig.client.homing())
    assert b"RB\n" in rig.sent(mark) and b"RESET\n" not in rig.sent(mark)
    assert rig.client.controller_fault() == ""
