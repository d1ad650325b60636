"""Fail-safe bench (issue 20): what the simulated iron does when a ``urc run`` process
freezes, dies or stops, mid-move, with and without the modelled safety part.

For each seed machine (its example configuration on the emulated gpio backend with the
simulator, wind off) and each event — SIGSTOP of the control process for 2 s and for
10 s, kill -9 of the control process, kill -9 of the I/O process, SIGSTOP of the I/O
process for 10 s, a clean stop (SIGTERM to ``urc run``) — given while the azimuth turns
at most of its top speed, it measures

* the travel of the simulator's truth after the event (deg, azimuth: the axis moving),
* the time until every motor is off (ms): drive zero or motor power cut,

with the safety part (``motor_enable_timeout_s = 0.22`` as the examples have it) and
without it (the key left out: not wired), the I/O process's takeover at its default
(``[faults] control_takeover_s = 1``).

The truth comes from the simulated world, never from urc's reports: every world that
opens the rotator (the control process's, the I/O process's after a takeover, ...)
appends its history to a truth log (``URC_SIM_TRUTH_LOG``, :mod:`urc.hardware.sim.truthlog`):
samples, the safety relay's cut, and for a world opened on moving iron how long the dead
process's lines kept the motors driving (until the relay cut them, or without the part
until that world's process took the lines) and where the coast ended.

Goals (issue 20), per row:
* with the part, when the process that drives the motors freezes or dies (its heartbeat
  stops): motors off within the timeout (<= 250 ms), travel <= top speed x 0.25 s + the
  axis' coast (simulated below), and under 2 deg;
* otherwise (without the part; with it when the control process stays healthy and keeps
  the heartbeat, so the part cannot act): motors off within 1.5 s.

It also asks rotctld ``p`` on connections opened before the event, 0.5 s and 1.3 s after
it, and compares each answer with the truth at that moment: a number more than 1 deg
from the truth is a stale position given as current (STALE).

Usage: python bench/failsafe_bench.py [--machines tartu-urc,g5500] [--events a,b]
       [--parts with,without] [--json bench/results/failsafe.json]
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import socket
import sys
import tempfile
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
from urc_process import UrcProcess, free_port  # noqa: E402

from bench_report import write_json  # noqa: E402
from urc.clock import VirtualClock  # noqa: E402
from urc.hardware.sim import SimWorld, physics_for  # noqa: E402
from urc.hardware.sim.truthlog import ENV as TRUTH_LOG_ENV, read_log  # noqa: E402
from urc.profiles import get_profile  # noqa: E402

MACHINES = ("tartu-urc", "g5500")
EVENTS = ("ctl_stop_2s", "ctl_stop_10s", "ctl_kill9", "io_kill9", "io_stop_10s", "sigterm")
#: events that stop the heartbeat (the process that drives the motors freezes or dies)
HEARTBEAT_STOPS = ("ctl_stop_2s", "ctl_stop_10s", "ctl_kill9")
TIMEOUT_S = 0.22
GOAL_PART_S = 0.25
GOAL_SOFTWARE_S = 1.5
MAX_TRAVEL_DEG = 2.0
PROBES_S = (0.5, 1.3)
#: a numeric answer this far from the truth is a stale position given as current
STALE_DEG = 1.0


# ------------------------------------------------------------------ the machines
def config_text(machine: str, part: bool, api_port: int, rotctld_port: int) -> str:
    text = (ROOT / "examples" / f"{machine}.toml").read_text()
    line = f"motor_enable_timeout_s = {TIMEOUT_S}\n"
    assert line in text, f"examples/{machine}.toml has no {line!r}"
    if not part:
        text = text.replace(line, "")
    text = text.replace("[hardware.gpio]\n", "[hardware.gpio]\nemulate = true\n", 1)
    return (text + f"\n[hardware.sim]\nwind = false\n\n[api]\nport = {api_port}\n\n"
            f'[[serve]]\nprotocol = "rotctld"\ntcp = "127.0.0.1:{rotctld_port}"\n')


def coast_deg(machine: str) -> dict:
    """The azimuth's coast from its top speed once the relay cuts the power, and the
    travel from the last heartbeat edge to rest (virtual clock, the sim's physics)."""
    caps = get_profile(machine)
    top = caps.az.max_rate_deg_per_s

    def run(duty: float, cut: bool) -> tuple[float, float, float]:
        clock = VirtualClock(0.0)
        w = SimWorld(caps, physics_for(machine), clock, truth_path=None, wind=False,
                     motor_enable_timeout_s=TIMEOUT_S)
        w.advance_to(0.0)
        level = False
        w.command_brake("az", True)
        w.motors["az"].set_drive(duty)
        for _ in range(400):                      # 8 s with the heartbeat: steady speed
            clock.advance(0.02)
            level = not level
            w.enable.heartbeat(level)
            w.advance_to(clock.now_s())
        rate, at_edge = w.truth()["az"]["rate_deg_per_s"], w.truth()["az"]["deg"]
        if not cut:
            return rate, at_edge, at_edge
        last_edge_s = w.enable.last_edge_s
        clock.advance(last_edge_s + TIMEOUT_S - clock.now_s())
        w.advance_to(clock.now_s())
        at_cut = w.truth()["az"]["deg"]
        for _ in range(1000):
            clock.advance(0.01)
            w.advance_to(clock.now_s())
        return rate, at_cut, w.truth()["az"]["deg"]

    lo, hi = 0.0, 1.0
    if run(1.0, False)[0] > top:                  # the duty that turns at the top speed
        for _ in range(20):
            mid = (lo + hi) / 2
            lo, hi = (mid, hi) if run(mid, False)[0] < top else (lo, mid)
    rate, at_cut, rest = run(hi, True)
    coast = abs(rest - at_cut)
    return {"top_deg_per_s": top, "sim_rate_deg_per_s": rate, "coast_deg": coast,
            "bound_deg": top * GOAL_PART_S + coast}


# ------------------------------------------------------------------ rotctld probes
class Probe(threading.Thread):
    """One rotctld client connected before the event: ``p`` at ``offset_s`` after it."""

    def __init__(self, port: int, offset_s: float):
        super().__init__(daemon=True)
        self.offset_s = offset_s
        self.sock = socket.create_connection(("127.0.0.1", port), timeout=5)
        self.t_event = 0.0
        self.result: dict = {}

    def run(self) -> None:
        time.sleep(max(0.0, self.t_event + self.offset_s - time.time()))
        sent = time.time()
        got = b""
        try:
            self.sock.settimeout(3.0)
            self.sock.sendall(b"p\n")
            while got.count(b"\n") < 2 and not got.startswith(b"RPRT"):
                chunk = self.sock.recv(256)
                if not chunk:
                    break
                got += chunk
            answer = got.decode(errors="replace").strip() or "connection closed"
        except socket.timeout:
            answer = "no answer in 3 s" + (f" (partial {got!r})" if got else "")
        except OSError as exc:
            answer = f"connection error: {exc.strerror or exc}"
        self.result = {"offset_s": self.offset_s, "sent_wall_s": sent, "answer": answer,
                       "latency_s": time.time() - sent}
        self.sock.close()


# ------------------------------------------------------------------ one run
def gone(pid: int) -> bool:
    try:
        return open(f"/proc/{pid}/stat").read().rsplit(")", 1)[1].split()[0] == "Z"
    except FileNotFoundError:
        return True


def wait_for(pred, timeout_s: float) -> bool:
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        if pred():
            return True
        time.sleep(0.05)
    return False


def one_run(machine: str, part: bool, event: str, workdir: Path) -> dict:
    workdir.mkdir(parents=True)
    log_path = workdir / "truth.log"
    u = UrcProcess(workdir, profile=machine)
    rotctld_port = free_port()
    u.config.write_text(config_text(machine, part, u.port, rotctld_port))
    caps = get_profile(machine)
    top = caps.az.max_rate_deg_per_s
    row: dict = {"machine": machine, "part": part, "event": event}
    probes: list[Probe] = []
    t_event = 0.0
    try:
        u.start(env={**os.environ, TRUTH_LOG_ENV: str(log_path)})
        s = u.status()
        az = s["simulator_truth"]["az"]["deg"]
        lo, hi = caps.az.min_deg, caps.az.max_deg
        target = hi - 5.0 if az - lo < hi - az else lo + 5.0
        if event in ("io_stop_10s", "io_kill9"):
            # (a silent or dead I/O process stops open-ended motion only: a goto flies on
            # to its end since issue 33 (after a kill -9, to be taken over by the next urc
            # run), so the rule is measured on a jog)
            r = u.post("/api/move", {"axis": "az", "direction": 1 if target > az else -1})
        else:
            r = u.post("/api/goto", {"az_deg": target, "el_deg": s["el_deg"]})
        assert r.status_code == 200, r.text
        u.wait(lambda s: abs(s["simulator_truth"]["az"]["rate_deg_per_s"]) > 0.8 * top, 60.0)
        ctl, io = u.control_pid(), u.proc.pid
        probes = [Probe(rotctld_port, off) for off in PROBES_S]
        t_event = time.time()
        for p in probes:
            p.t_event = t_event
        if event.startswith("ctl_stop"):
            os.kill(ctl, signal.SIGSTOP)
        elif event == "ctl_kill9":
            os.kill(ctl, signal.SIGKILL)
        elif event == "io_kill9":
            os.kill(io, signal.SIGKILL)
        elif event == "io_stop_10s":
            os.kill(io, signal.SIGSTOP)
        elif event == "sigterm":
            os.kill(io, signal.SIGTERM)
        for p in probes:
            p.start()
        if event in ("ctl_stop_2s", "ctl_stop_10s", "io_stop_10s"):
            time.sleep(2.0 if event == "ctl_stop_2s" else 10.0)
            try:
                os.kill(ctl if event.startswith("ctl") else io, signal.SIGCONT)
            except ProcessLookupError:
                pass
        if event == "io_kill9":
            row["ended"] = wait_for(lambda: gone(ctl), 60.0)
        elif event.startswith("ctl"):
            # taken over (or not, thawed in time), then started again by urc run's watch
            # (issue 33: urc run no longer exits after a takeover)
            row["ended"] = wait_for(lambda: u.proc.poll() is not None or gone(ctl) and any(
                "started again" in e for e in u.status()["events"]) or not gone(ctl) and not u.status()["moving"],
                60.0)
        elif event == "io_stop_10s":
            row["ended"] = wait_for(lambda: not u.status()["moving"], 60.0)
        else:
            row["ended"] = wait_for(lambda: u.proc.poll() is not None, 60.0)
        row["exit_code"] = u.proc.poll()
        for p in probes:
            p.join(10.0)
    finally:
        exited = u.proc is not None and u.proc.poll() is not None
        out = u.stop()               # (the whole group: nothing of this urc is left)
        if exited and u.proc is not None:
            out = u.proc.stdout.read()
        for p in probes:
            if p.is_alive():
                p.sock.close()
    row["urc_said"] = [ln for ln in out.splitlines() if "urc:" in ln or "rror" in ln][-4:]
    row.update(analyse(log_path, u.state_dir / "simulator-truth.json", t_event))
    row["p"] = [judge_probe(p.result, log_path, t_event, row) for p in probes]
    return row


# ------------------------------------------------------------------ the truth
def _samples(entries: list[dict]) -> list[dict]:
    return [e for e in entries if e["t"] == "s"]


def truth_at(entries: list[dict], t: float, axis: str = "az") -> float:
    """The truth at wall time ``t``: the last sample before it, run on at its rate for at
    most 50 ms (a sample is at most a tick old while the world runs)."""
    before = [e for e in _samples(entries) if e["wall_s"] <= t]
    if not before:
        raise ValueError("no truth sample before the event")
    e = before[-1]["axes"][axis]
    return e["deg"] + e["rate"] * min(0.05, t - before[-1]["wall_s"])


def analyse(log_path: Path, truth_file: Path, t_event: float) -> dict:
    entries = read_log(log_path)
    at_event = {a: truth_at(entries, t_event, a) for a in ("az", "el")}
    final = json.loads(truth_file.read_text())["axes"]
    travel = {a: abs(final[a]["load_deg"] - at_event[a]) for a in ("az", "el")}
    offs = []
    for e in entries:
        if e["wall_s"] < t_event - 0.5:
            continue
        if e["t"] == "cut":
            offs.append(e["wall_s"])
        elif e["t"] == "restore":
            driving = any(ax["drive"] for ax in e["axes"].values())
            offs.append(e["off_wall_s"] if driving and e["off_wall_s"] is not None else
                        e["record_wall_s"] or e["wall_s"])
        elif e["t"] == "s" and e["wall_s"] >= t_event and all(
                ax["drive"] == 0.0 or not ax["powered"] for ax in e["axes"].values()):
            offs.append(e["wall_s"])
    off_s = max(0.0, min(offs) - t_event) if offs else None
    restores = [e for e in entries if e["t"] == "restore" and e["wall_s"] >= t_event]
    resumed = _resumed(entries, t_event, off_s)
    if resumed is not None:
        # (urc run started the control process again and the goto resumed, on absolute
        # sensors (issue 33): the travel judged is the run-on and coast before that)
        travel = {a: abs(resumed["axes"][a]["deg"] - at_event[a]) for a in ("az", "el")}
        final = {a: {"load_deg": resumed["axes"][a]["deg"]} for a in ("az", "el")}
    return {"travel_az_deg": travel["az"], "travel_el_deg": travel["el"],
            "off_ms": None if off_s is None else 1000.0 * off_s,
            "run_on_s": restores[0]["run_on_s"] if restores else None,
            "at_event_az_deg": at_event["az"], "final_az_deg": final["az"]["load_deg"]}


def _resumed(entries: list[dict], t_event: float, off_s: float | None) -> dict | None:
    """The last sample before the motors drove again after they went off (a command
    resumed by a control process started again), or None if they did not."""
    if off_s is None:
        return None
    samples = [e for e in _samples(entries) if e["wall_s"] >= t_event]
    t_off = t_event + off_s + 0.5
    for before, e in zip(samples, samples[1:]):
        if e["wall_s"] > t_off and any(ax["drive"] and ax.get("powered", True) for ax in e["axes"].values()):
            return before
    return None


def judge_probe(result: dict, log_path: Path, t_event: float, row: dict) -> dict:
    """A numeric answer against the truth when it was asked. While a world ran (the
    control process alive) that is its sample; while none ran (the control process
    frozen or dead, its world with it) the iron is rebuilt from what came after: it
    drove on at the rate of its last sample until the motors went off, then coasted to
    where the next world found it at rest; in the coast the answer is judged against the
    nearest point of it (the error is then at least what is shown)."""
    if not result:
        return {"answer": "probe did not run"}
    out = dict(result)
    parts = result["answer"].split()
    try:
        az = float(parts[0])
        float(parts[1])
    except (IndexError, ValueError):
        out["verdict"] = "no position (truthful)"
        return out
    t = result["sent_wall_s"]
    entries = read_log(log_path)
    live = [e for e in _samples(entries) if t_event < e["wall_s"] <= t and t - e["wall_s"] < 0.1]
    if live or row["off_ms"] is None:
        lo = hi = truth_at(entries, t)
    else:
        last = [e for e in _samples(entries) if e["wall_s"] <= t_event][-1]
        deg, rate = last["axes"]["az"]["deg"], last["axes"]["az"]["rate"]
        off_s = t_event + row["off_ms"] / 1000.0
        if t <= off_s:
            lo = hi = deg + rate * (t - last["wall_s"])
        else:
            at_off = deg + rate * (off_s - last["wall_s"])
            lo, hi = sorted((at_off, row["final_az_deg"]))
    nearest = min(max(az, lo), hi)
    err = abs((az - nearest + 180.0) % 360.0 - 180.0)
    out.update(truth_az_deg=[lo, hi], error_deg=err, verdict="STALE" if err > STALE_DEG else "current")
    return out


def goal(row: dict, coast: dict) -> tuple[str, bool]:
    off_ms = row["off_ms"]
    if row["part"] and row["event"] in HEARTBEAT_STOPS:
        text = f"off <= {GOAL_PART_S * 1000:.0f} ms, travel <= {min(coast['bound_deg'], MAX_TRAVEL_DEG):.2f} deg"
        met = off_ms is not None and off_ms <= GOAL_PART_S * 1000 and \
            row["travel_az_deg"] <= min(coast["bound_deg"], MAX_TRAVEL_DEG)
        return text, met
    return f"off <= {GOAL_SOFTWARE_S * 1000:.0f} ms", off_ms is not None and off_ms <= GOAL_SOFTWARE_S * 1000


def p_cell(p: dict) -> str:
    if "error_deg" in p:
        return f"{p['verdict']} {p['error_deg']:.1f}"
    a = p.get("answer", "")
    return a.replace("connection error: ", "")[:18]


def table(rows: list[dict], coasts: dict[str, dict]) -> None:
    print("\nper machine: top speed, simulated coast from it after the relay cuts, bound = top x "
          f"{GOAL_PART_S} s + coast")
    for m, c in coasts.items():
        print(f"  {m:10} top {c['top_deg_per_s']:.2f} deg/s  coast {c['coast_deg']:.2f} deg  "
              f"bound {c['bound_deg']:.2f} deg")
    head = (f"\n{'machine':10} {'part':4} {'event':13} {'travel deg':>10} {'off ms':>8} {'run-on s':>8}  "
            f"{'goal':32} {'met':4} {'p +0.5 s':20} {'p +1.3 s':20}")
    print(head)
    print("-" * len(head))
    for r in rows:
        if "error" in r:
            print(f"{r['machine']:10} {'with' if r['part'] else 'w/o':4} {r['event']:13} ERROR {r['error']}")
            continue
        off = "-" if r["off_ms"] is None else f"{r['off_ms']:.0f}"
        run_on = "-" if r["run_on_s"] is None else f"{r['run_on_s']:.2f}"
        print(f"{r['machine']:10} {'with' if r['part'] else 'w/o':4} {r['event']:13} {r['travel_az_deg']:10.2f} "
              f"{off:>8} {run_on:>8}  {r['goal']:32} {'yes' if r['met'] else 'NO':4} "
              + " ".join(f"{p_cell(p):20}" for p in r["p"]))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--machines", default=",".join(MACHINES))
    ap.add_argument("--events", default=",".join(EVENTS))
    ap.add_argument("--parts", default="with,without")
    ap.add_argument("--json", default="bench/results/failsafe.json")
    ap.add_argument("--keep", metavar="DIR", help="keep each run's config, state and truth log here")
    args = ap.parse_args()
    machines = args.machines.split(",")
    events = args.events.split(",")
    parts = [p == "with" for p in args.parts.split(",")]
    coasts = {m: coast_deg(m) for m in machines}
    rows = []
    with tempfile.TemporaryDirectory(prefix="urc-failsafe-") as tmp:
        if args.keep:
            tmp = args.keep
        n = 0
        for m in machines:
            for part in parts:
                for ev in events:
                    n += 1
                    try:
                        row = one_run(m, part, ev, Path(tmp) / f"run{n}")
                        row["goal"], row["met"] = goal(row, coasts[m])
                    except Exception as exc:  # one failed run must not lose the others
                        row = {"machine": m, "part": part, "event": ev, "error": repr(exc)[:300]}
                    rows.append(row)
                    print(f"  {m} {'with' if part else 'without'} part, {ev}: " +
                          (row.get("error") or f"travel {row['travel_az_deg']:.2f} deg, off "
                           f"{row['off_ms'] if row['off_ms'] is None else round(row['off_ms'])} ms, "
                           f"goal met: {row['met']}, p: {[p.get('answer') for p in row['p']]}"), flush=True)
    table(rows, coasts)
    write_json({"coast": coasts, "runs": rows, "timeout_s": TIMEOUT_S,
                "goals": {"part_s": GOAL_PART_S, "software_s": GOAL_SOFTWARE_S, "max_travel_deg": MAX_TRAVEL_DEG}},
               args.json)


if __name__ == "__main__":
    main()
