"""The commands the HTTP API (urc.api, urc.web's routes) and MQTT (urc.mqtt.commands)
share, free of either framework: their bodies (:mod:`.bodies`, pydantic models), how
each is performed over the link (:mod:`.dispatcher`) and why one is refused
(:mod:`.errors`, each a CommandRejected with its reason). A front end parses its own
envelope, hands the body here and answers in its own form what comes back.

Nothing here imports fastapi, starlette, aiomqtt, urc.web or urc.mqtt, even indirectly
(.importlinter's dispatch-framework-free; mqtt-no-web keeps MQTT off the web's modules)."""

from __future__ import annotations

from .dispatcher import Dispatcher, PotReading, Stopped
from .errors import Invalid, NotSimulated, TrackerFailed, TrackingOff

__all__ = ["Dispatcher", "Invalid", "NotSimulated", "PotReading", "Stopped", "TrackerFailed", "TrackingOff"]
