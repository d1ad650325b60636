"""The control process's entry point: ``python -m urc.control_entry`` (started by
:class:`urc.link.control_process.ControlProcess`). It sits with the composition root, so
that the link, which serves and supervises the control process, imports no assembly: it
is handed :func:`build`, which builds this process's rotator from the configuration."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

from .clock import RealClock
from .link.control_process import main


def build(cfg: Any, state_dir: Path) -> tuple[Any, Any]:
    """This process's rotator, and the settings its configuration gives it (a urc run
    taking the process over compares its own with these)."""
    # (imported here, once the signal handlers are set: the assembly is the slow part
    # of a start, and a stop asked meanwhile must find them)
    from .assembly import build_rotator, settings_from_config

    return build_rotator(cfg, RealClock(), state_dir), settings_from_config(cfg, state_dir)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:], build))
