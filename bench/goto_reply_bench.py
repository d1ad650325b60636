"""How long a goto's reply takes through a real control process (issue 36.19: a moving
command's reply waits for the first state record of its motion, written with fsync by
the state writer's thread, never on the tick).

For each profile: a goto from standing (a record is needed ahead of the motion: the
reply waits for the tick that applies it and for that record's write), a goto while
moving (a new target: a record only when the old one's window no longer covers), and a
query's round trip (the floor: nothing waits). A profile whose sensors need no record
(absolute, within one turn: g5500) never waits. Works on any urc version, so the same
command run with an older tree on PYTHONPATH gives "before".
Prints a table, writes JSON (default bench/results/goto_reply.json).
Usage: python bench/goto_reply_bench.py [--profiles a,b] [--rounds N] [--state-dir DIR] [--json PATH]
"""

from __future__ import annotations

import argparse
import tempfile
import threading
import time
from pathlib import Path

from bench_report import pct, write_json
from urc.config import Config
from urc.model.messages import OvershootQuery
from urc.link.control_process import PING_S, ControlProcess


def wait_still(rot, timeout_s: float = 60.0) -> None:
    deadline_s = time.monotonic() + timeout_s
    while time.monotonic() < deadline_s:
        s = rot.status()
        if not s.moving and all(a is None or a.mode in ("holding", "idle") for a in (s.az, s.el)):
            return
        time.sleep(0.05)
    raise RuntimeError("the antenna did not come to rest")


def timed_ms(call) -> float:
    t0 = time.perf_counter()
    call()
    return (time.perf_counter() - t0) * 1e3


def measure(profile: str, rounds: int, state_root: Path | None) -> dict:
    cfg = Config.from_dict({"rotator": {"profile": profile}, "hardware": {"sim": {"wind": False}}})
    with tempfile.TemporaryDirectory(dir=state_root) as d:
        proc = ControlProcess(cfg, Path(d) / "state", [])
        rot = proc.start()
        done = threading.Event()

        def ping() -> None:   # (as urc run's event loop does: a silent I/O process stops jogs)
            while not done.wait(PING_S):
                proc.ping()
        threading.Thread(target=ping, daemon=True).start()
        standing, moving, query = [], [], []
        try:
            rot.goto(10.0, 60.0)
            wait_still(rot)
            for i in range(rounds):
                az = 10.0 + 4.0 * ((i + 1) % 2)          # 4 deg there and back
                standing.append(timed_ms(lambda: rot.goto(az, 60.0)))
                time.sleep(0.3)                          # under way
                moving.append(timed_ms(lambda: rot.goto(az + 0.5, 60.0)))
                wait_still(rot)
                query.append(timed_ms(lambda: rot.ask(OvershootQuery("az"))))
        finally:
            done.set()
            proc.stop()
    row = {"profile": profile, "rounds": rounds}
    for name, xs in (("goto_standing", standing), ("goto_moving", moving), ("query", query)):
        row[name] = {"p50_ms": round(pct(xs, 0.5), 2), "p90_ms": round(pct(xs, 0.9), 2),
                     "max_ms": round(max(xs), 2)}
    return row


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--profiles", default="tartu-urc,g5500")
    ap.add_argument("--rounds", type=int, default=20)
    ap.add_argument("--state-dir", type=Path, default=None, help="where the state dirs go (a filesystem to try)")
    ap.add_argument("--json", default="bench/results/goto_reply.json")
    args = ap.parse_args()
    rows = [measure(p, args.rounds, args.state_dir) for p in args.profiles.split(",")]
    print(f"{'profile':12} {'reply to':16} {'p50 ms':>8} {'p90 ms':>8} {'max ms':>8}")
    for r in rows:
        for name in ("goto_standing", "goto_moving", "query"):
            m = r[name]
            print(f"{r['profile']:12} {name:16} {m['p50_ms']:8.2f} {m['p90_ms']:8.2f} {m['max_ms']:8.2f}")
    write_json({"rows": rows}, args.json)


if __name__ == "__main__":
    main()
