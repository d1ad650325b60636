"""The safety property (tests/rotator/test_safety_properties.py) in benchmark mode: many
more random command sequences per profile than the test runs, each judged by the
simulator's truth every tick, and the worst measured: how far past a soft limit each
axis went, and how deep into a keep-out zone (the mast, the roof) the beam went after
being outside it (negative: the nearest it came, still inside the limits or outside
the zones). Beside them the allowance the test grants, term by term.
Prints a table, writes JSON (default bench/results/safety_property.json).
Usage: python bench/safety_property_bench.py [--examples 200] [--profiles a,b] [--seed 0] [--json PATH]
"""

from __future__ import annotations

import argparse
import logging
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(ROOT / "tests" / "service"))

from hypothesis import HealthCheck, Phase, given, seed, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from bench_report import write_json  # noqa: E402
from conftest import ALL_PROFILES, Bench  # noqa: E402
from test_safety_properties import allowance_terms, check_sequence, step  # noqa: E402


def terms_of(profile: str) -> dict[str, dict[str, float]]:
    with tempfile.TemporaryDirectory() as tmp:
        rot = Bench(profile, Path(tmp)).rot
        return {a: allowance_terms(rot, a) for a in rot.caps.axes}


def measure(profile: str, examples: int, seed_value: int) -> dict:
    worst: dict[str, float] = {}
    runs = [0]

    @seed(seed_value)
    @settings(max_examples=examples, deadline=None, database=None, phases=[Phase.generate],
              suppress_health_check=list(HealthCheck))
    @given(steps=st.lists(step, min_size=1, max_size=5))
    def run(steps):
        runs[0] += 1
        check_sequence(profile, steps, measured=worst)

    t0 = time.perf_counter()
    run()
    return {"examples": runs[0], "wall_s": time.perf_counter() - t0, **worst}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--examples", type=int, default=200, help="command sequences per profile (the test: 12)")
    ap.add_argument("--profiles", default=",".join(ALL_PROFILES))
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", default=str(ROOT / "bench" / "results" / "safety_property.json"))
    args = ap.parse_args()
    logging.disable(logging.WARNING)   # (each example's start and guard events)
    rows = []
    head = (f"{'profile':<13} {'n':>5} {'az past':>8} {'el past':>8} {'in zone':>8} {'viol':>5} "
            f"{'allow az':>9} {'allow el':>9}  az terms (quantum noise tick guard stopping)")
    print(head)
    print("-" * len(head))
    for profile in args.profiles.split(","):
        terms = terms_of(profile)
        m = measure(profile, args.examples, args.seed)
        allow = {a: sum(t.values()) for a, t in terms.items()}
        row = {"profile": profile, **m, "allowance_deg": allow, "allowance_terms_deg": terms}
        rows.append(row)
        az_terms = " ".join(f"{v:.2f}" for v in terms["az"].values())
        print(f"{profile:<13} {m['examples']:>5} {m.get('az_past_limit_deg', float('nan')):>8.3f} "
              f"{m.get('el_past_limit_deg', float('nan')):>8.3f} {m.get('into_zone_deg', float('nan')):>8.3f} "
              f"{int(m.get('violations', 0)):>5} {allow['az']:>9.2f} {allow.get('el', 0.0):>9.2f}  {az_terms}",
              flush=True)
    write_json({"examples_per_profile": args.examples, "seed": args.seed, "profiles": rows}, args.json)


if __name__ == "__main__":
    main()
