"""MQTT: telemetry, commands and Home Assistant discovery through a broker, and the
``urc fleet`` view of every station on it (docs/mqtt.md).

``urc run`` starts :class:`~urc.mqtt.service.MqttService` when the configuration has an
``[mqtt]`` section; aiomqtt is imported only then.
"""

from __future__ import annotations

from typing import Any


def build_service(cfg: Any, rotator: Any, tracker: Any = None, hub: Any = None) -> Any:
    """The MQTT client ``urc run`` runs, or None without ``[mqtt]``."""
    if cfg.mqtt is None:
        return None
    from .. import __version__
    from .commands import CommandHandler
    from .config import base_topic, station_name
    from .service import MqttService

    return MqttService(cfg.mqtt, base_topic(cfg), station_name(cfg),
                       status=hub.status_dict, procedure=hub.procedure_dict,
                       handler=CommandHandler(rotator, tracker, hub),
                       profile=rotator.caps.name, version=__version__)
