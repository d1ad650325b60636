"""Write tests/file_seconds.json (each test file's seconds, the suite's order hint: see
tests/conftest.py) from a run's ``--durations=0`` output.

Usage: bash scripts/test.sh -q -n 2 --dist loadfile --no-loadscope-reorder --durations=0 | tee run.txt
       python3 scripts/file_seconds.py run.txt
"""

from __future__ import annotations

import collections
import json
import re
import sys
from pathlib import Path

LINE = re.compile(r"\s*([\d.]+)s (?:call|setup|teardown)\s+(\S+?\.py)::")


def main(path: str) -> None:
    seconds: collections.Counter[str] = collections.Counter()
    for line in Path(path).read_text(errors="replace").splitlines():
        m = LINE.match(line)
        if m:
            seconds[m.group(2)] += float(m.group(1))
    out = Path(__file__).resolve().parents[1] / "tests" / "file_seconds.json"
    out.write_text(json.dumps({f: round(s, 1) for f, s in sorted(seconds.items())}, indent=1) + "\n")
    print(f"{len(seconds)} files, {sum(seconds.values()):.0f} s -> {out}")


if __name__ == "__main__":
    main(sys.argv[1])
