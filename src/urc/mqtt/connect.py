"""An aiomqtt client for a broker URL (plain or TLS, password or client certificate)."""

from __future__ import annotations

import logging
import ssl
from typing import Any

from .config import Broker

#: paho's own log: it logs every failed socket read (each reconnection attempt to a
#: broker that refuses the TLS handshake); urc.mqtt logs the loss once instead
_PAHO_LOG = logging.getLogger("urc.mqtt.paho")
_PAHO_LOG.setLevel(logging.CRITICAL)


def tls_context(ca_file: str = "", cert_file: str = "", key_file: str = "") -> ssl.SSLContext:
    ctx = ssl.create_default_context(cafile=ca_file or None)
    if cert_file:
        ctx.load_cert_chain(cert_file, key_file or None)
    return ctx


def make_client(broker: Broker, *, identifier: str | None = None, username: str = "", password: str = "",
                ca_file: str = "", cert_file: str = "", key_file: str = "", will: Any = None,
                keepalive_s: int = 15, timeout_s: float = 10.0) -> Any:
    import aiomqtt

    user = broker.username or username
    return aiomqtt.Client(broker.host, broker.port, identifier=identifier,
                          username=user or None, password=(broker.password or password) or None,
                          tls_context=tls_context(ca_file, cert_file, key_file) if broker.tls else None,
                          will=will, keepalive=keepalive_s, timeout=timeout_s, logger=_PAHO_LOG,
                          protocol=aiomqtt.ProtocolVersion.V5)
