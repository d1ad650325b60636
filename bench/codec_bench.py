"""What the link's codec costs per message: dumps and loads of a real Status (a hundred
cross the link each second), a Reply carrying one, and the "init" message's Config.

The Status is a simulator rotator's (tartu-urc, with a fault latched so its tuple is not
empty), built in this process as ``urc run``'s control process builds it. Each figure is
the best of ``--repeat`` timeit runs of ``--number`` calls (the least disturbed by the
other processes on the machine), in microseconds per call.

Usage: PYTHONPATH=src python3 bench/codec_bench.py [--number N] [--repeat R] [--json PATH]
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import timeit
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_report import write_json  # noqa: E402

from urc.assembly import build_rotator  # noqa: E402
from urc.clock import VirtualClock  # noqa: E402
from urc.config import Config  # noqa: E402
from urc.link import codec  # noqa: E402
from urc.model.messages import Reply  # noqa: E402


def messages(state_dir: Path) -> dict[str, object]:
    cfg = Config.from_dict({"rotator": {"profile": "tartu-urc"}, "hardware": {"sim": {"wind": False}}})
    rot = build_rotator(cfg, VirtualClock(), state_dir, durable_state=False)
    rot.tick()
    rot.power_fail("a benchmark's fault")
    rot.tick()
    status = rot.status()
    return {"status": ("status", status), "reply+status": ("reply", Reply(7, "value", None, status)),
            "init (Config)": ("init", cfg, str(state_dir), [], 20)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--number", type=int, default=2000)
    ap.add_argument("--repeat", type=int, default=7)
    ap.add_argument("--json", default=str(Path(__file__).resolve().parent / "results" / "codec.json"))
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        msgs = messages(Path(tmp))
    results: dict[str, dict[str, float]] = {}
    for name, msg in msgs.items():
        data = codec.dumps(msg)
        assert codec.loads(data) == msg or name.startswith("init")
        per_call = {}
        for op, fn in (("dumps", lambda m=msg: codec.dumps(m)), ("loads", lambda d=data: codec.loads(d))):
            per_call[f"{op}_us"] = min(timeit.repeat(fn, number=args.number, repeat=args.repeat)) / args.number * 1e6
        results[name] = {"bytes": len(data), **per_call}
    print(f"codec per call, best of {args.repeat} x {args.number} (load average {os.getloadavg()[0]:.2f})")
    print(f"{'message':<14} | {'bytes':>6} | {'dumps us':>9} | {'loads us':>9}")
    for name, r in results.items():
        print(f"{name:<14} | {r['bytes']:6d} | {r['dumps_us']:9.1f} | {r['loads_us']:9.1f}")
    write_json({"number": args.number, "repeat": args.repeat, "messages": results}, args.json)


if __name__ == "__main__":
    main()
