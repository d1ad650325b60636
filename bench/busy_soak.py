"""A long soak on a busy machine (issue 33): passes, Gpredict-style rotctld clients, MQTT
gotos, a big catalog reloaded, SIGSTOP pauses of the I/O process, all under stress-ng.

One real ``urc run`` (tartu-urc on the simulator, or examples/g5500.toml on emulated
gpio) with, for ``--minutes``:
- a synthetic pass every ``--pass-every-min`` (5) minutes, picked before the start so the
  passes do not overlap (AOS above ``[tracking] min_el_deg`` = 40, 60-120 s long), asked
  for with POST /api/track/pass a lead before AOS;
- 8 rotctld clients (a thread and a socket each): ``p`` every 0.5 s, and ``P az el``
  while a pass satellite is up and the antenna is more than 5 deg off it (as Gpredict);
- an MQTT goto about every minute where the passes leave room, judged completed when
  the status shows the antenna within 1 deg of it and still within travel + 30 s;
- a 30,000-set catalog imported at the start and imported again every 10 minutes
  (``urc tle import`` rewrites the catalog file: urc reads it again);
- SIGSTOP of the I/O process for 1-3 s at random every 2-4 minutes;
- ``stress-ng --cpu 8 --vm 2 --vm-bytes 256M`` throughout (not with --no-stress).
/api/status is polled every 0.5 s (1 s timeout; failures counted).

Reported: passes flown and lost, each pass's RMS pointing error after AOS (simulator
truth's beam direction against the satellite's look angles) against the same pass flown
unstressed on a virtual clock; stops by reason; gotos accepted but not completed;
takeovers; RPRT answers to ``p``; the event loop's lag p99 (when status has it);
tick_late_p99_ms max. Prints a table, writes JSON. Never gates CI.

``--quiet`` runs the same timetable, clients and gotos without stress-ng, SIGSTOP pauses
or catalog reloads: the real-time reference (real ticks, real threads) against which the
virtual-clock reference can be read. (A pass cannot be flown twice in real time: its
satellite is up once.)

Usage: python bench/busy_soak.py --config {tartu-sim|g5500-emulate} --minutes 60
       [--no-stress | --quiet] [--json PATH]
"""

from __future__ import annotations

import argparse
import json
import math
import random
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
import tomllib
from pathlib import Path

import httpx
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(ROOT / "tests" / "mqtt"))
sys.path.insert(0, str(ROOT / "bench"))
from bench_report import pct, write_json  # noqa: E402
from broker import Client, Mosquitto  # noqa: E402
from urc_process import URC, UrcProcess, free_port, stop_process_group  # noqa: E402

from urc.angles import great_circle_deg  # noqa: E402
from urc.testing.synthetic import STATION_TOML as STATION  # noqa: E402
from urc.testing.synthetic import satellites_passing_between, synthetic_catalog  # noqa: E402
from urc.tracking.propagate import look_angles  # noqa: E402
from urc.tracking.station import Station  # noqa: E402

TARTU = Station(58.378, 26.729, 70.0, "Tartu")
MIN_EL_DEG = 40.0            # [tracking] min_el_deg: short passes fit a 5-minute timetable
PASS_S = (60.0, 120.0)       # pass length range (AOS..LOS above MIN_EL_DEG)
AFTER_LOS_S = 20.0           # the pass's end (and the park) before a goto
POLL_S = 0.5
CLIENTS = 8
OFF_DEG = 5.0                # a client sends P when the antenna is this far off the satellite
BASE = "urc/soak"
CATALOG_SETS = 30_000
CONFIGS = {  # profile, request lead before AOS (the pre-position of a slow rotator)
    "tartu-sim": ("tartu-urc", 60.0),
    "g5500-emulate": ("g5500", 110.0),
}


def wrap180(x: float) -> float:
    return (x + 180.0) % 360.0 - 180.0


def beam(s: dict) -> tuple[float, float]:
    """Sky az/el of the beam: the simulator's truth (flip mapped) or the status' own."""
    truth = s.get("simulator_truth") or {}
    if "az" in truth and "deg" in truth["az"]:
        az = truth["az"]["deg"]
        el = truth["el"]["deg"] if "el" in truth else s["el_deg"]
        if el > 90.0:
            az, el = az + 180.0, 180.0 - el
        return az % 360.0, el
    return s["az_deg"] % 360.0, s["el_deg"]


def config_text(kind: str, u: UrcProcess, work: Path, mqtt_url: str, rotctld_port: int) -> tuple[str, dict]:
    """The config file's text and the dict fly_pass_on_sim merges for the same rotator."""
    tracking = f"[tracking]\ncatalog_dir = '{work / 'cat'}'\nmin_el_deg = {MIN_EL_DEG}\n"
    mqtt = f'[mqtt]\nurl = "{mqtt_url}"\nbase_topic = "{BASE}"\n'
    serve = f'[[serve]]\nprotocol = "rotctld"\ntcp = "127.0.0.1:{rotctld_port}"\n'
    if kind == "tartu-sim":
        return (f'[rotator]\nprofile = "tartu-urc"\n[hardware.sim]\nwind = false\n[api]\nport = {u.port}\n'
                f"{STATION}{tracking}{mqtt}{serve}"), {}
    example = (ROOT / "examples" / "g5500.toml").read_text()
    assert "[hardware.gpio]\n" in example
    text = example.replace("[hardware.gpio]\n", "[hardware.gpio]\nemulate = true\n", 1)
    doc = tomllib.loads(text)
    own = {"rotator": doc["rotator"], "hardware": {**doc["hardware"], "sim": {"wind": False}}}
    return text + f"\n[api]\nport = {u.port}\n{STATION}{tracking}{mqtt}{serve}", own


class Shared:
    """What the threads share: the latest status, the satellite up now, counters."""

    def __init__(self) -> None:
        self.lock = threading.Lock()
        self.stop = threading.Event()
        self.sky: tuple[float, float] | None = None     # look angles of the pass satellite up now
        self.counts = {"p_answers": 0, "p_rprt": 0, "p_timeouts": 0, "P_sent": 0, "P_rprt_nonzero": 0,
                       "client_reconnects": 0}

    def add(self, key: str, n: int = 1) -> None:
        with self.lock:
            self.counts[key] += n


def rotctld_client(port: int, sh: Shared) -> None:
    """A Gpredict-style client: ``p`` every 0.5 s; ``P`` when over OFF_DEG off a satellite up."""
    sock = f = None
    while not sh.stop.is_set():
        t0 = time.monotonic()
        try:
            if f is None:
                sock = socket.create_connection(("127.0.0.1", port), timeout=5.0)
                f = sock.makefile("rwb")
            f.write(b"p\n")
            f.flush()
            first = f.readline().decode().strip()
            if first.startswith("RPRT"):
                sh.add("p_rprt")
            else:
                az, el = float(first), float(f.readline().decode().strip())
                if el > 90.0:   # a flipped pass: the beam points the other way
                    az, el = az + 180.0, 180.0 - el
                sh.add("p_answers")
                sky = sh.sky
                if sky is not None and float(great_circle_deg(az, el, sky[0], sky[1])) > OFF_DEG:
                    f.write(f"P {sky[0]:.2f} {sky[1]:.2f}\n".encode())
                    f.flush()
                    sh.add("P_sent")
                    if f.readline().decode().strip() != "RPRT 0":
                        sh.add("P_rprt_nonzero")
        except (OSError, ValueError) as exc:
            sh.add("p_timeouts" if isinstance(exc, socket.timeout) else "client_reconnects")
            for c in (f, sock):
                try:
                    c and c.close()
                except OSError:
                    pass
            sock = f = None
            sh.stop.wait(1.0)
        sh.stop.wait(max(0.0, t0 + 0.5 - time.monotonic()))
    if sock is not None:
        sock.close()


def pauser(pid: int, sh: Shared, rng: random.Random, pauses: list) -> None:
    """SIGSTOP the I/O process for 1-3 s every 2-4 minutes."""
    while not sh.stop.wait(rng.uniform(120.0, 240.0)):
        hold_s = rng.uniform(1.0, 3.0)
        t = time.time()
        try:
            import os
            os.kill(pid, signal.SIGSTOP)
            time.sleep(hold_s)
        finally:
            os.kill(pid, signal.SIGCONT)
        pauses.append((round(t, 2), round(hold_s, 2)))


def timetable(t0: float, end: float, every_s: float, first_s: float, lead_s: float, rates: tuple) -> tuple:
    """AOS targets of the passes, and goto times in the room they leave."""
    aos = []
    a = t0 + first_s
    while a <= end - 60.0:   # (the run waits for the last LOS)
        aos.append(a)
        a += every_s
    busy = [(a - lead_s - 5.0, a + PASS_S[1] + AFTER_LOS_S) for a in aos]
    travel_max_s = max(60.0 / rates[0], 50.0 / rates[1]) + 3.0
    bound_s = travel_max_s + 30.0
    gotos, t = [], t0 + 5.0
    while t + bound_s <= end:
        clash = next((b for b in busy if t + bound_s > b[0] and t < b[1]), None)
        if clash is None:
            gotos.append(t)
            t += 60.0
        else:
            t = clash[1]
    return aos, gotos


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--config", choices=sorted(CONFIGS), default="tartu-sim")
    ap.add_argument("--minutes", type=float, default=60.0)
    ap.add_argument("--no-stress", action="store_true")
    ap.add_argument("--quiet", action="store_true", help="no stress-ng, no SIGSTOP pauses, no catalog reloads")
    ap.add_argument("--pass-every-min", type=float, default=5.0)
    ap.add_argument("--first-pass-min", type=float, default=None, help="first AOS (default: --pass-every-min)")
    ap.add_argument("--reload-every-min", type=float, default=10.0)
    ap.add_argument("--catalog-sets", type=int, default=CATALOG_SETS)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--json", default=None)
    args = ap.parse_args()
    if args.quiet:
        args.no_stress, args.reload_every_min = True, math.inf
    json_path = args.json or f"bench/results/busy-soak-{args.config}.json"
    profile, lead_s = CONFIGS[args.config]
    from urc.profiles import PROFILES   # (the axes' top rates: a goto's time bound)

    caps = PROFILES[profile]
    rates = (caps.az.max_rate_deg_per_s, caps.el.max_rate_deg_per_s)
    rng = random.Random(args.seed)

    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        setup_s = 90.0   # catalog, import, start: the timetable begins after
        t0 = time.time() + setup_s
        end = t0 + 60.0 * args.minutes
        first_s = 60.0 * (args.first_pass_min if args.first_pass_min is not None else args.pass_every_min)
        aos_targets, goto_times = timetable(t0, end, 60.0 * args.pass_every_min, first_s, lead_s, rates)
        print(f"{args.config}: {len(aos_targets)} passes, {len(goto_times)} gotos, "
              f"{'quiet' if args.quiet else 'no stress' if args.no_stress else 'stress-ng --cpu 8 --vm 2 --vm-bytes 256M'}",
              flush=True)
        picks = satellites_passing_between(
            work, TARTU, [(a - 10.0, a + 30.0) for a in aos_targets], MIN_EL_DEG + 2.0,
            [99100 + k for k in range(len(aos_targets))], [f"SOAK-{k}" for k in range(len(aos_targets))],
            accept=lambda p: PASS_S[0] <= p.los_unix_s - p.aos_unix_s <= PASS_S[1],
            min_el_deg=MIN_EL_DEG) if aos_targets else []
        catalog = work / "catalog.tle"
        catalog.write_text(synthetic_catalog(args.catalog_sets) + "".join(text for text, _, _ in picks))

        broker = Mosquitto(work / "mqtt").start()
        u = UrcProcess(work, profile=profile)
        rotctld_port = free_port()
        text, own = config_text(args.config, u, work, broker.url, rotctld_port)
        u.config.write_text(text)
        t_imp = time.monotonic()
        subprocess.run(URC + ["tle", "import", str(catalog), "--config", str(u.config)], check=True,
                       capture_output=True)
        import_s = time.monotonic() - t_imp
        stress = mq = None
        sh = Shared()
        threads: list[threading.Thread] = []
        pauses: list = []
        try:
            u.start_logged(work / "urc.log")
            if not args.no_stress:
                stress = subprocess.Popen(["stress-ng", "--cpu", "8", "--vm", "2", "--vm-bytes", "256M",
                                           "--timeout", f"{int(end - time.time() + 600)}s", "--quiet"],
                                          start_new_session=True)
            mq = Client(broker.port, subscribe=(f"{BASE}/cmd/result", f"{BASE}/event"))
            for _ in range(CLIENTS):
                threads.append(threading.Thread(target=rotctld_client, args=(rotctld_port, sh), daemon=True))
            if not args.quiet:
                threads.append(threading.Thread(target=pauser, args=(u.proc.pid, sh, rng, pauses), daemon=True))
            if time.time() > t0:
                print(f"warning: set-up ended {time.time() - t0:.0f} s late", flush=True)
            while time.time() < t0:
                time.sleep(0.2)
            for th in threads:
                th.start()
            run = soak(u, sh, rng, picks, goto_times, end, lead_s, rates, catalog, 60.0 * args.reload_every_min, mq)
        finally:
            sh.stop.set()
            for th in threads:
                th.join(timeout=10.0)
            if stress is not None:
                stop_process_group(stress, timeout_s=10)
            if mq is not None:
                mq.close()
            u.stop()
            broker.stop()
        unstressed = [fly_unstressed(profile, es, p, work / f"virtual-{k}", own) for k, (_, es, p) in enumerate(picks)]

    report(args, run, picks, unstressed, sh.counts, pauses, import_s, json_path)


def _count(xs) -> dict:
    out: dict = {}
    for x in xs:
        out[x] = out.get(x, 0) + 1
    return out


def fly_unstressed(profile: str, es, p, state_dir: Path, own: dict) -> float:
    from urc.testing.evaluate import fly_pass_on_sim
    state_dir.mkdir(parents=True, exist_ok=True)
    return fly_pass_on_sim(profile, es, TARTU, p, state_dir, config=own or None).stats.rms_deg


def soak(u, sh: Shared, rng, picks, goto_times, end, lead_s, rates, catalog, reload_every_s, mq) -> dict:
    """Run the timetable; poll status; return what was seen."""
    http = httpx.Client(timeout=1.0, limits=httpx.Limits(max_keepalive_connections=0))
    t_start = time.time()
    requests = [(p.aos_unix_s - lead_s, k) for k, (_, _, p) in enumerate(picks)]
    run_end = max([end] + [p.los_unix_s + 15.0 for _, _, p in picks])
    samples: list = []            # (t, az, el, beam az, beam el)
    events: list[str] = []
    stops: dict = {}
    last_stop_seen: list = []
    faults: set[str] = set()
    tick_late: list[float] = []
    loop_lag: list[float] = []
    pass_seen = [{"tracking": False, "program_states": set(), "program_ends": []} for _ in picks]
    program_ends: list = []
    gotos: list[dict] = []
    reloads: list[dict] = []
    track_requests: list[dict] = []
    poll_fail = poll_n = 0
    next_reload = t_start + reload_every_s
    gi = 0
    last_status: dict | None = None

    def request(k: int) -> None:
        _, _, p = picks[k]
        t = time.time()
        try:
            r = httpx.post(u.url + "/api/track/pass", json={"norad": p.norad_id, "aos": p.aos.isoformat()}, timeout=120)
            track_requests.append({"pass": k, "status": r.status_code, "s": round(time.time() - t, 2),
                                   "body": r.text[:200] if r.status_code != 200 else ""})
        except httpx.HTTPError as exc:
            track_requests.append({"pass": k, "status": None, "s": round(time.time() - t, 2), "body": str(exc)})

    def reload() -> None:
        t = time.monotonic()
        r = subprocess.run(URC + ["tle", "import", str(catalog), "--config", str(u.config)], capture_output=True)
        reloads.append({"t": round(time.time(), 1), "s": round(time.monotonic() - t, 1), "rc": r.returncode})

    def goto(n: int, pos: tuple[float, float]) -> None:
        az = (pos[0] + rng.uniform(-60.0, 60.0)) % 360.0
        el = rng.uniform(10.0, 60.0)
        # (the mechanical route may be most of a turn: from the park at 0 through a 400 deg
        # range, not the sky angle; a first run judged 6 gotos still on their way as lost)
        travel_s = max(420.0 / rates[0], abs(el - pos[1]) / rates[1]) + 3.0
        g = {"id": f"g{n}", "az": az, "el": el, "t": time.time(), "bound_s": travel_s + 30.0, "ok": None,
             "completed": None}
        gotos.append(g)
        try:
            mq.publish(f"{BASE}/cmd", json.dumps({"id": g["id"], "command": "goto", "az_deg": round(az, 2),
                                                  "el_deg": round(el, 2)}))
        except AssertionError:
            g["ok"] = "no PUBACK"

    while time.time() < run_end:
        now = time.time()
        while requests and now >= requests[0][0]:
            threading.Thread(target=request, args=(requests.pop(0)[1],), daemon=True).start()
        if now >= next_reload and now < end:
            next_reload += reload_every_s
            threading.Thread(target=reload, daemon=True).start()
        if gi < len(goto_times) and now >= goto_times[gi] and last_status is not None:
            threading.Thread(target=goto, args=(gi, beam(last_status)), daemon=True).start()
            gi += 1
        up = next((i for i, (_, _, p) in enumerate(picks) if p.aos_unix_s <= now <= p.los_unix_s), None)
        if up is not None:
            la = look_angles(picks[up][1], TARTU, [now])
            sh.sky = (float(la.az_deg[0]) % 360.0, float(la.el_deg[0]))
        else:
            sh.sky = None
        poll_n += 1
        t0 = time.time()
        try:
            s = http.get(u.url + "/api/status").json()
        except (httpx.HTTPError, ValueError):
            poll_fail += 1
            s = None
        t1 = time.time()
        if s is not None:
            last_status = s
            b = beam(s)
            # the truth is of the tick that made the status (t_s: CLOCK_MONOTONIC, shared by
            # every process), not of the request's middle: a slow answer under stress would
            # count the satellite's motion meanwhile as pointing error
            t_sample = s["t_s"] + (time.time() - time.monotonic()) if "t_s" in s else 0.5 * (t0 + t1)
            samples.append((t_sample, s["az_deg"], s["el_deg"], b[0], b[1]))
            for e in s.get("events", []):
                if e not in events:
                    events.append(e)
            ls = s.get("last_stop")
            if ls and (not last_stop_seen or last_stop_seen[-1] != ls):
                last_stop_seen.append(ls)
                stops[f"{ls.get('kind')}: {ls.get('reason')}"] = stops.get(f"{ls.get('kind')}: {ls.get('reason')}", 0) + 1
            faults.update(f"{f.get('kind')}: {f.get('reason')}" for f in s.get("faults", []))
            if s.get("tick_late_p99_ms") is not None:
                tick_late.append(float(s["tick_late_p99_ms"]))
            lag = s.get("loop_lag")
            if isinstance(lag, dict):
                v = lag.get("p99_ms", lag.get("lag_p99_ms"))
                if v is not None:
                    loop_lag.append(float(v))
            elif isinstance(lag, (int, float)):
                loop_lag.append(float(lag))
            pe = s.get("program_end")
            if pe and (not program_ends or program_ends[-1][1] != pe):
                program_ends.append((t1, pe))
                owner = next((i for i, (_, _, p) in enumerate(picks) if p.aos_unix_s - 300 <= t1 <= p.los_unix_s + 30), None)
                if owner is not None:
                    pass_seen[owner]["program_ends"].append({"t": round(t1, 1), **pe})
            if up is not None:
                if (s.get("tracking") or {}).get("state") == "tracking":
                    pass_seen[up]["tracking"] = True
                if s.get("program"):
                    pass_seen[up]["program_states"].add(s["program"].get("state"))
            for g in gotos:   # judge the gotos under way
                if g["completed"] is None:
                    if (abs(wrap180(s["az_deg"] - g["az"])) <= 1.0 and abs(s["el_deg"] - g["el"]) <= 1.0
                            and not s.get("moving")):
                        g["completed"], g["took_s"] = True, round(t1 - g["t"], 1)
                    elif t1 > g["t"] + g["bound_s"] or (t1 > g["t"] + 5.0 and not s.get("moving")):
                        g["completed"] = False   # (late, or at rest short of its target)
                        g["status"] = {k: s.get(k) for k in ("az_deg", "el_deg", "state", "moving", "last_stop")}
        time.sleep(max(0.0, t0 + POLL_S - time.time()))
    for g in gotos:
        results = mq.json_on(f"{BASE}/cmd/result")
        # (how it ended, said by urc itself: urc.mqtt.outcomes' second result)
        end_r = next((r for r in results if r.get("id") == g["id"] and r.get("state") not in (None, "accepted")), None)
        g["outcome"] = None if end_r is None else {k: end_r.get(k) for k in ("state", "kind", "reason")}
        res = next((r for r in results if r.get("id") == g["id"]), None)
        if g["ok"] is None:
            g["ok"] = None if res is None else bool(res.get("ok"))
            if res is not None and not res.get("ok"):
                g["error"] = res.get("error")
    http.close()
    return {"samples": samples, "events": events, "stops": stops, "last_stops": last_stop_seen,
            "faults": sorted(faults), "tick_late": tick_late, "loop_lag": loop_lag, "pass_seen": pass_seen,
            "gotos": gotos, "reloads": reloads, "track_requests": track_requests, "poll_n": poll_n,
            "poll_fail": poll_fail, "mqtt_events": [e.get("type") for e in mq.json_on(f"{BASE}/event")]}


def report(args, run, picks, unstressed, counts, pauses, import_s, json_path) -> None:
    samples = np.array(run["samples"]) if run["samples"] else np.zeros((0, 5))
    passes = []
    for k, ((_, es, p), seen) in enumerate(zip(picks, run["pass_seen"])):
        t = samples[:, 0] if len(samples) else np.zeros(0)
        up = (t >= p.aos_unix_s) & (t <= p.los_unix_s)
        rms = err15 = math.nan
        worst: list = []
        if up.any():
            la = look_angles(es, TARTU, t[up])
            err = great_circle_deg(samples[up, 3], samples[up, 4], la.az_deg, la.el_deg)
            rms = float(np.sqrt(np.mean(err ** 2)))
            # the largest errors, where in the pass and where the beam was (explains an outlier)
            worst = [{"s_after_aos": round(float(t[up][i] - p.aos_unix_s), 1), "error_deg": round(float(err[i]), 2),
                      "beam": [round(float(samples[up][i, 3]), 2), round(float(samples[up][i, 4]), 2)],
                      "satellite": [round(float(la.az_deg[i]), 2), round(float(la.el_deg[i]), 2)]}
                     for i in np.argsort(err)[::-1][:5]]
            after = t[up] >= p.aos_unix_s + 15.0
            err15 = float(err[after][0]) if after.any() else math.nan
        early = [e for e in seen["program_ends"] if e.get("why") != "done" or e["t"] < p.los_unix_s - 5.0]
        why = []
        if not seen["tracking"]:
            why.append("never tracking")
        if not (err15 <= 5.0):
            why.append(f"error 15 s after AOS {err15:.1f} deg")
        if early:
            why.append("program ended early: " + "; ".join(str(e.get("why")) for e in early))
        passes.append({"norad": p.norad_id, "aos": p.aos.isoformat(), "los": p.los.isoformat(),
                       "max_el_deg": round(p.max_el_deg, 1), "rms_deg": round(rms, 3),
                       "unstressed_rms_deg": round(unstressed[k], 3),
                       "ratio": round(rms / unstressed[k], 2) if unstressed[k] > 0 else None,
                       "error_15s_deg": round(err15, 2), "worst": worst, "lost": bool(why), "why": why,
                       "program_states": sorted(x for x in seen["program_states"] if x)})
    health_events = [e for e in run["events"] if "stopped (" in e]
    takeovers = [e for e in run["events"] if "froze" in e or "died" in e or "control process started again" in e]
    accepted = [g for g in run["gotos"] if g["ok"] is True]
    not_completed = [g for g in accepted if not g["completed"]]
    result = {
        "config": args.config, "minutes": args.minutes, "stress": not args.no_stress, "quiet": args.quiet,
        "catalog_sets": args.catalog_sets, "catalog_import_s": round(import_s, 1), "reloads": run["reloads"],
        "passes": passes, "passes_flown": sum(not p["lost"] for p in passes),
        "passes_lost": sum(p["lost"] for p in passes),
        "stops_by_reason": run["stops"], "stop_events": health_events, "takeovers": takeovers,
        "gotos_sent": len(run["gotos"]), "gotos_accepted": len(accepted),
        "gotos_refused": [g for g in run["gotos"] if g["ok"] is False],
        "gotos_no_result": sum(g["ok"] is None for g in run["gotos"]),
        "accepted_not_completed": not_completed,
        "rotctld": counts, "sigstop_pauses": pauses, "track_requests": run["track_requests"],
        "status_polls": run["poll_n"], "status_poll_failures": run["poll_fail"],
        "loop_lag_p99_ms": round(pct(run["loop_lag"], 0.99), 1) if run["loop_lag"] else None,
        "loop_lag_max_ms": round(max(run["loop_lag"]), 1) if run["loop_lag"] else None,
        "tick_late_p99_ms_max": max(run["tick_late"]) if run["tick_late"] else None,
        "faults": run["faults"], "mqtt_event_types": sorted(set(run["mqtt_events"])), "events": run["events"],
    }
    rows = [("config", f"{args.config}, {args.minutes:g} min, "
                       f"{'stress-ng --cpu 8 --vm 2 --vm-bytes 256M' if result['stress'] else 'quiet' if args.quiet else 'no stress'}"),
            ("catalog", f"{args.catalog_sets} sets, import {import_s:.1f} s, reloads "
                        + ", ".join(f"{r['s']} s (rc {r['rc']})" for r in run["reloads"]) or "none"),
            ("passes flown / lost", f"{result['passes_flown']} / {result['passes_lost']}")]
    for p in passes:
        rows.append((f"  pass {p['norad']} AOS {p['aos'][11:19]}",
                     f"max el {p['max_el_deg']}, RMS {p['rms_deg']} deg vs unstressed {p['unstressed_rms_deg']} "
                     f"(x{p['ratio']}), 15 s after AOS {p['error_15s_deg']} deg"
                     + (f"  LOST: {'; '.join(p['why'])}" if p["lost"] else "")))
    rows += [("stops by reason", "; ".join(f"{k} x{v}" for k, v in run["stops"].items()) or "none"),
             ("gotos sent / accepted / refused", f"{len(run['gotos'])} / {len(accepted)} / "
                                                 f"{len(result['gotos_refused'])}"),
             ("accepted but not completed (goal 0)", str(len(not_completed))),
             ("gotos' ends as urc said them", "; ".join(
                 f"{k} x{v}" for k, v in sorted(_count(g["outcome"]["state"] if g.get("outcome") else "none"
                                                       for g in accepted).items())) or "none"),
             ("takeovers (goal 0)", str(len(takeovers))),
             ("RPRT answers to p (goal 0)", f"{counts['p_rprt']} of {counts['p_rprt'] + counts['p_answers']}"),
             ("p timeouts / reconnects", f"{counts['p_timeouts']} / {counts['client_reconnects']}"),
             ("P sent (replace the program)", f"{counts['P_sent']} ({counts['P_rprt_nonzero']} not RPRT 0)"),
             ("SIGSTOP pauses", f"{len(pauses)}: " + ", ".join(f"{h} s" for _, h in pauses)),
             ("status polls failed", f"{run['poll_fail']} of {run['poll_n']}"),
             ("loop lag p99", f"{result['loop_lag_p99_ms']} ms" if run["loop_lag"] else "n/a (status has no loop_lag)"),
             ("tick_late_p99_ms max", str(result["tick_late_p99_ms_max"])),
             ("faults", "; ".join(run["faults"]) or "none")]
    width = max(len(r[0]) for r in rows)
    for name, value in rows:
        print(f"  {name:<{width}}  {value}")
    write_json(result, json_path)


if __name__ == "__main__":
    main()
