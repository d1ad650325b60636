"""Home Assistant discovery payloads against Home Assistant's MQTT schema (issue 36.4).

The keys each component accepts are those of Home Assistant's own schemas
(homeassistant/components/mqtt: schemas.py's MQTT_ENTITY_COMMON_SCHEMA and availability
schema, sensor.py, binary_sensor.py, button.py), as of 2025.10, where ``object_id`` was
deprecated for ``default_entity_id`` (the full entity id, domain included; removed in 2026.4).
"""

from __future__ import annotations

import json
import re

import pytest

from urc.mqtt.discovery import discovery_messages, removal_messages
from urc.mqtt.topics import Topics

COMMON = {"availability_topic", "availability_template", "availability", "availability_mode",
          "payload_available", "payload_not_available", "device", "origin", "enabled_by_default",
          "entity_category", "entity_picture", "icon", "json_attributes_topic", "json_attributes_template",
          "default_entity_id", "unique_id", "name", "encoding", "qos"}
BY_COMPONENT = {
    "sensor": {"state_topic", "value_template", "unit_of_measurement", "state_class", "device_class",
               "suggested_display_precision", "options", "expire_after", "force_update",
               "last_reset_value_template"},
    "binary_sensor": {"state_topic", "value_template", "device_class", "payload_on", "payload_off",
                      "expire_after", "force_update", "off_delay"},
    "button": {"command_topic", "command_template", "payload_press", "device_class", "retain"},
}
DEVICE = {"identifiers", "connections", "manufacturer", "model", "model_id", "name", "hw_version",
          "serial_number", "sw_version", "via_device", "suggested_area", "configuration_url"}
ORIGIN = {"name", "sw_version", "support_url"}


def messages():
    topics = Topics("urc/dish")
    return [(t, json.loads(p)) for t, p in discovery_messages("homeassistant", topics, "dish", "tartu-urc", "1.2.3")]


def test_default_entity_id_not_object_id():
    for topic, cfg in messages():
        component, node, obj = re.fullmatch(r"homeassistant/(\w+)/(\w+)/(\w+)/config", topic).groups()
        assert "object_id" not in cfg, topic
        assert cfg["default_entity_id"] == f"{component}.{node}_{obj}" == f"{component}.{cfg['unique_id']}"


@pytest.mark.parametrize("topic, cfg", messages(), ids=lambda v: v if isinstance(v, str) else "")
def test_every_key_is_one_home_assistant_takes(topic, cfg):
    component = topic.split("/")[1]
    unknown = set(cfg) - COMMON - BY_COMPONENT[component]
    assert not unknown, (topic, unknown)
    assert not set(cfg["device"]) - DEVICE and cfg["device"]["identifiers"]
    assert not set(cfg["origin"]) - ORIGIN and cfg["origin"]["name"]
    if component == "button":
        assert "state_topic" not in cfg and cfg["command_topic"]
    else:
        assert cfg["state_topic"] and "command_topic" not in cfg
    if cfg.get("device_class") == "enum":       # Home Assistant: options only with enum, no state_class
        assert cfg["options"] and "state_class" not in cfg and "unit_of_measurement" not in cfg


def test_removal_covers_every_entity():
    topics = Topics("urc/dish")
    assert [t for t, _ in removal_messages("homeassistant", topics)] == [t for t, _ in messages()]
