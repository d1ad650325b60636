"""urc.config imports nothing above it (issue 34): the packages that give its keys a
meaning register their checks with it (urc.config.owners), and urc.registrations, which
every entry point imports, imports them. Each probe runs in a fresh interpreter: this
test process has imported everything already (tests/conftest.py)."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from urc.config import loads_config
from urc.errors import ConfigError

#: urc.config's owners: none of these may load with it
ABOVE = ("urc.hardware", "urc.frontpanel", "urc.mqtt", "urc.protocols", "urc.pointing", "urc.model",
         "urc.procedures", "urc.rotator", "urc.link")


def run_python(code: str, cwd) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", code], cwd=cwd, capture_output=True, text=True,
                          env={**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}, timeout=120)


def test_importing_config_loads_none_of_its_owners(tmp_path):
    out = run_python("import sys, urc.config\n"
                     f"print(sorted(m for m in sys.modules if m.startswith({ABOVE!r})))\n", tmp_path)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "[]"


def test_an_owner_imports_first_without_a_cycle(tmp_path):
    """It was a cycle: urc.frontpanel.checks imported first failed (config -> its checks
    -> the panel's checks, partly initialised)."""
    for module in ("urc.frontpanel.checks", "urc.mqtt.config", "urc.hardware.factory", "urc.protocols.registry"):
        out = run_python(f"import {module}\nprint('ok')\n", tmp_path)
        assert out.returncode == 0 and out.stdout.strip() == "ok", (module, out.stderr)


def test_a_configuration_checked_before_the_owners_registered_is_refused_loudly(tmp_path):
    """Not passed unchecked: a program that reads a configuration without importing
    urc.registrations (no entry point of urc does) fails at once, naming the fix."""
    out = run_python("from urc.config import loads_config\nloads_config('')\n", tmp_path)
    assert out.returncode != 0
    assert "RuntimeError" in out.stderr and "import urc.registrations" in out.stderr


@pytest.mark.parametrize("entry", ["urc.cli", "urc.assembly", "urc.registrations"])
def test_every_entry_point_registers_every_owner(tmp_path, entry):
    out = run_python(f"import {entry}\n"
                     "from urc.config import loads_config\n"
                     "from urc.errors import ConfigError\n"
                     "try:\n"
                     "    loads_config('[hardware]\\nbackend = \"simm\"\\n')\n"
                     "except ConfigError as exc:\n"
                     "    print(exc.key)\n", tmp_path)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "hardware.backend"


@pytest.mark.parametrize("toml, key", [
    ('[hardware]\nbackend = "simm"\n', "hardware.backend"),
    ('[hardware.bridge]\nprotocol = "nope"\ntcp = "localhost:4533"\n', "hardware.bridge.protocol"),
    ('[hardware.sim]\npointing_error = { zz_deg = 1.0 }\n', "hardware.sim.pointing_error"),
    ('[panel.buttons]\ncw = 5\nccw = 5\n', "panel.buttons.ccw"),
    ('[mqtt]\nurl = "http://broker"\n', "mqtt.url"),
    ('[[serve]]\nprotocol = "rotctl"\ntcp = "127.0.0.1:4533"\n', "serve[0].protocol"),
])
def test_each_owner_still_checks_its_keys(toml, key):
    """What each owner's registered check catches, in the usual words (file: key)."""
    with pytest.raises(ConfigError) as exc:
        loads_config(toml, source="urc.toml")
    assert f"urc.toml: {key}: expected" in str(exc.value)
