"""The commands the HTTP API (urc.api, urc.web's routes) and MQTT (urc.mqtt.commands)
share, free of either framework: their bodies (:mod:`.bodies`, pydantic models), how
each is performed over the link (:mod:`.dispatcher`) and why one is refused
(:mod:`.errors`, each a CommandRejected with its reason). A front end parses its own
envelope, hands the body here and answers in its own form what comes back.

Nothing here imports fastapi, starlette, aiomqtt, urc.web or urc.mqtt
(.importlinter's dispatch-framework-free and tests/test_layers.py)."""

from __future__ import annotations

from .dispatcher import Dispatcher, PotReading, Stopped
from .errors import Invalid, TrackerFailed, TrackingOff

__all__ = ["Dispatcher", "Invalid", "PotReading", "Stopped", "TrackerFailed", "TrackingOff"]
