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
