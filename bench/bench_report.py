"""What every benchmark does with its results: write them as JSON and say where."""

from __future__ import annotations

import json
from pathlib import Path


def write_json(results, path: str) -> Path:
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(results, indent=2))
    print(f"\nJSON written to {out}")
    return out
