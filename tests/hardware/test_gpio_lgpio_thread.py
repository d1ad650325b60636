"""The edge parts fed through the real lgpio module's notification thread.

lgpio (0.2.2, ``lgpio.py``) makes a FIFO ``.lgd-nfy<N>`` in the current directory at
import and runs one thread that reads 16-byte reports from it (``struct 'QBBBBI'``:
timestamp ns, chip, gpio, level, flags, padding) and calls each matching callback in
turn. The kernel side needs a Pi; here the test writes the reports into that FIFO, and
gpiozero's real LGPIOFactory/LGPIOPin register the callbacks, with only lgpio's calls
that touch /dev/gpiochip (claim, read, mode) replaced. So the late, bunched delivery
and the thread a raising callback kills are lgpio's own.

Each case runs in a subprocess of its own (cwd = a temporary directory): importing
lgpio creates the FIFO there and starts the thread for the life of the process.
"""

from __future__ import annotations

import importlib.util
import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

pytestmark = pytest.mark.skipif(importlib.util.find_spec("lgpio") is None,
                                reason="lgpio not installed (pip install lgpio; x86_64 and aarch64 wheels)")

PRELUDE = textwrap.dedent('''
    import json, os, struct, sys, time
    import lgpio
    from gpiozero.pins.lgpio import LGPIOFactory

    live = {}                                   # what a gpio_read would return now
    for name in ("gpiochip_open",):
        setattr(lgpio, name, lambda chip: 0)
    for name in ("gpio_claim_input", "gpio_claim_alert", "gpio_free", "gpiochip_close"):
        setattr(lgpio, name, lambda *a, **k: 0)
    lgpio.gpio_claim_output = lambda h, g, level=0, lFlags=0: live.__setitem__(g, level)
    lgpio.gpio_get_mode = lambda h, g: 0
    lgpio.gpio_read = lambda h, g: live.get(g, 1)
    lgpio.gpio_write = lambda h, g, v: live.__setitem__(g, int(v))
    LGPIOFactory._get_revision = lambda self: 0xC03111          # a Pi 4 B
    factory = LGPIOFactory(chip=0)
    fifo = os.open(".lgd-nfy{}".format(lgpio._notify_thread._notify), os.O_WRONLY)
    t_ns = [1_000_000_000]

    def report(gpio, level, dt_us=100):
        t_ns[0] += dt_us * 1000
        return struct.pack("QBBBBI", t_ns[0], 0, gpio, level, 0, 0)

    def send(reports):
        os.write(fifo, b"".join(reports))

    def wait(cond, timeout_s=20.0):
        end = time.monotonic() + timeout_s
        while time.monotonic() < end:
            if cond():
                return True
            time.sleep(0.01)
        return False

    out = {}
''')


def run_case(tmp_path: Path, body: str) -> dict:
    script = PRELUDE + textwrap.dedent(body) + "\nprint(json.dumps(out))\n"
    env = dict(os.environ)
    env.pop("LG_WD", None)
    r = subprocess.run([sys.executable, "-c", script], cwd=tmp_path, env=env, capture_output=True,
                       text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    return json.loads(r.stdout.strip().splitlines()[-1])


FORWARD = [(0, 1), (1, 1), (1, 0), (0, 0)]       # (A, B) levels, x4 forward order


def test_quadrature_counts_from_the_reports_levels_however_late(tmp_path):
    """1000 forward edges, sent in bursts while the live levels read something else
    entirely (the callbacks run late): the count is exact, no error."""
    out = run_case(tmp_path, '''
        from urc.hardware.gpio.pins import PinQuadrature
        q = PinQuadrature(factory, 17, 27)           # live A=B=1 at start: state 11
        start = [(1, 1), (1, 0), (0, 0), (0, 1)]     # forward from 11
        reports, prev = [], (1, 1)
        for k in range(1000):
            a, b = start[(k + 1) % 4]
            reports.append(report(17, a) if a != prev[0] else report(27, b))
            prev = (a, b)
        live[17], live[27] = 0, 1                    # the pins are elsewhere by now
        for i in range(0, 1000, 37):                 # bursts of 37 reports, some split
            send(reports[i:i + 37])
        out["delivered"] = wait(lambda: q.count() == 1000)
        out["count"], out["errors"] = q.count(), q.errors()
    ''')
    assert out == {"delivered": True, "count": 1000, "errors": 0}


def test_a_lost_report_is_an_error_not_a_guess(tmp_path):
    out = run_case(tmp_path, '''
        from urc.hardware.gpio.pins import PinQuadrature
        q = PinQuadrature(factory, 17, 27)           # 11
        send([report(17, 1)])                        # A "rises" again: its fall was lost
        send([report(27, 0)])                        # 11 -> 10: +1
        out["delivered"] = wait(lambda: q.count() == 1)
        out["count"], out["errors"] = q.count(), q.errors()
    ''')
    assert out == {"delivered": True, "count": 1, "errors": 1}


def test_pulse_debounce_judges_the_reports_timestamps(tmp_path):
    """Reed pulses that bounce on closing and on opening count once each, with the
    reports all delivered together long after (their timestamps, not the arrival,
    decide). lgpio reports both edges (lgPthAlerts.c: a falling-only request would get
    the last falling edge of each opening burst, half a period after the pulse)."""
    out = run_case(tmp_path, '''
        from urc.hardware.gpio.pins import PinPulseCounter
        c = PinPulseCounter(factory, 22, debounce_s=0.005)
        reports = []
        for k in range(10):                          # 10 pulses 100 ms apart, closed 50 ms
            reports += [report(22, 0, dt_us=50_000),                          # closes ...
                        report(22, 1, dt_us=300), report(22, 0, dt_us=300),   # ... bouncing twice
                        report(22, 1, dt_us=300), report(22, 0, dt_us=300),
                        report(22, 1, dt_us=48_800),                          # opens ...
                        report(22, 0, dt_us=300), report(22, 1, dt_us=300),   # ... re-closing twice
                        report(22, 0, dt_us=300), report(22, 1, dt_us=300)]
        send(reports)
        out["delivered"] = wait(lambda: c.count() + c.rejected == 50)
        out["count"], out["rejected"] = c.count(), c.rejected
    ''')
    # per pulse: 1 counted, 2 closing and 2 opening re-closures rejected (review 20 #4:
    # a debounce timed from the last counted pulse counted 20 here)
    assert out == {"delivered": True, "count": 10, "rejected": 40}


def test_a_raising_handler_is_caught_and_the_thread_lives_on(tmp_path):
    """An exception in urc's handler is caught and counted, the part reports a fault,
    and lgpio's thread keeps delivering to every other callback."""
    out = run_case(tmp_path, '''
        from urc.hardware.gpio.pins import PinPulseCounter, PinQuadrature
        from urc.hardware.parts import PartError
        q = PinQuadrature(factory, 17, 27)
        c = PinPulseCounter(factory, 22)
        def broken(*a):
            raise RuntimeError("a bug in a handler")
        q._edge = broken
        send([report(17, 0)] + [report(22, 0, dt_us=10_000) for _ in range(5)])
        out["delivered"] = wait(lambda: c.count() == 5)
        out["callback_errors"] = q.callback_errors
        out["thread_alive"] = lgpio._notify_thread.is_alive()
        try:
            q.count()
            out["count"] = "no fault"
        except PartError as exc:
            out["count"] = "fault: " + str(exc)
    ''')
    assert out["delivered"] and out["thread_alive"] and out["callback_errors"] == 1
    assert out["count"].startswith("fault: ") and "edge callback(s) failed" in out["count"]


def test_an_unguarded_raising_callback_ends_lgpios_thread(tmp_path):
    """Why the guard: the same exception from a bare lgpio callback ends lgpio's one
    notification thread, and no edge of any line is delivered again."""
    out = run_case(tmp_path, '''
        seen = []
        def broken(chip, gpio, level, tick):
            raise RuntimeError("a bug in a handler")
        lgpio.callback(0, 17, lgpio.BOTH_EDGES, broken)
        lgpio.callback(0, 22, lgpio.BOTH_EDGES, lambda *a: seen.append(a))
        send([report(22, 0)])
        out["before"] = wait(lambda: len(seen) == 1)
        send([report(17, 0)])
        wait(lambda: not lgpio._notify_thread.is_alive(), 10.0)
        send([report(22, 1)])
        time.sleep(0.5)
        out["thread_alive"], out["seen"] = lgpio._notify_thread.is_alive(), len(seen)
    ''')
    assert out == {"before": True, "thread_alive": False, "seen": 1}
