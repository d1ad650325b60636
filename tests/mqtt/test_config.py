"""[mqtt]: off by default, URLs and keys checked with the file/key/expected/found errors."""

from __future__ import annotations

import pytest

from urc.config import Config, loads_config
from urc.errors import ConfigError
from urc.mqtt.config import Broker, base_topic, parse_url, topic_level


def test_off_by_default():
    assert Config().mqtt is None


@pytest.mark.parametrize("url, broker", [
    ("mqtt://127.0.0.1", Broker("127.0.0.1", 1883, False)),
    ("mqtts://broker.example:8884", Broker("broker.example", 8884, True)),
    ("mqtts://broker.example", Broker("broker.example", 8883, True)),
    ("mqtt://op:s%40cret@[::1]:1884", Broker("::1", 1884, False, "op", "s@cret")),
])
def test_urls(url, broker):
    assert parse_url(url) == broker


@pytest.mark.parametrize("toml, key, expected", [
    ('url = "http://x"', "mqtt.url", "mqtt://host[:port]"),
    ('url = "mqtt://"', "mqtt.url", "mqtt://host[:port]"),
    ('url = "mqtt://h:99999"', "mqtt.url", "mqtt://host[:port]"),
    ('url = "mqtt://h/path"', "mqtt.url", "mqtt://host[:port]"),
    ("url = 1883", "mqtt.url", "a string"),
    ('url = "mqtt://h"\nca_file = "/ca.pem"', "mqtt.ca_file", "mqtts://"),
    ('url = "mqtts://h"\ncert_file = "/c.pem"', "mqtt.key_file", "together"),
    ('password = "x"', "mqtt.username", "user name"),
    ('base_topic = "urc/+/x"', "mqtt.base_topic", "without wildcards"),
    ('base_topic = "$SYS/x"', "mqtt.base_topic", "not starting with $"),
    ('discovery_prefix = "home/assistant"', "mqtt.discovery_prefix", "one topic level"),
    ("max_rate_hz = 0", "mqtt.max_rate_hz", "> 0"),
    ("deadband_deg = nan", "mqtt.deadband_deg", "finite"),
    ('discovery = "yes"', "mqtt.discovery", "true or false"),
    ('urll = "mqtt://h"', "mqtt.urll", "one of the keys of [mqtt]"),
])
def test_errors_name_the_key_what_was_expected_and_found(toml, key, expected):
    with pytest.raises(ConfigError) as err:
        loads_config(f"[mqtt]\n{toml}\n", source="site.toml")
    msg = str(err.value)
    assert msg.startswith(f"site.toml: {key}: expected") and expected in msg and "found" in msg, msg


def test_base_topic_from_the_station_name_or_host():
    cfg = loads_config('[station]\nname = "Dish #2 / S-band"\n[mqtt]\n')
    assert base_topic(cfg) == "urc/Dish-2-S-band"
    assert base_topic(loads_config('[mqtt]\nbase_topic = "club/site1/"\n')) == "club/site1"
    import socket
    assert base_topic(loads_config("[mqtt]\n")) == f"urc/{topic_level(socket.gethostname())}"


def test_round_trip_through_toml():
    cfg = loads_config('[mqtt]\nurl = "mqtts://b:8883"\nusername = "u"\npassword = "p"\ndiscovery = false\n')
    assert loads_config(cfg.to_toml()) == cfg


def test_settings_page_never_shows_the_broker_password_and_keeps_it(tmp_path):
    """GET /api/settings is open to read: the [mqtt] password stays out of it (as the API
    token does), and saving the page's document back keeps it; [mqtt] waits for a restart."""
    from urc.web.settings_store import RESTART_SECTIONS, SettingsStore

    cfg = loads_config('[mqtt]\nurl = "mqtt://b"\nusername = "dish"\npassword = "pw-123"\n')
    store = SettingsStore(cfg, tmp_path / "urc.toml", None)
    doc = store.document()["config"]
    assert "password" not in doc["mqtt"] and "pw-123" not in repr(doc)
    doc["mqtt"]["url"] = "mqtt://other"
    new, errors = store.validate(doc)
    assert not errors and new.mqtt.password == "pw-123" and new.mqtt.url == "mqtt://other"
    assert store.changed_sections(new) == ["mqtt"] and "mqtt" in RESTART_SECTIONS
    doc["mqtt"]["password"] = "changed"
    assert store.validate(doc)[0].mqtt.password == "changed"
