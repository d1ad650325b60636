"""`urc status` against Hamlib's `rotctl -m 2 ... p` in the same run (issue 19: the CLI
took 0.24-0.32 s; target <= 80 ms on this machine).

Starts one `urc run` (the simulator, rotctld on a TCP port) and times, alternately, N
runs of each client as a new process would be run by a user or a script: `python3 -m urc
status --port P` (what `urc status` runs), `rotctl -m 2 -r 127.0.0.1:PORT p` (Hamlib's
client against urc's rotctld port) and `python3 -c pass` (the interpreter's own start,
the floor under any Python CLI). Prints a table (wall median, p90, min, max and CPU
median in ms, the ratios of the medians to rotctl's and to the interpreter's start, the
load average) and writes JSON (default bench/results/cli.json).
Usage: python bench/cli_bench.py [--runs 20] [--json PATH]
"""

from __future__ import annotations

import argparse
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from bench_report import write_json  # noqa: E402
from urc_process import UrcProcess, free_port  # noqa: E402

#: the directory urc is imported from (for the runs without site, which sees no .pth)
URC_SRC = str(Path(__import__("urc").__file__).resolve().parents[1])


def timed(cmd: list[str], env: dict) -> tuple[float, float]:
    """(wall ms, CPU ms: user + system) of one run of ``cmd``. CPU time says what the
    client costs when the machine is loaded and the wall time mostly waits for a core."""
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    done = subprocess.run(cmd, capture_output=True, text=True, env=env)
    dt_ms = (time.perf_counter() - t0) * 1000.0
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed ({done.returncode}): {done.stderr or done.stdout}")
    return dt_ms, (r1.ru_utime - r0.ru_utime + r1.ru_stime - r0.ru_stime) * 1000.0


def summary(runs: list[tuple[float, float]]) -> dict:
    s = sorted(w for w, _ in runs)
    return {"runs": len(s), "median_ms": statistics.median(s), "p90_ms": s[min(len(s) - 1, int(0.9 * len(s)))],
            "min_ms": s[0], "max_ms": s[-1], "cpu_median_ms": statistics.median(c for _, c in runs)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--runs", type=int, default=20)
    ap.add_argument("--json", default=str(Path(__file__).resolve().parent / "results" / "cli.json"))
    args = ap.parse_args()
    rotctl = shutil.which("rotctl")
    env = dict(os.environ)
    with tempfile.TemporaryDirectory() as tmp:
        rport = free_port()
        urc = UrcProcess(Path(tmp), serve=[{"protocol": "rotctld", "tcp": f"127.0.0.1:{rport}"}]).start()
        try:
            status = ["-m", "urc", "status", "--port", str(urc.port)]
            clients = {"urc status": ([sys.executable, *status], env),
                       # the floor: the interpreter starting and doing nothing (site hooks included)
                       "python3 -c pass": ([sys.executable, "-c", "pass"], env),
                       # the same two without site (-S): what its .pth hooks cost on this
                       # machine (a sandbox's hook that loads certifi: ~60 ms here) is not
                       # urc's, and a plain Pi has none
                       "urc status -S": ([sys.executable, "-S", *status], {**env, "PYTHONPATH": URC_SRC}),
                       "python3 -S -c pass": ([sys.executable, "-S", "-c", "pass"], env)}
            if rotctl:
                clients["rotctl -m 2 p"] = ([rotctl, "-m", "2", "-r", f"127.0.0.1:{rport}", "p"], env)
            for cmd, cmd_env in clients.values():  # (warm the page cache: a user's second run)
                timed(cmd, cmd_env)
            load_before = os.getloadavg()
            times: dict[str, list[tuple[float, float]]] = {name: [] for name in clients}
            for _ in range(args.runs):  # alternately: the same load for all
                for name, (cmd, cmd_env) in clients.items():
                    times[name].append(timed(cmd, cmd_env))
            load_after = os.getloadavg()
        finally:
            urc.stop()
    results = {"runs": args.runs, "load_avg_1_5_15": {"before": load_before, "after": load_after},
               "clients": {name: summary(ms) for name, ms in times.items()}}
    print(f"one client process per query, {args.runs} runs each, alternating "
          f"(load average {load_before[0]:.2f} -> {load_after[0]:.2f})")
    print(f"{'client':<18} | {'median ms':>9} {'p90 ms':>8} {'min ms':>8} {'max ms':>8} | {'CPU med ms':>10}")
    for name, s in results["clients"].items():
        print(f"{name:<18} | {s['median_ms']:9.1f} {s['p90_ms']:8.1f} {s['min_ms']:8.1f} {s['max_ms']:8.1f} | "
              f"{s['cpu_median_ms']:10.1f}")
    urc_s, floor = results["clients"]["urc status"], results["clients"]["python3 -c pass"]
    # what urc adds to the interpreter's own start (its site hooks included)
    results["ratio_to_floor"] = {"wall_median": urc_s["median_ms"] / floor["median_ms"],
                                 "cpu_median": urc_s["cpu_median_ms"] / floor["cpu_median_ms"]}
    print(f"urc status / python3 -c pass: wall median {results['ratio_to_floor']['wall_median']:.2f}, "
          f"CPU median {results['ratio_to_floor']['cpu_median']:.2f} "
          f"(+{urc_s['median_ms'] - floor['median_ms']:.1f} ms wall, "
          f"+{urc_s['cpu_median_ms'] - floor['cpu_median_ms']:.1f} ms CPU)")
    bare, bare_floor = results["clients"]["urc status -S"], results["clients"]["python3 -S -c pass"]
    results["site_hooks_ms"] = floor["median_ms"] - bare_floor["median_ms"]
    print(f"without site: urc status {bare['median_ms']:.1f} ms median, the interpreter "
          f"{bare_floor['median_ms']:.1f} ms; this machine's site hooks cost {results['site_hooks_ms']:.1f} ms")
    if "rotctl -m 2 p" in results["clients"]:
        ratio = urc_s["median_ms"] / results["clients"]["rotctl -m 2 p"]["median_ms"]
        results["ratio_median"] = ratio
        print(f"urc status / rotctl p (median): {ratio:.2f}")
    else:
        print("rotctl not installed: urc status alone")
    write_json(results, args.json)


if __name__ == "__main__":
    main()
