"""The ``[mqtt]`` configuration section and the broker address it names.

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

from pydantic import BaseModel, ConfigDict, Field

#: MQTT's registered ports (IANA): plain and over TLS
DEFAULT_PORTS = {"mqtt": 1883, "mqtts": 8883}
#: characters allowed in one topic level urc builds from a name (no wildcards, no '/')
_LEVEL_UNSAFE = re.compile(r"[^A-Za-z0-9_.-]+")


class MqttSection(BaseModel):
    """``[mqtt]``: urc's client of an MQTT broker (telemetry, commands, HA discovery)."""

    model_config = ConfigDict(strict=True, frozen=True, extra="forbid", validate_default=False)

    #: mqtt://host[:port] or mqtts://host[:port] (TLS)
    url: str = Field("mqtt://127.0.0.1:1883", min_length=1)
    username: str = ""
    password: str = ""
    #: TLS: the CA bundle to trust ("" = the system's), a client certificate and its key
    ca_file: str = ""
    cert_file: str = ""
    key_file: str = ""
    #: "" = urc/<station name or host name>
    base_topic: str = ""
    #: Home Assistant MQTT discovery under ``discovery_prefix``; false removes urc's entities
    discovery: bool = True
    discovery_prefix: str = Field("homeassistant", min_length=1)
    #: status: published when a position moves by more than this ...
    deadband_deg: float = Field(0.1, ge=0.0, le=10.0, allow_inf_nan=False)
    #: ... at most this often ...
    max_rate_hz: float = Field(4.0, gt=0.0, le=20.0, allow_inf_nan=False)
    #: ... and at least this often (a fleet view tells a live station from a stale one)
    refresh_s: float = Field(10.0, ge=1.0, le=3600.0, allow_inf_nan=False)
    keepalive_s: int = Field(15, ge=5, le=3600)
    #: an answer from the broker (to the connection, a subscription, a publish) missing
    #: this long fails the attempt: the connection is dropped and tried again (back-off)
    timeout_s: float = Field(10.0, ge=0.5, le=300.0, allow_inf_nan=False)
    #: the longest wait between reconnection attempts (they back off from 1 s)
    reconnect_max_s: float = Field(30.0, ge=1.0, le=3600.0, allow_inf_nan=False)


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
