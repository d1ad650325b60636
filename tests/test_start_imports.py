"""What a `urc run` start does not import: every module here costs CPU at each start of
each process (the test suite starts ~150 of them on two cores), and none is needed
until the feature that uses it is."""

from __future__ import annotations

import os
import subprocess
import sys


def run_python(code: str, cwd) -> None:
    out = subprocess.run([sys.executable, "-c", code], cwd=cwd, capture_output=True, text=True,
                         env={**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}, timeout=120)
    assert out.returncode == 0 and out.stdout.strip() == "ok", out.stderr


def test_the_io_process_web_stack_imports_no_tracking_maths(tmp_path):
    """Without a [station] (or a GPS) the I/O process never needs numpy, sgp4 or skyfield:
    the web stack, the composition root and the tracking package itself do not load them."""
    run_python("import sys\n"
               "import urc.app, urc.api, urc.tracking, urc.tracking.cycle, urc.web.live\n"
               "from urc.web.history import pointing_error_deg\n"
               "assert pointing_error_deg({'az_deg': 10.0, 'el_deg': 20.0, 'target_az_deg': 30.0,"
               " 'target_el_deg': 40.0}) > 0\n"
               "heavy = [m for m in ('numpy', 'sgp4', 'skyfield', 'urc.procedures.calibration') if m in sys.modules]\n"
               "assert not heavy, heavy\n"
               "print('ok')\n", tmp_path)


def test_the_tracking_package_still_offers_its_names(tmp_path):
    run_python("import urc.tracking as t\n"
               "for name in t.__all__:\n"
               "    assert getattr(t, name).__name__ == name, name\n"
               "from urc.tracking import Catalog, sky\n"
               "print('ok')\n", tmp_path)


def test_the_control_process_imports_no_event_loop(tmp_path):
    run_python("import sys\n"
               "import urc.link.control_process, urc.assembly, urc.clock\n"
               "assert 'asyncio' not in sys.modules and 'greenlet' not in sys.modules\n"
               "print('ok')\n", tmp_path)


def test_checking_a_configuration_imports_only_the_backends_it_names(tmp_path):
    run_python("import sys\n"
               "import urc.registrations\n"
               "from urc.config import loads_config\n"
               "from urc.errors import ConfigError\n"
               "loads_config(\"[hardware]\\nbackend = 'sim'\\n\")\n"
               "loaded = [m for m in ('urc.hardware.sim', 'urc.hardware.bridge', 'urc.hardware.gpio')"
               " if m in sys.modules]\n"
               "assert not loaded, loaded\n"
               "try:\n"
               "    loads_config(\"[hardware.bridge]\\nprotocol = 'nope'\\ntcp = 'localhost:4533'\\n\")\n"
               "except ConfigError as exc:\n"
               "    assert 'hardware.bridge.protocol' in str(exc), exc\n"
               "else:\n"
               "    raise AssertionError('a bridge section is still checked')\n"
               "print('ok')\n", tmp_path)


def test_prepare_takeover_imports_the_configured_backend(tmp_path):
    run_python("import sys\n"
               "import urc.registrations\n"
               "from urc.config import loads_config\n"
               "from urc.assembly import prepare_takeover\n"
               "assert prepare_takeover(loads_config(\"[hardware]\\nbackend = 'sim'\\n\")) == []\n"
               "assert 'urc.hardware.sim' in sys.modules\n"
               "print('ok')\n", tmp_path)
