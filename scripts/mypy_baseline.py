"""mypy on src/urc, held to a baseline that may only shrink.

The package predates type checking in CI (379 errors in 54 files when it began): each
file may keep at most the errors the baseline records for it, and a file not in the
baseline must have none. Fix some, then `python scripts/mypy_baseline.py --update` to
lower the baseline; it never goes up by itself.

Usage: python scripts/mypy_baseline.py [--update]
"""

from __future__ import annotations

import collections
import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
BASELINE = ROOT / "scripts" / "mypy-baseline.json"


def error_counts() -> dict[str, int]:
    res = subprocess.run([sys.executable, "-m", "mypy", "src/urc", "--no-error-summary", "--show-error-codes"],
                         cwd=ROOT, capture_output=True, text=True)
    counts: collections.Counter[str] = collections.Counter()
    for line in res.stdout.splitlines():
        path, sep, rest = line.partition(":")
        if sep and " error: " in rest:
            counts[path] += 1
    if res.returncode not in (0, 1):
        sys.exit(f"mypy failed to run:\n{res.stdout}{res.stderr}")
    return dict(sorted(counts.items()))


def main() -> int:
    counts = error_counts()
    if "--update" in sys.argv:
        old = json.loads(BASELINE.read_text()) if BASELINE.exists() else {}
        grew = {f: n for f, n in counts.items() if n > old.get(f, 0)}
        if old and grew:
            print(f"not lowering the baseline: more errors than it allows in {grew}")
            return 1
        BASELINE.write_text(json.dumps(counts, indent=1) + "\n")
        print(f"baseline: {sum(counts.values())} errors in {len(counts)} files")
        return 0
    allowed = json.loads(BASELINE.read_text())
    worse = {f: (n, allowed.get(f, 0)) for f, n in counts.items() if n > allowed.get(f, 0)}
    total, base = sum(counts.values()), sum(allowed.values())
    for f, (n, a) in worse.items():
        print(f"{f}: {n} mypy errors, the baseline allows {a}")
    if worse:
        print("run `python -m mypy src/urc` to see them")
        return 1
    print(f"mypy: {total} errors, baseline {base}" + (" (lower it: --update)" if total < base else ""))
    return 0


if __name__ == "__main__":
    sys.exit(main())
