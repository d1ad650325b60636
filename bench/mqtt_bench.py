"""MQTT benchmark: real ``urc run`` stations on a real Mosquitto.

1. Command-to-motion latency: a goto sent through the broker (``<base>/cmd``) against the
   same goto over rotctld (``P az el``) to the same urc in the same run, interleaved.
   Measured per command: until it is acknowledged (``cmd/result`` / ``RPRT 0``), until
   the API's status shows the new setpoint (read back to back), and until the simulated
   azimuth gear turns (its truth file, read every 2 ms) — after the acknowledgement the
   motion is the same control loop for both.
2. Messages and bytes per minute per station while tracking NOAA 19 high overhead
   (status, events and results on ``urc/<station>/#``, topic + payload bytes).
3. How many stations one broker and this machine carry with every station's status
   under 1 s old: N stations tracking at once; each second every station's age
   (now - t_unix_s of its newest status) is sampled; CPU of the broker and of all urc
   processes (I/O and control) over the window.
4. The control loop with MQTT on and the broker flapping: two stations tracking side by
   side, one with [mqtt], one without; lateness/tick p99 and stalls with the broker
   steady, then killed and restarted every 2 s.
Prints a table, writes JSON (default bench/results/mqtt.json). Never gates CI.
Usage: python bench/mqtt_bench.py [--trials 20] [--window-s 60] [--stations 1,2,4] [--phase-s 12]
       [--only latency,tracking,flapping] [--json PATH]
"""

from __future__ import annotations

import argparse
import json
import os
import socket
import statistics
import sys
import tempfile
import threading
import time
import uuid
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(ROOT / "src"))
import httpx  # noqa: E402
from bench_report import cpu_s, pct, write_json  # noqa: E402
from mqtt.broker import Client, Mosquitto, overhead_station  # noqa: E402
from urc_process import UrcProcess, free_port, wait_until  # noqa: E402

def urc_pids(u: UrcProcess) -> list[int]:
    return [u.proc.pid, u.control_pid()]


def catalog(work: Path) -> tuple[str, Path]:
    from click.testing import CliRunner

    from urc.cli import main as cli
    where, tle = overhead_station()
    cat = work / "cat"
    res = CliRunner().invoke(cli, ["tle", "import", str(tle), "--catalog-dir", str(cat)])
    assert res.exit_code == 0, res.output
    return where, cat


def make_station(work: Path, name: str, url: str, where: str = "", cat: Path | None = None,
                 serve: list | None = None) -> UrcProcess:
    d = work / name
    d.mkdir()
    extra = f'[station]\nname = "{name}"\n{where}'
    if cat is not None:
        extra += f"[tracking]\ncatalog_dir = '{cat}'\n"
    extra += f'[mqtt]\nurl = "{url}"\n'
    return UrcProcess(d, serve=serve, extra=extra)


# ---------------------------------------------------------------------- 1. latency
class StatusPoller:
    """Reads /api/status back to back in a thread: (time received, target az, az mode)."""

    def __init__(self, url: str):
        self.samples: list[tuple[float, float | None, str]] = []
        self.gets_ms: list[float] = []
        self._stop = threading.Event()
        self._http = httpx.Client(base_url=url, timeout=5)
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while not self._stop.is_set():
            t = time.perf_counter()
            s = self._http.get("/api/status").json()
            now = time.perf_counter()
            self.gets_ms.append((now - t) * 1000)
            self.samples.append((now, s["target_az_deg"], s["az"]["mode"]))

    def first(self, since: float, pred) -> float | None:
        return next((t for t, az, mode in list(self.samples) if t > since and pred(az, mode)), None)

    def close(self) -> None:
        self._stop.set()
        self._thread.join()
        self._http.close()


class TruthPoller:
    """Reads the simulator's truth file (written at most every 20 ms while something
    changes) every 2 ms: (time read, azimuth gear rate deg/s) - the iron itself moving."""

    def __init__(self, path: Path):
        self.path = path
        self.samples: list[tuple[float, float]] = []
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while not self._stop.is_set():
            try:
                rate = json.loads(self.path.read_text())["axes"]["az"]["gear_deg_per_s"]
            except (OSError, ValueError, KeyError):
                rate = None
            if rate is not None:
                self.samples.append((time.perf_counter(), rate))
            time.sleep(0.002)

    def first_moving(self, since: float) -> float | None:
        return next((t for t, rate in list(self.samples) if t > since and abs(rate) > 0.1), None)

    def still(self) -> bool:
        return bool(self.samples) and abs(self.samples[-1][1]) < 0.01

    def close(self) -> None:
        self._stop.set()
        self._thread.join()


def latency(work: Path, broker: Mosquitto, trials: int) -> dict:
    rot_port = free_port()
    u = make_station(work, "lat", broker.url, serve=[{"protocol": "rotctld", "tcp": f"127.0.0.1:{rot_port}"}])
    try:
        u.start(timeout_s=120.0)
    except BaseException:
        u.stop()
        raise
    base = "urc/lat"
    c = Client(broker.port, subscribe=(f"{base}/cmd/result",))
    results: dict[str, float] = {}
    got = threading.Condition()

    def on_result(_c, _u, msg) -> None:  # the moment the result arrives, on paho's thread
        with got:
            results[json.loads(msg.payload)["id"]] = time.perf_counter()
            got.notify_all()
    c.c.on_message = on_result
    http = httpx.Client(base_url=u.url, timeout=5)
    rot = socket.create_connection(("127.0.0.1", rot_port))
    rot.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    poller = StatusPoller(u.url)
    truth = TruthPoller(u.state_dir / "simulator-truth.json")
    out: dict[str, dict[str, list[float]]] = {k: {"ack_ms": [], "setpoint_ms": [], "motion_ms": []}
                                              for k in ("mqtt", "rotctld")}
    try:
        for i in range(trials):
            for path in (("mqtt", "rotctld") if i % 2 == 0 else ("rotctld", "mqtt")):
                http.post("/api/stop")
                wait_until(lambda: (lambda s: not s["moving"] and s["az"]["mode"] in ("idle", "holding"))(
                    http.get("/api/status").json()) and truth.still(), 60, "at rest")
                az = 100.0 + 20.0 * (i % 2) + (5.0 if path == "mqtt" else 0.0) + 0.1 * i
                t0 = time.perf_counter()
                if path == "mqtt":
                    cmd_id = uuid.uuid4().hex[:8]
                    c.c.publish(f"{base}/cmd", json.dumps({"id": cmd_id, "command": "goto", "az_deg": az,
                                                           "el_deg": 30.0}), qos=0)
                    with got:
                        got.wait_for(lambda: cmd_id in results, 20)
                    ack = results[cmd_id]
                else:
                    rot.sendall(f"P {az:.2f} 30.00\n".encode())
                    reply = rot.recv(64)
                    ack = time.perf_counter()
                    assert reply.startswith(b"RPRT 0"), reply
                setpoint = wait_until(lambda: poller.first(t0, lambda taz, _m: taz is not None and abs(taz - az) < 0.01),
                                      20, "setpoint")
                motion = wait_until(lambda: truth.first_moving(t0), 20, "the simulated iron moving")
                out[path]["ack_ms"].append((ack - t0) * 1000)
                out[path]["setpoint_ms"].append((setpoint - t0) * 1000)
                out[path]["motion_ms"].append((motion - t0) * 1000)
    finally:
        poller.close()
        truth.close()
        rot.close()
        http.close()
        c.close()
        u.stop()
    res = {path: {k: {"median": statistics.median(v), "p95": pct(v, 0.95), "n": len(v)} for k, v in d.items()}
           for path, d in out.items()}
    res["status_read_ms_median"] = statistics.median(poller.gets_ms)
    return res


# ---------------------------------------------------------------------- 2 and 3. tracking
def tracking(work: Path, broker: Mosquitto, n: int, window_s: float, where: str, cat: Path) -> dict:
    names = [f"s{n}-{i}" for i in range(n)]
    stations = [make_station(work, name, broker.url, where, cat) for name in names]
    c = None
    try:  # (every station started is stopped, whatever fails)
        for u in stations:
            u.start(timeout_s=120.0)  # (a busy host starts many slowly)
        c = Client(broker.port, subscribe=("urc/#",))
        for u in stations:  # (planning the pass takes a while on a busy host)
            assert httpx.post(u.url + "/api/track", json={"kind": "satellite", "norad": 33591},
                              timeout=120).status_code == 200
        for name in names:
            wait_until(lambda: ((c.last(f"urc/{name}/status") or {}).get("tracking") or {}).get("state")
                       in ("tracking", "prepositioning"), 60, f"{name} tracking")
        time.sleep(3.0)  # settled on the track
        pids = [p for u in stations for p in urc_pids(u)]
        with c.lock:
            start_n = len(c.messages)
        cpu0 = {p: cpu_s(p) for p in pids + [broker.proc.pid]}
        t0 = time.monotonic()
        ages: list[float] = []
        while time.monotonic() - t0 < window_s:
            time.sleep(1.0)
            now = time.time()
            for name in names:
                last = c.last(f"urc/{name}/status")
                ages.append(now - last["t_unix_s"])
        elapsed = time.monotonic() - t0
        cpu = {p: (cpu_s(p) - cpu0[p]) / elapsed * 100.0 for p in cpu0}
        with c.lock:
            window = c.messages[start_n:]
        per = {name: [(t, p) for t, p, _ in window if t.startswith(f"urc/{name}/")] for name in names}
        states = {name: (c.last(f"urc/{name}/status") or {}).get("state") for name in names}
    finally:
        if c is not None:
            c.close()
        for u in stations:
            u.stop()
    msgs = [len(v) / elapsed * 60.0 for v in per.values()]
    byts = [sum(len(t) + len(p) for t, p in v) / elapsed * 60.0 for v in per.values()]
    status_sizes = [len(p) for v in per.values() for t, p in v if t.endswith("/status")]
    return {"stations": n, "window_s": round(elapsed, 1), "states_at_end": states,
            "msgs_per_min_per_station": statistics.mean(msgs), "bytes_per_min_per_station": statistics.mean(byts),
            "status_bytes_mean": statistics.mean(status_sizes) if status_sizes else 0,
            "status_age_s": {"median": statistics.median(ages), "p99": pct(ages, 0.99), "max": max(ages)},
            "all_under_1s": max(ages) < 1.0,
            "cpu_percent": {"broker": cpu[broker.proc.pid],
                            "urc_io_per_station": statistics.mean(cpu[u] for u in pids[0::2]),
                            "urc_control_per_station": statistics.mean(cpu[u] for u in pids[1::2]),
                            "urc_total": sum(cpu[p] for p in pids)}}


# ---------------------------------------------------------------------- 4. the loop, broker flapping
def flapping(work: Path, broker: Mosquitto, phase_s: float, where: str, cat: Path) -> dict:
    """Two stations tracking side by side, one with MQTT and one without: the control
    loop's lateness p99 and stalls (its own window: the last 500 ticks) with the broker
    steady, then killed and restarted every 2 s."""
    with_mqtt = make_station(work, "flap-mqtt", broker.url, where, cat)
    d = work / "flap-none"
    d.mkdir()
    without = UrcProcess(d, extra=f'[station]\nname = "flap-none"\n{where}[tracking]\ncatalog_dir = \'{cat}\'\n')
    out: dict = {}
    log = ""
    try:
        with_mqtt.start(timeout_s=120.0)
        without.start(timeout_s=120.0)
        for u in (with_mqtt, without):
            assert httpx.post(u.url + "/api/track", json={"kind": "satellite", "norad": 33591},
                              timeout=120).status_code == 200
        time.sleep(5.0)
        for phase in ("broker steady", "broker flapping"):
            t0 = time.monotonic()
            flaps = 0
            while time.monotonic() - t0 < phase_s:
                if phase == "broker flapping":
                    broker.kill()
                    time.sleep(1.0)
                    broker.start()
                    flaps += 1
                    time.sleep(1.0)
                else:
                    time.sleep(1.0)
            out[phase] = {"flaps": flaps}
            if flaps:  # telemetry resumes: a status taken after the last restart reaches a client
                back = time.time()
                c = Client(broker.port, subscribe=("urc/flap-mqtt/status",))
                try:
                    wait_until(lambda: any(m["t_unix_s"] > back for m in c.json_on("urc/flap-mqtt/status")),
                               60, "telemetry after the flapping")
                    out[phase]["telemetry_resumed_after_s"] = round(time.time() - back, 1)
                finally:
                    c.close()
            for name, u in (("mqtt", with_mqtt), ("no mqtt", without)):
                s = u.status()
                out[phase][name] = {"late_p99_ms": s["loop"]["late_p99_ms"], "tick_p99_ms": s["loop"]["tick_p99_ms"],
                                    "stalls": s["loop"]["stalls"], "faults": [f["kind"] for f in s["faults"]],
                                    "tracking": (s.get("tracking") or {}).get("target")}
    finally:
        log = with_mqtt.stop()
        without.stop()
    out["lost_broker_log_lines"] = log.count("unreachable or lost")
    out["broker_back_log_lines"] = log.count("reachable again")
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--trials", type=int, default=20, help="gotos per path (latency)")
    ap.add_argument("--window-s", type=float, default=60.0, help="tracking window per station count")
    ap.add_argument("--stations", default="1,2,4", help="station counts to try (comma separated)")
    ap.add_argument("--phase-s", type=float, default=12.0, help="loop timing: each broker phase")
    ap.add_argument("--only", default="latency,tracking,flapping", help="which parts to run")
    ap.add_argument("--json", default=str(ROOT / "bench" / "results" / "mqtt.json"))
    args = ap.parse_args()
    work = Path(tempfile.mkdtemp(prefix="urc-mqtt-bench-"))
    broker = Mosquitto(work / "broker").start()
    parts = set(args.only.split(","))
    lat, runs, flap = None, [], None
    ratio = None
    print(f"MQTT benchmark ({os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.1f} at start, Mosquitto, "
          "urc run on the simulator)", flush=True)
    try:
        if "latency" in parts:
            lat = latency(work, broker, args.trials)
            ratio = report_latency(lat)
        where, cat = catalog(work)
        if "tracking" in parts:
            for n in args.stations.split(","):
                runs.append(tracking(work, broker, int(n), args.window_s, where, cat))
            report_tracking(runs)
        if "flapping" in parts:
            flap = flapping(work, broker, args.phase_s, where, cat)
    finally:
        broker.stop()
    load = os.getloadavg()
    if flap is not None:
        print("\ncontrol loop while tracking, MQTT on vs off side by side (lateness / tick p99 ms, stalls)")
        for phase in ("broker steady", "broker flapping"):
            r = flap[phase]
            print(f"  {phase:<16} " + "   ".join(
                f"{name}: {r[name]['late_p99_ms']:.2f} / {r[name]['tick_p99_ms']:.2f} ms, {r[name]['stalls']} stalls, "
                f"faults {r[name]['faults'] or 'none'}" for name in ("mqtt", "no mqtt")) +
                (f"  ({r['flaps']} restarts; telemetry back {r['telemetry_resumed_after_s']:.1f} s after the last)"
                 if r["flaps"] else ""))
        print(f"  log lines: broker lost x{flap['lost_broker_log_lines']}, back x{flap['broker_back_log_lines']}")
    write_json({"load_average": load, "latency": lat, "ratio_mqtt_over_rotctld": ratio, "tracking": runs,
                "loop_with_broker_flapping": flap}, args.json)


def report_latency(lat: dict) -> dict:
    print(f"\ncommand to motion, goto az/el (ms, median / p95; the status is read every "
          f"{lat['status_read_ms_median']:.1f} ms)")
    print(f"  {'':<10} {'acknowledged':>16} {'setpoint in status':>20} {'iron turns':>18}")
    for path in ("mqtt", "rotctld"):
        d = lat[path]
        print(f"  {path:<10} " + " ".join(f"{d[k]['median']:>8.1f} / {d[k]['p95']:<6.1f}".rjust(w) for k, w in
                                           (("ack_ms", 16), ("setpoint_ms", 20), ("motion_ms", 18))))
    ratio = {k: lat["mqtt"][k]["median"] / lat["rotctld"][k]["median"] for k in ("ack_ms", "setpoint_ms", "motion_ms")}
    print("  mqtt/rotctld " + ", ".join(f"{k[:-3]} x{v:.2f}" for k, v in ratio.items()), flush=True)
    return ratio


def report_tracking(runs: list[dict]) -> None:
    print("\nwhile tracking NOAA 19 (per station)")
    print(f"  {'N':>3} {'msgs/min':>9} {'KiB/min':>8} {'status B':>9} {'age p99 s':>10} {'age max s':>10} "
          f"{'<1 s':>5} {'broker %':>9} {'urc I/O %':>10} {'urc ctl %':>10}")
    for r in runs:
        print(f"  {r['stations']:>3} {r['msgs_per_min_per_station']:>9.0f} {r['bytes_per_min_per_station'] / 1024:>8.1f} "
              f"{r['status_bytes_mean']:>9.0f} {r['status_age_s']['p99']:>10.2f} {r['status_age_s']['max']:>10.2f} "
              f"{'yes' if r['all_under_1s'] else 'NO':>5} {r['cpu_percent']['broker']:>9.1f} "
              f"{r['cpu_percent']['urc_io_per_station']:>10.1f} {r['cpu_percent']['urc_control_per_station']:>10.1f}",
              flush=True)


if __name__ == "__main__":
    main()
