"""The ``[mqtt]`` configuration section's meaning: the broker address it names, and its
checks (registered with urc.config at import; the section's model is config's,
:mod:`urc.config.mqtt_section`).

No section, no MQTT: urc never needs a broker. The section is checked like every other
(file: key: expected, found); the broker itself is only tried at run time, and may be
away (``urc.mqtt.service`` reconnects).
"""

from __future__ import annotations

import re
import socket
from dataclasses import dataclass
from typing import Any
from urllib.parse import unquote, urlsplit

from ..config.mqtt_section import MqttSection
from ..config.owners import register_check

#: MQTT's registered ports (IANA): plain and over TLS
DEFAULT_PORTS = {"mqtt": 1883, "mqtts": 8883}
#: characters allowed in one topic level urc builds from a name (no wildcards, no '/')
_LEVEL_UNSAFE = re.compile(r"[^A-Za-z0-9_.-]+")


@dataclass(frozen=True)
class Broker:
    host: str
    port: int
    tls: bool
    username: str = ""
    password: str = ""


def parse_url(url: str) -> Broker:
    """``mqtt[s]://[user[:password]@]host[:port]`` -> Broker; ValueError saying why not."""
    parts = urlsplit(url)
    if parts.scheme not in DEFAULT_PORTS:
        raise ValueError(f"scheme {parts.scheme or 'none'!r}: expected mqtt:// or mqtts://")
    if not parts.hostname:
        raise ValueError("no host")
    if parts.path not in ("", "/") or parts.query or parts.fragment:
        raise ValueError("a path, query or fragment (a broker URL names only a host and port)")
    try:
        port = parts.port or DEFAULT_PORTS[parts.scheme]
    except ValueError:
        raise ValueError("a port 1..65535") from None
    return Broker(parts.hostname, port, parts.scheme == "mqtts",
                  unquote(parts.username or ""), unquote(parts.password or ""))


def topic_level(name: str) -> str:
    """A name made safe as one topic level (no '/', '+', '#', spaces)."""
    return _LEVEL_UNSAFE.sub("-", name).strip("-") or "station"


def station_name(cfg: Any) -> str:
    """The station's name: ``[station] name``, else this machine's host name."""
    return (cfg.station.name or socket.gethostname()).strip()


def base_topic(cfg: Any) -> str:
    m: MqttSection = cfg.mqtt
    return m.base_topic.rstrip("/") if m.base_topic else f"urc/{topic_level(station_name(cfg))}"


def mqtt_issues(cfg: Any) -> list[tuple[str, str, Any, str]]:
    """Cross-checks of ``[mqtt]`` as (key, expected, found, hint) issues."""
    m: MqttSection | None = cfg.mqtt
    if m is None:
        return []
    issues = []
    try:
        broker = parse_url(m.url)
    except ValueError as exc:
        issues.append(("mqtt.url", f'mqtt://host[:port] or mqtts://host[:port], e.g. "mqtt://127.0.0.1:1883" '
                       f"(not {exc})", m.url, ""))
    else:
        for key in ("ca_file", "cert_file", "key_file"):
            if getattr(m, key) and not broker.tls:
                issues.append((f"mqtt.{key}", "an mqtts:// url (TLS) with it", m.url, ""))
    if bool(m.cert_file) != bool(m.key_file):
        issues.append(("mqtt.key_file" if m.cert_file else "mqtt.cert_file",
                       "cert_file and key_file together (a client certificate and its key)", "only one", ""))
    if m.password and not m.username:
        issues.append(("mqtt.username", "a user name with the password", "", ""))
    if m.base_topic and (any(c in m.base_topic for c in "+#\0") or m.base_topic.startswith("$")
                         or "//" in m.base_topic.strip("/") or not m.base_topic.strip("/")):
        issues.append(("mqtt.base_topic", "a topic without wildcards (+ #), not starting with $, "
                       'e.g. "urc/dish"', m.base_topic, ""))
    if any(c in m.discovery_prefix for c in "+#/\0"):
        issues.append(("mqtt.discovery_prefix", 'one topic level, e.g. "homeassistant"', m.discovery_prefix, ""))
    return issues


# [mqtt] is checked whenever a configuration is validated (urc.registrations imports this)
register_check("mqtt", lambda cfg, _caps: mqtt_issues(cfg))
