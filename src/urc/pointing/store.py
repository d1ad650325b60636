"""The fitted pointing model and the scans it is fitted from, in the state directory
(they describe this rotator's iron, like its position, not a setting to edit):

* ``pointing-model.json``: the model in force: when it was fitted, from what, each
  term's value and standard uncertainty, the residual RMS, and the scans themselves;
* ``pointing-scans.jsonl``: every finished calibration scan, one JSON object a line.

A scan is stored in the frame the model maps from: the boresight's sky direction where
the beam was on the source (the position urc would report with no model, after the
[offsets] then in force) and the boresight minus the beam on the sky (dx = dA cos E,
dy = dE) with their uncertainties. Stored so, a scan flown with an older model in force
still counts, and one flown under other [offsets] is moved to the present ones.

No numpy here: the control process and the web stack read the model at start.
"""

from __future__ import annotations

import json
import math
import os
import time
from pathlib import Path
from typing import Any, Iterable

from ..control.geometry import POINTING_TERMS
from ..errors import UrcError

MODEL_FILE = "pointing-model.json"
SCANS_FILE = "pointing-scans.jsonl"
VERSION = 1
#: what a stored scan must give (finite numbers; the uncertainties positive)
SCAN_KEYS = ("az_deg", "el_deg", "dx_deg", "dy_deg", "dx_err_deg", "dy_err_deg")
_CLEAR_HINT = "`urc pointing clear` removes it"


class PointingStoreError(UrcError):
    """A stored model or scan file that cannot be used, with the reason."""


def _finite(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def _write_atomic(path: Path, text: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    with open(tmp, "w", encoding="utf-8") as fh:
        fh.write(text)
        fh.flush()
        os.fsync(fh.fileno())
    os.replace(tmp, path)


# ----------------------------------------------------------------------- the model
def model_doc(terms: dict[str, tuple[float, float | None]], *, fitted: Iterable[str], residual_rms_deg: float,
              chi2_reduced: float, scans: list[dict[str, Any]], source: str,
              fitted_unix_s: float | None = None) -> dict[str, Any]:
    """The stored form: ``terms`` {name: (value_deg, err_deg or None: not fitted)}."""
    t = time.time() if fitted_unix_s is None else fitted_unix_s
    doc = {"version": VERSION, "fitted_unix_s": t,
           "date": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime(t)),
           "source": source, "fitted": [n for n in fitted],
           "terms": {n: {"value_deg": float(terms.get(n, (0.0, None))[0]), "err_deg": terms.get(n, (0.0, None))[1]}
                     for n in POINTING_TERMS},
           "residual_rms_deg": float(residual_rms_deg), "chi2_reduced": float(chi2_reduced),
           "scans": list(scans)}
    check_model(doc, "model")
    return doc


def check_model(doc: Any, where: Any) -> None:
    """Raise PointingStoreError naming what is wrong with a stored model ``doc``."""
    if not isinstance(doc, dict) or doc.get("version") != VERSION:
        raise PointingStoreError(f"{where}: not a urc pointing model (version {VERSION})")
    terms = doc.get("terms")
    if not isinstance(terms, dict) or set(terms) != set(POINTING_TERMS):
        raise PointingStoreError(f"{where}: expected the terms {', '.join(POINTING_TERMS)}")
    for name, t in terms.items():
        v, err = (t.get("value_deg"), t.get("err_deg")) if isinstance(t, dict) else (None, None)
        if not (_finite(v) and abs(float(v)) <= 10.0):  # type: ignore[arg-type]
            raise PointingStoreError(f"{where}: term {name}: value_deg must be a finite number within +-10, found {v!r}")
        if err is not None and not (_finite(err) and err >= 0):
            raise PointingStoreError(f"{where}: term {name}: err_deg must be a number >= 0 or null, found {err!r}")
    for key in ("residual_rms_deg", "fitted_unix_s"):
        if not _finite(doc.get(key)):
            raise PointingStoreError(f"{where}: {key} must be a finite number, found {doc.get(key)!r}")
    if not isinstance(doc.get("scans"), list):
        raise PointingStoreError(f"{where}: scans must be a list")


def model_terms(doc: dict[str, Any]) -> tuple[float, ...]:
    """The terms in Geometry.pointing_deg's order."""
    return tuple(float(doc["terms"][n]["value_deg"]) for n in POINTING_TERMS)


def model_path(state_dir: Path | str) -> Path:
    return Path(state_dir) / MODEL_FILE


def load_model(state_dir: Path | str) -> dict[str, Any] | None:
    """The stored model, None if there is none; PointingStoreError if it is damaged."""
    path = model_path(state_dir)
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        return None
    except (OSError, ValueError, UnicodeDecodeError) as exc:
        raise PointingStoreError(f"{path}: unreadable ({exc}); {_CLEAR_HINT}") from None
    try:
        check_model(doc, path)
    except PointingStoreError as exc:
        raise PointingStoreError(f"{exc}; {_CLEAR_HINT}") from None
    return doc


def save_model(state_dir: Path | str, doc: dict[str, Any]) -> Path:
    check_model(doc, "model")
    path = model_path(state_dir)
    _write_atomic(path, json.dumps(doc, indent=1, sort_keys=True) + "\n")
    return path


def clear_model(state_dir: Path | str) -> bool:
    """Remove the stored model (the scans stay); False if there was none."""
    try:
        model_path(state_dir).unlink()
    except FileNotFoundError:
        return False
    return True


def pointing_for(state_dir: Path | str | None) -> tuple[tuple[float, ...], str]:
    """(the terms to apply, () if none; why a stored model is not applied, or "")."""
    if state_dir is None:
        return (), ""
    try:
        doc = load_model(state_dir)
    except PointingStoreError as exc:
        return (), f"pointing model not applied: {exc}"
    return (model_terms(doc) if doc is not None else ()), ""


# ----------------------------------------------------------------------- the scans
def scans_path(state_dir: Path | str) -> Path:
    return Path(state_dir) / SCANS_FILE


def check_scan(rec: Any, where: str) -> dict[str, Any]:
    if not isinstance(rec, dict):
        raise PointingStoreError(f"{where}: a scan must be a JSON object, found {type(rec).__name__}")
    for key in SCAN_KEYS:
        v = rec.get(key)
        if not _finite(v):
            raise PointingStoreError(f"{where}: {key} must be a finite number, found {v!r}")
    if rec["dx_err_deg"] <= 0 or rec["dy_err_deg"] <= 0:
        raise PointingStoreError(f"{where}: the uncertainties must be positive")
    if not (-5.0 <= rec["el_deg"] <= 90.0):
        raise PointingStoreError(f"{where}: el_deg {rec['el_deg']} outside -5..90")
    offsets = rec.get("offsets", {})
    if not (isinstance(offsets, dict) and all(_finite(offsets.get(k, 0.0)) for k in ("az_deg", "el_deg"))):
        raise PointingStoreError(f"{where}: offsets must be {{az_deg, el_deg}} numbers")
    return rec


def append_scan(state_dir: Path | str, rec: dict[str, Any]) -> Path:
    check_scan(rec, "scan")
    path = scans_path(state_dir)
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "a", encoding="utf-8") as fh:
        fh.write(json.dumps(rec, sort_keys=True) + "\n")
        fh.flush()
        os.fsync(fh.fileno())
    return path


def read_scans(path: Path | str) -> list[dict[str, Any]]:
    """Every scan in a scan file (JSON lines, or one JSON list, or a stored model's
    ``scans``); PointingStoreError naming the line that is wrong."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise PointingStoreError(f"{path}: no such scan file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise PointingStoreError(f"{path}: unreadable ({exc})") from None
    stripped = text.lstrip()
    if stripped.startswith(("[", "{")) and not _is_json_lines(text):
        try:
            doc = json.loads(text)
        except ValueError as exc:
            raise PointingStoreError(f"{path}: not JSON ({exc})") from None
        items = doc.get("scans") if isinstance(doc, dict) else doc
        if not isinstance(items, list):
            raise PointingStoreError(f"{path}: expected a list of scans (or a model with its scans)")
        return [check_scan(r, f"{path}: scan {i + 1}") for i, r in enumerate(items)]
    out = []
    for n, line in enumerate(text.splitlines(), 1):
        if not line.strip():
            continue
        try:
            rec = json.loads(line)
        except ValueError as exc:
            raise PointingStoreError(f"{path}:{n}: not JSON ({exc})") from None
        out.append(check_scan(rec, f"{path}:{n}"))
    return out


def _is_json_lines(text: str) -> bool:
    lines = [ln for ln in text.splitlines() if ln.strip()]
    if len(lines) < 2:
        return False
    try:
        return all(isinstance(json.loads(ln), dict) for ln in lines)
    except ValueError:
        return False
