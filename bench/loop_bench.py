"""Control-loop timing of a real ``urc run`` while its API is abused (issue 8, 9.7, 12).

A ``urc run`` process (simulator, a station, a catalog of LEO satellites) goes through
phases of ``--phase-s`` seconds each: idle; slewing; slewing while curl POSTs 40 MB
bodies to /api/goto back to back; slewing while 8 curl clients search /api/passes in
parallel; both at once; and slewing while 4 Hamlib ``rotctl`` clients poll the position
(``p``) over rotctld back to back. The load comes from curl and rotctl (C) processes, so the generator is
not the bottleneck (nor shares urc's GIL). At the end of each phase the loop's own numbers
are read from /api/status (its window is the last 500 ticks = 10 s at 50 Hz):

* lateness p99: how long after its deadline each tick had written its outputs (start
  lateness plus the tick's own run time: the whole tick);
* tick p99: the tick's run time alone;
* stalls (ticks later than the watchdog time) and faults latched;
* CPU per tick: the control process's user+system time over the ticks run (heartbeat
  toggles), and the I/O process's CPU share beside it.

Reference, same run: ``rt_probe`` (bench/rt_probe.c, compiled with the system's cc) wakes
a C thread at the loop's period and priority during every phase. It needs no Python
lock, so it shows what the host itself (kernel, VM, the curl load) adds. urc's loop runs
in a control process of its own (urc.link.control_process); with the loop in the
same interpreter as the web server it waited for Python's lock behind a preempted
event-loop thread: 10-19 ms p99 under the pass-search flood (0.9 ms idle).

Goal: lateness p99 <= 1 ms and no stalls. ``--switch-interval-ms`` runs urc with another
``sys.setswitchinterval`` (the evidence for the loop thread's setting).
Prints a table, writes JSON (default bench/results/loop.json). Never gates CI.
Usage: python bench/loop_bench.py [--phase-s 12] [--profile tartu-urc] [--json PATH]
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from datetime import datetime, timezone
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(ROOT / "bench"))
from bench_report import cpu_s, write_json  # noqa: E402
from urc_process import UrcProcess, free_port  # noqa: E402
from web_abuse_bench import leo_catalog  # noqa: E402
from web_bench import STATION  # noqa: E402

from urc.profiles import get_profile  # noqa: E402

def urc_cpu_s(urc: UrcProcess) -> tuple[float, float]:
    """CPU seconds of urc's I/O process and of its control process (the loop); a urc
    with the loop in its one process (before the split: for comparisons) counts as
    all control."""
    try:
        return cpu_s(urc.proc.pid), cpu_s(urc.control_pid())
    except AssertionError:
        return 0.0, cpu_s(urc.proc.pid)


def curl_loop(cmd: str) -> subprocess.Popen:
    """Run a curl command back to back until killed (a shell loop: no Python in the way)."""
    return subprocess.Popen(["sh", "-c", f"while true; do {cmd} >/dev/null 2>&1; done"], start_new_session=True)


def stop_all(procs: list[subprocess.Popen]) -> None:
    for p in procs:
        try:
            os.killpg(p.pid, 9)
        except ProcessLookupError:
            pass
        p.wait()


def build_probe(work: Path) -> Path | None:
    """Compile the C reference (None, and the table says so, without a C compiler)."""
    cc = shutil.which("cc") or shutil.which("gcc")
    if cc is None:
        return None
    exe = work / "rt_probe"
    subprocess.run([cc, "-O2", "-o", str(exe), str(ROOT / "bench" / "rt_probe.c")], check=True)
    return exe


def start_probe(exe: Path | None, period_ms: float, seconds: float) -> subprocess.Popen | None:
    if exe is None:
        return None
    return subprocess.Popen([str(exe), f"{period_ms:g}", f"{seconds:g}"], stdout=subprocess.PIPE, text=True)


def probe_result(proc: subprocess.Popen | None) -> dict | None:
    if proc is None:
        return None
    out, _ = proc.communicate(timeout=30)
    return json.loads(out) if proc.returncode == 0 else None


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--phase-s", type=float, default=12.0)
    ap.add_argument("--profile", default="tartu-urc")
    ap.add_argument("--satellites", type=int, default=60)
    ap.add_argument("--big-mb", type=int, default=40)
    ap.add_argument("--searchers", type=int, default=8)
    ap.add_argument("--clients", type=int, default=4, help="Hamlib rotctl clients polling the position")
    ap.add_argument("--switch-interval-ms", type=float, default=None,
                    help="run urc with this sys.setswitchinterval instead of the loop's own")
    ap.add_argument("--json", default=str(ROOT / "bench" / "results" / "loop.json"))
    args = ap.parse_args()

    results: dict = {"profile": args.profile, "phase_s": args.phase_s, "big_mb": args.big_mb,
                     "searchers": args.searchers, "switch_interval_ms": args.switch_interval_ms,
                     "cpus": os.cpu_count(), "load_avg_start": os.getloadavg(), "phases": []}
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        tle = work / "leo.tle"
        tle.write_text(leo_catalog(args.satellites, datetime.now(timezone.utc)))
        big = work / "big.json"
        big.write_bytes(b'{"az_deg": 1, "el_deg": 1, "pad": "' + b"x" * (args.big_mb * 2**20) + b'"}')
        rotctld_port = free_port()
        urc = UrcProcess(work, profile=args.profile, extra=STATION + f"[tracking]\ncatalog_dir = '{work / 'cat'}'\n",
                         serve=[{"protocol": "rotctld", "tcp": f"127.0.0.1:{rotctld_port}"}])
        subprocess.run([sys.executable, "-m", "urc", "tle", "import", str(tle), "--config", str(urc.config)],
                       check=True, capture_output=True)
        if args.switch_interval_ms is not None:
            # the loop thread only ever shortens the interval: patch its setting for this run
            os.environ["URC_BENCH_SWITCH_S"] = str(args.switch_interval_ms / 1000.0)
            launcher = work / "launch.py"
            launcher.write_text("import os, sys\nimport urc.rotator.loop as loop\n"
                                "loop.SWITCH_INTERVAL_S = float(os.environ['URC_BENCH_SWITCH_S'])\n"
                                "sys.setswitchinterval(loop.SWITCH_INTERVAL_S)\n"
                                "from urc.cli import main\nmain(prog_name='urc')\n")
            import urc_process
            urc_process.URC = [sys.executable, str(launcher)]
        probe = build_probe(work)
        period_ms = 1000.0 / get_profile(args.profile).loop_hz
        urc.start()
        big_cmd = (f"curl -s -o /dev/null -H 'Content-Type: application/json' --data-binary @{big} "
                   f"{urc.url}/api/goto")
        pass_cmd = f"curl -s -o /dev/null '{urc.url}/api/passes?hours=48&min_el_deg=0'"
        # Hamlib's own client asking for the position back to back (what a tracking
        # program polls): 2000 `p` per connection, then a new connection
        polls = work / "polls.txt"
        polls.write_text("p\n" * 2000)
        rotctl_cmd = f"rotctl -m 2 -r 127.0.0.1:{rotctld_port} - < {polls}" if shutil.which("rotctl") else None
        phases = [("idle", [], False), ("slewing", [], True),
                  (f"slewing + {args.big_mb} MB POSTs", [big_cmd], True),
                  (f"slewing + {args.searchers} pass searches", [pass_cmd] * args.searchers, True),
                  ("slewing + both", [big_cmd] + [pass_cmd] * args.searchers, True)]
        if rotctl_cmd is not None:
            phases.append((f"slewing + {args.clients} rotctl polling", [rotctl_cmd] * args.clients, True))
        try:
            time.sleep(2.0)
            toward = 0
            for name, cmds, slew in phases:
                s0 = urc.status()
                (io0, c0), t0 = urc_cpu_s(urc), time.monotonic()
                load = [curl_loop(c) for c in cmds]
                end = time.monotonic() + args.phase_s
                ref = start_probe(probe, period_ms, args.phase_s - 1.0)
                try:
                    while time.monotonic() < end:
                        if slew and not urc.status()["moving"]:
                            toward ^= 1
                            urc.post("/api/goto", {"az_deg": 300.0 if toward else 20.0,
                                                   "el_deg": 70.0 if toward else 10.0})
                        time.sleep(0.25)
                finally:
                    stop_all(load)
                reference = probe_result(ref)
                s1 = urc.status()
                (io1, c1), t1 = urc_cpu_s(urc), time.monotonic()
                ticks = s1["simulator_truth"]["heartbeat"]["toggles"] - s0["simulator_truth"]["heartbeat"]["toggles"]
                loop = s1["loop"]
                results["phases"].append({
                    "phase": name, "seconds": t1 - t0, "ticks": ticks,
                    "ticks_per_s": ticks / (t1 - t0),
                    "late_p99_ms": loop["late_p99_ms"], "tick_p99_ms": loop["tick_p99_ms"],
                    "stalls": loop["stalls"] - s0["loop"]["stalls"],
                    "faults": [f"{f['kind']}: {f['reason']}" for f in s1["faults"]],
                    "cpu_ms_per_tick": 1000.0 * (c1 - c0) / max(ticks, 1),
                    "cpu_share_of_a_core": (c1 - c0) / (t1 - t0),
                    "io_cpu_share_of_a_core": (io1 - io0) / (t1 - t0),
                    "c_probe": reference})
                if s1["faults"]:
                    urc.post("/api/clear-faults")
        finally:
            urc.stop()
    results["load_avg_end"] = os.getloadavg()
    print(f"control loop of urc run ({args.profile}, {results['phases'][0]['ticks_per_s']:.0f} Hz measured), "
          f"{args.phase_s:g} s per phase, {os.cpu_count()} CPUs, load average "
          f"{results['load_avg_start'][0]:.1f} at start"
          + (f", switch interval {args.switch_interval_ms:g} ms" if args.switch_interval_ms is not None else ""))
    print(f"  {'phase':<34} {'late p99':>9} {'C probe':>9} {'tick p99':>9} {'stalls':>6} {'CPU/tick':>9} "
          f"{'CPU':>6} {'I/O CPU':>8}  faults")
    for p in results["phases"]:
        ref = p["c_probe"]
        ref_txt = "    n/a  " if ref is None else f"{ref['late_p99_ms']:7.2f}ms"
        print(f"  {p['phase']:<34} {p['late_p99_ms']:7.2f}ms {ref_txt} {p['tick_p99_ms']:7.2f}ms {p['stalls']:6d} "
              f"{p['cpu_ms_per_tick']:7.2f}ms {100 * p['cpu_share_of_a_core']:5.0f}% "
              f"{100 * p['io_cpu_share_of_a_core']:7.0f}%  "
              f"{'; '.join(p['faults']) or 'none'}")
    print("  late p99: urc's loop thread (deadline to outputs written); C probe: a C thread woken at the "
          "same period and priority in the same run (what the host adds without Python's lock)")
    print("  CPU/tick and CPU: the control process (loop, hardware, status out); I/O CPU: the process that "
          "serves the web, the protocols and the tracker")
    write_json(results, args.json)


if __name__ == "__main__":
    main()
