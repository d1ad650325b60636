"""What every web route needs, in one place."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable

from ..config import Config
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
    tracker: Any = None
