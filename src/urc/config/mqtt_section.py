"""The ``[mqtt]`` section's model: plain data, so that :class:`~urc.config.Config` names
it without importing urc.mqtt (what the keys mean, and their checks, are
:mod:`urc.mqtt.config`'s)."""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict, Field


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
