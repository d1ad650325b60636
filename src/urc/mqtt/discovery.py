"""Home Assistant MQTT discovery: one device per station, its entities read from
``<base>/status`` and its buttons write ``<base>/cmd``.

Each entity's config is retained at ``<prefix>/<component>/<node>/<object>/config``, so
Home Assistant finds it after its own restart; an empty retained payload on the same
topic removes it (``discovery = false``). Each asks for its entity id with
``default_entity_id`` (``sensor.urc_dish_azimuth``), Home Assistant's option since 2025.10
(``object_id`` stops working in 2026.4). See
https://www.home-assistant.io/integrations/mqtt/#mqtt-discovery.
"""

from __future__ import annotations

import json
import re

from .telemetry import STATES
from .topics import Topics

#: (component, object id, what the entity shows or does)
_ENTITIES = (
    ("sensor", "azimuth", {"name": "Azimuth", "value_template": "{{ value_json.az_deg }}",
                           "unit_of_measurement": "°", "state_class": "measurement", "icon": "mdi:compass-outline",
                           "suggested_display_precision": 1}),
    ("sensor", "elevation", {"name": "Elevation", "value_template": "{{ value_json.el_deg }}",
                             "unit_of_measurement": "°", "state_class": "measurement", "icon": "mdi:angle-acute",
                             "suggested_display_precision": 1}),
    ("sensor", "state", {"name": "State", "value_template": "{{ value_json.state }}",
                         "device_class": "enum", "options": list(STATES), "icon": "mdi:satellite-uplink"}),
    ("binary_sensor", "fault", {"name": "Fault", "device_class": "problem",
                                "value_template": "{{ 'ON' if value_json.faults else 'OFF' }}",
                                "json_attributes_topic": None,  # filled in: the status topic
                                "json_attributes_template": "{{ {'faults': value_json.faults} | tojson }}"}),
    ("sensor", "tracking", {"name": "Tracking target", "icon": "mdi:crosshairs-gps",
                            "value_template": "{{ value_json.tracking.target if value_json.tracking else 'none' }}"}),
    ("sensor", "next_pass", {"name": "Next pass", "device_class": "timestamp",
                             "value_template": "{{ value_json.next_pass.aos if value_json.next_pass else None }}"}),
    ("button", "stop", {"name": "Stop", "icon": "mdi:stop-circle-outline",
                        "payload_press": json.dumps({"id": "ha-stop", "command": "stop"})}),
    ("button", "park", {"name": "Park", "icon": "mdi:home-import-outline",
                        "payload_press": json.dumps({"id": "ha-park", "command": "park"})}),
)


def node_id(base_topic: str) -> str:
    """The station's id in Home Assistant: its base topic, as one safe word."""
    return re.sub(r"[^A-Za-z0-9_]+", "_", base_topic).strip("_") or "urc"


def discovery_messages(prefix: str, topics: Topics, station: str, profile: str,
                       version: str) -> list[tuple[str, str]]:
    """(topic, retained JSON payload) for every entity of this station."""
    node = node_id(topics.base)
    device = {"identifiers": [node], "name": f"urc {station}", "manufacturer": "urc",
              "model": f"rotator ({profile})", "sw_version": version}
    out = []
    for component, obj, spec in _ENTITIES:
        # default_entity_id: the entity id asked for, domain included (Home Assistant
        # 2025.10 deprecated object_id for it; 2026.4 drops object_id)
        cfg = {**spec, "unique_id": f"{node}_{obj}", "default_entity_id": f"{component}.{node}_{obj}",
               "availability_topic": topics.availability, "device": device,
               "origin": {"name": "urc", "sw_version": version}}
        if component == "button":
            cfg["command_topic"] = topics.cmd
        else:
            cfg["state_topic"] = topics.status
        if "json_attributes_topic" in cfg:
            cfg["json_attributes_topic"] = topics.status
        out.append((f"{prefix}/{component}/{node}/{obj}/config", json.dumps(cfg, separators=(",", ":"))))
    return out


def removal_messages(prefix: str, topics: Topics) -> list[tuple[str, str]]:
    """The same topics with empty retained payloads: Home Assistant drops the entities."""
    node = node_id(topics.base)
    return [(f"{prefix}/{component}/{node}/{obj}/config", "") for component, obj, _ in _ENTITIES]
