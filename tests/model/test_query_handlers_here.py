"""The shared model names nothing of the control process (issue 34 item 4): its request
effects run a query on a rotator in this process with the handlers urc.rotator registers
when imported, and say so when none are here."""

from __future__ import annotations

import os
import subprocess
import sys


def run_python(code: str) -> str:
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120,
                         env={**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)})
    assert out.returncode == 0, out.stderr
    return out.stdout.strip()


def test_the_model_loads_nothing_of_the_control_process_or_the_link():
    loaded = run_python(
        "import sys\n"
        "import urc.model.effects, urc.model.messages, urc.model.program, urc.model.settings, urc.model.snapshot\n"
        "print(sorted(m for m in sys.modules if m.startswith(('urc.rotator', 'urc.link', 'urc.procedures',\n"
        "                                                     'urc.hardware', 'urc.config'))))\n")
    assert loaded == "[]"


def test_a_query_with_no_handlers_in_this_process_is_refused_by_name():
    said = run_python(
        "from urc.model.effects import ask\n"
        "from urc.model.messages import SensorCount\n"
        "try:\n"
        "    ask(object(), SensorCount('az'))\n"
        "except TypeError as exc:\n"
        "    print(exc)\n")
    assert "SensorCount" in said and "urc.rotator" in said


class NoHardware:
    """A rotator in this process with no sensor on either axis."""
    hw = None


def test_importing_the_rotator_registers_its_query_handlers():
    import urc.rotator  # noqa: F401 (what registers them)
    from urc.model.effects import ask, drive
    from urc.model.messages import CountReading, SensorCount

    assert ask(NoHardware(), SensorCount("az")) == CountReading(None, None)

    def step():
        return (yield SensorCount("el"))
    assert drive(step(), NoHardware()) == CountReading(None, None)
