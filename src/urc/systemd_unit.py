"""The systemd unit for ``urc run`` (``urc service install``).

``Type=notify``: urc says READY=1 once every port is served and the control loop runs;
``WatchdogSec``: the control loop pings WATCHDOG=1 only while its ticks are on time
(``urc.rotator.loop.WatchdogPing``, from the control process: ``NotifyAccess=all``), so a hung or stalled controller is killed and
restarted by systemd, while the heartbeat output lets external hardware cut the motors
at once. ``TimeoutStopSec`` leaves room for the orderly stop (axes to rest, then save).

``WorkingDirectory``: lgpio creates its notification FIFO (``.lgd-nfy<N>``) in the
directory named by ``LG_WD``, else the current one, and its Python module then opens it
by a path relative to the current directory (lgpio 0.2.2 ``_callback_thread``). A unit
without one runs in ``/``: a non-root user cannot create the FIFO there
(``FileNotFoundError: '.lgd-nfy-3'``) and root litters ``/``. So the unit runs in the
state directory given (else the user's home, ``~``: writable by its user) and leaves ``LG_WD`` unset (``UnsetEnvironment``):
with it pointing elsewhere the C library and the Python module would disagree.
"""

from __future__ import annotations

import shlex
import sys
from pathlib import Path

from .link.control_process import STOP_TIMEOUT_S

UNIT_NAME = "urc.service"
#: systemd kills the service when no WATCHDOG=1 comes for this long
WATCHDOG_SEC = 2


def unit_text(config_path: Path | None, state_dir: Path | None, user: str | None = None,
              user_unit: bool = False, python: str = sys.executable) -> str:
    work_dir = Path(state_dir).resolve() if state_dir is not None else None
    cmd = [python, "-m", "urc", "run"]
    if config_path is not None:
        cmd += ["--config", str(Path(config_path).resolve())]
    if state_dir is not None:
        cmd += ["--state-dir", str(Path(state_dir).resolve())]
    lines = ["[Unit]",
             "Description=urc - Universal Rotator Controller",
             "Wants=network-online.target",
             "After=network-online.target",
             "",
             "[Service]",
             "Type=notify",
             "NotifyAccess=all",  # the control process pings the watchdog
             f"ExecStart={shlex.join(cmd)}",
             # lgpio's notify FIFO is made in, and opened from, the working directory
             f"WorkingDirectory={work_dir if work_dir is not None else '~'}",
             "UnsetEnvironment=LG_WD",
             f"WatchdogSec={WATCHDOG_SEC}",
             "Restart=on-failure",
             "RestartSec=2",
             # signals to urc run only (a stop, a watchdog timeout): it stops the control
             # process in order (axes to rest, save) within TimeoutStopSec. The control
             # process is left alone when urc run dies: a bounded motion it flies (a pass
             # program, a goto, a park) goes on, and the restarted urc run takes it over
             # (urc.link.adoption); with nothing in flight it stops in order by itself.
             # control-group would SIGTERM it, and lose the pass, on every restart.
             f"TimeoutStopSec={int(STOP_TIMEOUT_S + 5)}",
             "KillMode=process",
             "WatchdogSignal=SIGTERM",
             # room for every client the ports admit (servers/limits.py) and then some:
             # 1024, systemd's usual soft limit, let idle connections take every port down
             "LimitNOFILE=65536"]
    if user and not user_unit:
        lines.append(f"User={user}")
    lines += ["", "[Install]", f"WantedBy={'default.target' if user_unit else 'multi-user.target'}", ""]
    return "\n".join(lines)


def unit_path(user_unit: bool) -> Path:
    if user_unit:
        return Path.home() / ".config" / "systemd" / "user" / UNIT_NAME
    return Path("/etc/systemd/system") / UNIT_NAME
