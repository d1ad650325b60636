"""A configuration file that holds a secret (the API tokens, the MQTT password) must not
be readable by other users: said at ``urc run``'s start and by ``urc config check``; a
save from the settings (``urc.web.settings_store``) writes it 0600."""

from __future__ import annotations

import os
import stat
from pathlib import Path
from typing import Any


def holds_secret(cfg: Any) -> bool:
    mqtt = getattr(cfg, "mqtt", None)
    return bool(cfg.api.token or cfg.api.read_token or (mqtt is not None and mqtt.password))


def readable_by_others(path: str | os.PathLike, cfg: Any) -> str:
    """A warning when ``path`` holds a secret and its group or other users may read it; ""."""
    if not holds_secret(cfg):
        return ""
    try:
        mode = stat.S_IMODE(Path(path).stat().st_mode)
    except OSError:
        return ""
    if not mode & (stat.S_IRGRP | stat.S_IROTH):
        return ""
    return (f"{path} holds the API token (or the MQTT password) and other users can read it "
            f"(mode {mode:04o}): chmod 600 {path}")
