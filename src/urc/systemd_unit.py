"""The systemd unit for ``urc run`` (``urc service install``).

``Type=notify``: urc says READY=1 once every port is served and the control loop runs;
``WatchdogSec``: the control loop pings WATCHDOG=1 only while its ticks are on time
(``urc.service.loop.WatchdogPing``, from the control process: ``NotifyAccess=all``), so a hung or stalled controller is killed and
restarted by systemd, while the heartbeat output lets external hardware cut the motors
at once. ``TimeoutStopSec`` leaves room for the orderly stop (axes to rest, then save).
"""

from __future__ import annotations

import shlex
import sys
from pathlib import Path

from .service.control_process import STOP_TIMEOUT_S

UNIT_NAME = "urc.service"
#: systemd kills the service when no WATCHDOG=1 comes for this long
WATCHDOG_SEC = 2


def unit_text(config_path: Path | None, state_dir: Path | None, user: str | None = None,
              user_unit: bool = False, python: str = sys.executable) -> str:
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
             f"WatchdogSec={WATCHDOG_SEC}",
             "Restart=on-failure",
             "RestartSec=2",
             # SIGTERM to both processes (also when the I/O process died, and on a watchdog
             # timeout): the control process stops, waits for standstill (bounded) and
             # saves on its own; SIGKILL only after that can have happened
             f"TimeoutStopSec={int(STOP_TIMEOUT_S + 5)}",
             "KillMode=control-group",
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
