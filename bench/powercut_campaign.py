"""Power-cut campaign (issue 9): kill -9 real ``urc run`` processes at random moments.

For every simulated profile, cycles of: start ``urc run`` (sim backend) on one state
directory, re-reference to the simulator's truth if the position is uncertain (what a
person would do), start a procedure — a move, a park, BIG-RAS limit-switch homing, the
SARCNET magnetometer calibration, a settings save — kill -9 at a random moment in it,
restart, and compare the reported position and its uncertainty bound with the
simulator's truth (status ``simulator_truth``; kill -9 of the process is the power cut:
the simulated iron coasts down unpowered).

A *loss* is the truth outside the reported bound while the position is called known
(known = within the axis' hold band plus the estimate's own slack: counts, noise, gear
play). Truth outside the bound of an uncertain position is counted apart ("outside
bound"). A start that fails (e.g. no config after a settings save) is counted too.
Prints a table (cycles per profile and procedure, losses, largest error while known,
bounds) and writes JSON (default bench/results/powercut.json).

Usage: python bench/powercut_campaign.py [--cycles-per-profile 20] [--profiles a,b]
       [--seed 1] [--json PATH]
       python bench/powercut_campaign.py --merge run1.json run2.json ... [--json PATH]
"""

from __future__ import annotations

import argparse
import json
import random
import signal
import sys
import tempfile
import time
from collections import defaultdict
from pathlib import Path

import httpx

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from urc_process import UrcProcess  # noqa: E402

from bench_report import write_json  # noqa: E402
from urc.profiles import PROFILES  # noqa: E402

#: (procedure, how long after starting it the kill may come, seconds)
KILL_WINDOW_S = {"move": (0.02, 5.0), "park": (0.02, 4.0), "homing": (0.2, 25.0),
                 "calibration": (0.5, 30.0), "settings": (0.0, 0.15)}


def procedures(profile: str) -> list[str]:
    caps = PROFILES[profile]
    out = ["move", "park", "settings"]
    if caps.az.limit_switches:
        out.append("homing")
    if caps.az.sensor.kind == "magnetometer":
        out.append("calibration")
    return out


def known_slack_deg(profile: str, axis: str) -> float:
    """What a known position may be off: the hold band plus the estimate's slack."""
    ax = PROFILES[profile].axis(axis)
    s = ax.sensor
    band = max(ax.tolerance_deg, 1.5 * s.resolution_deg + 3.0 * s.noise_deg)
    return band + 2.0 * s.resolution_deg + 4.0 * s.noise_deg + ax.backlash_deg


class Station:
    def __init__(self, profile: str, workdir: Path):
        self.profile = profile
        workdir.mkdir(parents=True, exist_ok=True)
        self.proc = UrcProcess(workdir, profile=profile)

    def start(self) -> dict | None:
        try:
            self.proc.start(timeout_s=240.0)  # a loaded machine starts slowly
        except AssertionError as exc:
            if self.proc.proc is not None and self.proc.proc.poll() is None:
                self.proc.proc.kill()
                self.proc.proc.wait()
            return {"start_failed": str(exc)[-300:]}
        return self.proc.status()

    def kill(self) -> None:
        self.proc.proc.send_signal(signal.SIGKILL)
        self.proc.proc.wait()

    def post(self, path: str, body: dict | None = None) -> httpx.Response:
        return self.proc.post(path, body)

    def ready(self, rng: random.Random) -> None:
        """Known position and no faults, as an operator would leave it."""
        s = self.proc.status()
        if s["faults"]:
            self.post("/api/clear-faults")
        if not s["position_known"]:
            # re-reference the uncertain axes to the truth (a parked axis may rest a
            # hair outside its soft limit: set-position takes values inside them)
            body = {}
            for axis in ("az", "el"):
                if s[axis]["uncertainty_deg"]:
                    lo, hi = s["limits"][axis]
                    body[f"{axis}_deg"] = min(max(s["simulator_truth"][axis]["deg"], lo), hi) + s["offsets"][axis]
            r = self.post("/api/set-position", body)
            if r.status_code != 200:
                raise AssertionError(f"set-position refused: {r.text}")
        self.proc.wait(lambda s: s["position_known"] and not s["faults"], timeout_s=10.0)

    def begin(self, what: str, rng: random.Random) -> str:
        caps = PROFILES[self.profile]
        if what == "move" or (what == "park" and self.proc.status()["parked"]):
            lo, hi = caps.az.min_deg, caps.az.max_deg
            az = rng.uniform(max(lo, 0.0), min(hi, 359.0))
            if hi > 365.0 and rng.random() < 0.3:
                az = rng.uniform(361.0, hi - 1.0)  # an explicit overlap pose
            el = rng.uniform(max(caps.el.min_deg, 5.0), min(caps.el.max_deg, 85.0))
            r = self.post("/api/goto", {"az_deg": az, "el_deg": el})
            if what == "park":  # from somewhere else than park: go there first, then park
                self.proc.wait(lambda s: not s["moving"], timeout_s=180.0)
                r = self.post("/api/park")
            return f"{what} {r.status_code}"
        if what == "park":
            return f"park {self.post('/api/park').status_code}"
        if what in ("homing", "calibration"):
            # from somewhere in the range, so the procedure has a way to go
            self.begin("move", rng)
            self.proc.wait(lambda s: not s["moving"] and s["az"]["mode"] in ("holding", "idle"), timeout_s=180.0)
        if what == "homing":
            axis = rng.choice(["az", "el"])
            return f"homing {axis} {self.post('/api/calibration/homing', {'axis': axis}).status_code}"
        if what == "calibration":
            return f"magnetometer {self.post('/api/calibration/magnetometer').status_code}"
        if what == "settings":
            doc = httpx.get(self.proc.url + "/api/settings", timeout=5).json()["config"]
            doc.setdefault("park", {})["idle_park_s"] = rng.choice([0, 3600, 7200])
            r = self.post("/api/settings", doc)
            return f"settings {r.status_code}"
        raise ValueError(what)


def judge(profile: str, s: dict) -> dict:
    out = {"known": s["position_known"], "axes": {}}
    for axis in ("az", "el"):
        ax, truth = s[axis], s["simulator_truth"][axis]["deg"]
        err = abs(ax["pos_deg"] - truth)
        unc = ax["uncertainty_deg"]
        out["axes"][axis] = {"pos_deg": ax["pos_deg"], "truth_deg": truth, "err_deg": err,
                             "uncertainty_deg": unc,
                             "loss": unc == 0 and err > known_slack_deg(profile, axis),
                             "outside_bound": unc > 0 and err > unc}
    return out


def campaign(profile: str, cycles: int, rng: random.Random, workroot: Path) -> list[dict]:
    st = Station(profile, workroot / profile)
    results = []
    first = st.start()
    if first and "start_failed" in first:
        return [{"profile": profile, "procedure": "start", "start_failed": first["start_failed"]}]
    procs = procedures(profile)
    for i in range(cycles):
        what = procs[i % len(procs)]
        try:
            st.ready(rng)
            note = st.begin(what, rng)
            lo, hi = KILL_WINDOW_S[what]
            time.sleep(rng.uniform(lo, hi))
            before = st.proc.status()
        except (AssertionError, httpx.HTTPError) as exc:
            results.append({"profile": profile, "procedure": what, "error": str(exc)[-200:]})
            before = None
        st.kill()
        after = st.start()
        row = {"profile": profile, "procedure": what, "note": note if before else "",
               "moving_at_kill": bool(before and before["moving"])}
        if after is None or "start_failed" in (after or {}):
            row["start_failed"] = (after or {}).get("start_failed", "no status")
            results.append(row)
            # the campaign goes on with a fresh station for this profile
            st = Station(profile, workroot / f"{profile}-{i}")
            st.start()
            continue
        row.update(judge(profile, after))
        results.append(row)
        print(f"  {profile:13} {i + 1:3}/{cycles} {what:11} moving={row['moving_at_kill']!s:5} "
              f"known={row['known']!s:5} " + "  ".join(
                  f"{a} err {v['err_deg']:7.3f} ±{v['uncertainty_deg']:7.2f}" + (" LOSS" if v["loss"] else "")
                  + (" OUTSIDE" if v["outside_bound"] else "") for a, v in row["axes"].items()), flush=True)
    st.proc.stop()
    return results


def table(rows: list[dict]) -> dict:
    groups: dict[tuple[str, str], list[dict]] = defaultdict(list)
    for r in rows:
        groups[(r["profile"], r["procedure"])].append(r)
    summary = {}
    print(f"\n{'profile':13} {'procedure':11} {'cycles':>6} {'known':>5} {'losses':>6} {'outside':>7} "
          f"{'failed':>6} {'max err known':>13} {'max bound':>9} {'med bound':>9}")
    tot = defaultdict(int)
    for (profile, proc), rs in sorted(groups.items()):
        judged = [r for r in rs if "axes" in r]
        known = [r for r in judged if r["known"]]
        losses = sum(any(a["loss"] for a in r["axes"].values()) for r in judged)
        outside = sum(any(a["outside_bound"] for a in r["axes"].values()) for r in judged)
        failed = sum("start_failed" in r for r in rs)
        max_err_known = max((a["err_deg"] for r in judged for a in r["axes"].values()
                             if a["uncertainty_deg"] == 0), default=0.0)
        bounds = sorted(a["uncertainty_deg"] for r in judged for a in r["axes"].values() if a["uncertainty_deg"])
        max_b = bounds[-1] if bounds else 0.0
        med_b = bounds[len(bounds) // 2] if bounds else 0.0
        summary[f"{profile}/{proc}"] = {"cycles": len(rs), "known": len(known), "losses": losses,
                                        "outside_bound": outside, "start_failed": failed,
                                        "max_err_known_deg": max_err_known, "max_bound_deg": max_b,
                                        "median_bound_deg": med_b}
        for k, v in (("cycles", len(rs)), ("losses", losses), ("outside", outside), ("failed", failed)):
            tot[k] += v
        print(f"{profile:13} {proc:11} {len(rs):6} {len(known):5} {losses:6} {outside:7} {failed:6} "
              f"{max_err_known:13.3f} {max_b:9.2f} {med_b:9.2f}")
    print(f"{'total':25} {tot['cycles']:6} {'':5} {tot['losses']:6} {tot['outside']:7} {tot['failed']:6}")
    summary["total"] = dict(tot)
    return summary


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--cycles-per-profile", type=int, default=20)
    ap.add_argument("--profiles", default=",".join(sorted(PROFILES)))
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--json", default="bench/results/powercut.json")
    ap.add_argument("--merge", nargs="*", metavar="JSON",
                    help="only tabulate the cycles of earlier runs (e.g. one per profile, run in parallel)")
    args = ap.parse_args()
    if args.merge:
        runs = [json.loads(Path(f).read_text()) for f in args.merge]
        rows = [r for run in runs for r in run["cycles"]]
        write_json({"summary": table(rows), "cycles": rows, "seeds": [run["seed"] for run in runs]}, args.json)
        return
    rng = random.Random(args.seed)
    rows: list[dict] = []
    with tempfile.TemporaryDirectory(prefix="urc-powercut-") as d:
        for profile in args.profiles.split(","):
            print(f"{profile}:", flush=True)
            rows += campaign(profile, args.cycles_per_profile, rng, Path(d))
    summary = table(rows)
    write_json({"summary": summary, "cycles": rows, "seed": args.seed}, args.json)


if __name__ == "__main__":
    main()
