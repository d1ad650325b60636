"""lgpio's notify FIFO in a directory of each process's own (review 35 #9): lg makes
``<LG_WD or cwd>/.lgd-nfy<handle>`` when lgpio is imported, unlinking any file of that
name first, and every process gets handle 0, so urc's two processes in one working
directory shared (and could steal) one FIFO. Real lgpio, in fresh interpreters."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("lgpio")

SRC = Path(__file__).resolve().parents[2] / "src"

CHILD = r"""
import json, os, subprocess, sys
import urc.hardware.gpio                 # installs the hook, imports no lgpio
assert "lgpio" not in sys.modules and "LG_WD" not in os.environ or os.environ.get("URC_LG_WD_PID")
inherited = os.environ.get("LG_WD")
import gpiozero.pins.lgpio               # imports lgpio: its notify FIFO is opened now
wd = os.environ["LG_WD"]
out = {"pid": os.getpid(), "wd": wd, "inherited": inherited, "cwd": os.getcwd(),
       "fifo": os.path.exists(os.path.join(wd, ".lgd-nfy0"))}
if len(sys.argv) > 1:                    # spawn the other process as urc does (env inherited)
    done = subprocess.run([sys.executable, "-c", sys.argv[1]], capture_output=True, text=True, check=True)
    out["child"] = json.loads(done.stdout)
    out["fifo_after_child"] = os.path.exists(os.path.join(wd, ".lgd-nfy0"))
print(json.dumps(out))
"""


def run(tmp_path: Path, *args: str) -> dict:
    env = dict(os.environ, PYTHONPATH=str(SRC), XDG_RUNTIME_DIR=str(tmp_path / "run"))
    env.pop("LG_WD", None)
    env.pop("URC_LG_WD_PID", None)
    (tmp_path / "run").mkdir(exist_ok=True)
    done = subprocess.run([sys.executable, "-c", CHILD, *args], cwd=tmp_path, env=env, capture_output=True,
                          text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout)


def test_each_process_gets_its_own_lgpio_notify_directory(tmp_path):
    out = run(tmp_path, CHILD)
    child = out["child"]
    run_dir = tmp_path / "run"
    for p in (out, child):
        wd = Path(p["wd"])
        assert wd.parent == run_dir and wd.name.startswith(f"urc-lgpio-{p['pid']}-")
        assert p["fifo"]                                  # LG_WD was set before lgpio opened its FIFO
        assert p["cwd"] == str(tmp_path)                  # lg's chdir into LG_WD undone
    assert out["wd"] != child["wd"] and child["inherited"] == out["wd"]   # inherited, not reused
    assert out["fifo_after_child"]                        # the child did not unlink the parent's FIFO
    assert not (tmp_path / ".lgd-nfy0").exists()          # none in the shared working directory
    assert not Path(child["wd"]).exists()                 # removed at exit


def test_a_dead_process_directory_is_pruned(tmp_path):
    stale = tmp_path / "run" / "urc-lgpio-999999999-abc"
    stale.mkdir(parents=True)
    (stale / ".lgd-nfy0").write_text("")
    run(tmp_path)
    assert not stale.exists()
