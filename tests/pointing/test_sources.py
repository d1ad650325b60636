"""The received-power sources: Hamlib's real rigctld (the dummy rig, model 1), rtl_power's
CSV lines, a TCP line feed and an ADC input; bad, missing, stale and saturated samples
refused with their reason. (None of these exist on main: each test fails there at import.)"""

from __future__ import annotations

import shutil
import socket
import statistics
import subprocess
import threading
import time
from pathlib import Path

import pytest

from urc.pointing.adc import AdcPower
from urc.pointing.line_feed import LineFeed, parse_feed_line
from urc.pointing.rigctld import RigctldStrength, parse_strength
from urc.pointing.rtl_power import RtlPowerLines, parse_line
from urc.pointing.sources import SignalRefused, judge

FIXTURE = Path(__file__).parent / "fixtures" / "rtl_power_sun.csv"
RIGCTLD = shutil.which("rigctld")


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture
def rigctld():
    if RIGCTLD is None:
        pytest.skip("Hamlib's rigctld is not installed (apt install libhamlib-utils)")
    port = free_port()
    proc = subprocess.Popen([RIGCTLD, "-m", "1", "-T", "127.0.0.1", "-t", str(port)],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    for _ in range(100):  # until it listens
        try:
            socket.create_connection(("127.0.0.1", port), timeout=0.1).close()
            break
        except OSError:
            time.sleep(0.05)
    yield port
    proc.terminate()
    proc.wait(5)


def ask(port: int, line: str) -> str:
    """One command on a connection of its own. rigctld (4.5) now and then resets a
    connection that closes right after its answer was read while it still writes: the
    command is sent again on a new one (L commands set a value: asking twice is the same)."""
    for attempt in range(3):
        try:
            with socket.create_connection(("127.0.0.1", port), timeout=2) as s:
                s.sendall(line.encode() + b"\n")
                return s.recv(100).decode()
        except ConnectionResetError:
            if attempt == 2:
                raise
            time.sleep(0.1)
    raise AssertionError("unreachable")


def test_rigctld_strength_from_the_real_dummy_rig(rigctld):
    """The dummy's S-meter wanders by itself (dB over S9, about S0..S3 on 2 m); its STRENGTH
    cannot be set (``L STRENGTH`` answers RPRT -11), but its attenuator takes dB off it:
    20 dB of ATT reads ~20 dB lower, interleaved so the wander cancels."""
    src = RigctldStrength("127.0.0.1", rigctld)
    s = src.read()
    assert s.unit == "dB" and -80 <= s.value <= 20 and s.value == int(s.value)
    assert abs(s.t_s - time.time()) < 5
    assert ask(rigctld, "L STRENGTH 10").strip() == "RPRT -11"
    diffs = []
    for _ in range(3):
        ask(rigctld, "L ATT 0")
        plain = src.read().value
        ask(rigctld, "L ATT 20")
        diffs.append(plain - src.read().value)
    ask(rigctld, "L ATT 0")
    assert 15 <= statistics.median(diffs) <= 25
    src.close()


def test_rigctld_refusals(rigctld):
    with pytest.raises(SignalRefused) as exc:
        RigctldStrength("127.0.0.1", rigctld, ceiling_db=-100).read()  # any reading is over it
    assert exc.value.reason == "saturated"
    with pytest.raises(SignalRefused) as exc:
        RigctldStrength("127.0.0.1", free_port(), timeout_s=0.3).read()
    assert exc.value.reason == "missing"
    with pytest.raises(SignalRefused) as exc:
        parse_strength("RPRT -11")
    assert exc.value.reason == "bad" and "feature not available" in str(exc.value)
    for junk in ("", "S9+10", "-54.5x", "get_level: STRENGTH"):
        with pytest.raises(SignalRefused):
            parse_strength(junk)


def test_rigctld_that_never_answers_is_missing_and_the_late_answer_not_taken():
    srv = socket.socket()
    srv.bind(("127.0.0.1", 0))
    srv.listen(1)
    port = srv.getsockname()[1]
    try:
        src = RigctldStrength("127.0.0.1", port, timeout_s=0.2)
        with pytest.raises(SignalRefused) as exc:
            src.read()
        assert exc.value.reason == "missing"
        assert src._sock is None  # dropped: a late "-54" cannot answer the next question
    finally:
        srv.close()


def test_rtl_power_fixture_lines_parsed_and_malformed_ones_refused():
    now_s = parse_line("2024-06-21, 11:59:05, 1420000000, 1421000000, 3906.25, 120, -1").t_s
    src = RtlPowerLines(max_age_s=30.0, clock=lambda: now_s)
    good = src.feed(FIXTURE.read_text())
    assert len(good) == 3 and src.bad_lines == 5
    s = src.read()
    assert s.unit == "dB" and s.t_s == good[-1].t_s
    # the mean of the bins as powers, in dB: a little above the mean of the dB
    assert -38.56 < s.value < -38.5
    line = parse_line("2024-06-21, 11:58:00, 144000000, 146000000, 7812.50, 20, -41.2, -40.8")
    assert (line.hz_low, line.hz_high, line.hz_step, line.samples, line.db) == (144e6, 146e6, 7812.5, 20, (-41.2, -40.8))


@pytest.mark.parametrize("bad", [
    "not rtl_power output",
    "2024-06-21, 11:58:30, 1420000000, 1421000000, 3906.25, 120",          # no dB
    "2024-06-21, 25:58:40, 1420000000, 1421000000, 3906.25, 120, -40",     # no such hour
    "2024-06-21, 11:58:50, 1421000000, 1420000000, 3906.25, 120, -40",     # low above high
    "2024-06-21, 11:58:20, 1420000000, 1421000000, 3906.25, 120, -40, nan",
    "2024-06-21, 11:58:20, 1420000000, 1421000000, 3906.25, 0, -40",       # no samples
    "2024-06-21, 11:58:20, 1420000000, 1421000000, x, 120, -40",
])
def test_rtl_power_malformed_line_refused_as_bad(bad):
    with pytest.raises(SignalRefused) as exc:
        parse_line(bad)
    assert exc.value.reason == "bad"


def test_rtl_power_stale_missing_and_saturated():
    src = RtlPowerLines(max_age_s=30.0, utc=True, clock=lambda: 1718971200.0 + 3600)
    with pytest.raises(SignalRefused) as exc:
        src.read()
    assert exc.value.reason == "missing"
    src.feed("2024-06-21, 12:00:00, 1420000000, 1421000000, 3906.25, 120, -40.0\n")
    with pytest.raises(SignalRefused) as exc:  # an hour old: rtl_power stopped
        src.read()
    assert exc.value.reason == "stale"
    fresh = RtlPowerLines(utc=True, ceiling_db=0.0, clock=lambda: 1718971205.0)
    fresh.feed("2024-06-21, 12:00:00, 1420000000, 1421000000, 3906.25, 120, -40.0, 0.0\n")
    with pytest.raises(SignalRefused) as exc:
        fresh.read()
    assert exc.value.reason == "saturated"
    # a line cut in two arrives whole
    part = RtlPowerLines(utc=True, clock=lambda: 1718971205.0)
    part.feed("2024-06-21, 12:00:00, 1420000000, 14210")
    part.feed("00000, 3906.25, 120, -40.0\n")
    assert part.read().value == pytest.approx(-40.0)


def test_line_feed_over_tcp_with_bad_and_stale_samples():
    srv = socket.socket()
    srv.bind(("127.0.0.1", 0))
    srv.listen(1)
    port = srv.getsockname()[1]
    conns: list[socket.socket] = []
    accepted = threading.Thread(target=lambda: conns.append(srv.accept()[0]))
    accepted.start()
    now = [1000.0]
    feed = LineFeed("127.0.0.1", port, max_age_s=2.0, clock=lambda: now[0])
    with pytest.raises(SignalRefused) as exc:
        feed.read()
    assert exc.value.reason == "missing"
    accepted.join(5)
    conn = conns[0]
    conn.sendall(b"-12.5 dB\n")

    def wait_read():
        for _ in range(100):
            try:
                return feed.read()
            except SignalRefused as e:
                if e.reason != "missing":
                    raise
            time.sleep(0.01)
        raise AssertionError("no sample")
    s = wait_read()
    assert (s.value, s.unit, s.t_s) == (-12.5, "dB", 1000.0)
    conn.sendall(b"999.0 0.25 V\nhello\n")
    time.sleep(0.1)
    s = feed.read()
    assert (s.t_s, s.value, s.unit) == (999.0, 0.25, "V")
    assert feed.bad_lines == 1 and "hello" in str(feed.last_error)
    now[0] = 1010.0  # nothing new for 11 s: the feed stopped
    with pytest.raises(SignalRefused) as exc:
        feed.read()
    assert exc.value.reason == "stale"
    feed.close()
    conn.close()
    srv.close()


def test_feed_line_forms():
    assert parse_feed_line("3.5", arrived_s=7.0, default_unit="dB") == (7.0, 3.5, "dB")
    assert parse_feed_line("1700000000.5,-80 dBm", arrived_s=7.0, default_unit="dB") == (1700000000.5, -80.0, "dBm")
    for bad in ("", "x", "1 2 3", "1 2 furlongs"):
        with pytest.raises(SignalRefused):
            parse_feed_line(bad, arrived_s=0.0, default_unit="dB")


def test_adc_input_as_a_calibrated_detector():
    """(urc's own ADC chips as sources: tests/hardware/test_gpio_adc_power.py)"""
    # a log detector (AD8307: 25 mV/dB, -84 dBm at 0 V) as a callable
    det = AdcPower(lambda: 1.5, to_power=lambda v: (v / 0.025 - 84.0, "dBm"), clock=lambda: 1.0)
    assert det.read().value == pytest.approx(-24.0) and det.read().unit == "dBm"
    with pytest.raises(SignalRefused) as exc:
        AdcPower(lambda: float("nan")).read()
    assert exc.value.reason == "bad"


def test_judge_stale():
    with pytest.raises(SignalRefused) as exc:
        judge(10.0, -3.0, "dB", now_s=20.0, max_age_s=5.0)
    assert exc.value.reason == "stale" and "10.0 s old" in str(exc.value)
    assert judge(10.0, -3.0, "dB", now_s=14.0, max_age_s=5.0).value == -3.0
