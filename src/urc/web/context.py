"""What every web route needs, in one place."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

from ..config import Config
from ..dispatch import Dispatcher
from .live import Hub
from .settings_store import SettingsStore


@dataclass
class WebContext:
    rotator: Any
    cfg: Config
    hub: Hub
    settings: SettingsStore
    #: FastAPI dependency: raises 401 when control needs a token and none was given
    control: Callable[..., None]
    #: a configuration's rotator settings, ``(cfg, state_dir) -> RotatorSettings``, for a
    #: saved setting applied at once: urc.assembly's settings_from_config, handed in by
    #: the composition root (a web route imports no composition root)
    settings_of: Callable[[Config, Path | None], Any]
    #: the commands shared with MQTT, on this rotator, tracker and hub
    dispatch: Dispatcher
    tracker: Any = None
