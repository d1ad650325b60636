"""urc's MQTT client inside ``urc run``: telemetry out, commands in, reconnecting.

The broker is not trusted to be there: urc starts without it, retries with back-off
(1 s doubling to ``reconnect_max_s``), logs a lost broker once and its return once.
Everything here is awaited on the event loop: nothing waits on the broker or on the
control process in a way that holds the loop (rotator calls run in worker threads,
``urc.mqtt.commands``), so the control loop never notices the broker come and go.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import logging
import os
import time
from collections.abc import Callable
from typing import Any

from .commands import CommandHandler
from .config import MqttSection, parse_url
from .connect import make_client
from .discovery import discovery_messages, removal_messages
from .telemetry import EventWatcher, StatusGate, status_payload
from .topics import OFFLINE, ONLINE, Topics

log = logging.getLogger("urc.mqtt")

#: how often the status is sampled (it is published far less often: StatusGate)
SAMPLE_S = 0.1
#: at a stop, the longest the client may take to publish "offline" and disconnect
STOP_GRACE_S = 2.0


def _json(doc: Any) -> str:
    return json.dumps(doc, separators=(",", ":"), allow_nan=False)


class MqttService:
    def __init__(self, section: MqttSection, base_topic: str, station: str, *, status: Callable[[], dict],
                 handler: CommandHandler, procedure: Callable[[], dict | None] = lambda: None,
                 profile: str = "", version: str = ""):
        self.section = section
        self.broker = parse_url(section.url)
        self.topics = Topics(base_topic)
        self.station = station
        self.status = status
        self.procedure = procedure
        self.handler = handler
        self.profile = profile
        self.version = version
        self.gate = StatusGate(section.deadband_deg, section.max_rate_hz, section.refresh_s)
        self.watcher = EventWatcher()
        self._down_logged = False
        self._ever_connected = False

    @property
    def where(self) -> str:
        return f"{'mqtts' if self.broker.tls else 'mqtt'}://{self.broker.host}:{self.broker.port}"

    def _client(self) -> Any:
        import aiomqtt

        m = self.section
        return make_client(self.broker, identifier=f"urc-{self.topics.base.replace('/', '-')}-{os.getpid()}",
                           username=m.username, password=m.password, ca_file=m.ca_file, cert_file=m.cert_file,
                           key_file=m.key_file, keepalive_s=m.keepalive_s, timeout_s=m.timeout_s,
                           will=aiomqtt.Will(self.topics.availability, OFFLINE, qos=1, retain=True))

    async def run(self, stop: asyncio.Event) -> None:
        """Until ``stop``; then at most STOP_GRACE_S to say "offline" (a connection
        attempt under way is abandoned: the axes' stop must not wait for a broker)."""
        inner = asyncio.create_task(self._connect_loop(stop), name="mqtt-connection")
        await stop.wait()
        try:
            await asyncio.wait_for(inner, STOP_GRACE_S)
        except (TimeoutError, asyncio.CancelledError):
            pass
        except Exception:
            log.exception("MQTT client failed while stopping")

    async def _connect_loop(self, stop: asyncio.Event) -> None:
        import aiomqtt

        delay_s = 1.0
        while not stop.is_set():
            try:
                async with self._client() as client:
                    delay_s = 1.0
                    if self._down_logged:
                        log.warning("MQTT: broker %s reachable again", self.where)
                    elif not self._ever_connected:
                        print(f"urc: MQTT connected to {self.where}, topics under {self.topics.base}/", flush=True)
                    self._ever_connected = True
                    self._down_logged = False
                    await self._session(client, stop)
            except (aiomqtt.MqttError, OSError, ValueError) as exc:
                if not self._down_logged:  # once per loss, not once per attempt
                    log.warning("MQTT: broker %s unreachable or lost (%s); retrying with back-off up to %g s",
                                self.where, exc, self.section.reconnect_max_s)
                    self._down_logged = True
            except Exception:  # a bug here must not take the controller down
                log.exception("MQTT client failed; restarting it")
            with contextlib.suppress(asyncio.TimeoutError):
                await asyncio.wait_for(stop.wait(), delay_s)
            delay_s = min(delay_s * 2.0, self.section.reconnect_max_s)

    async def _publish(self, client: Any, topic: str, payload: str, qos: int = 0, retain: bool = False) -> None:
        await client.publish(topic, payload, qos=qos, retain=retain)

    async def _session(self, client: Any, stop: asyncio.Event) -> None:
        from paho.mqtt.subscribeoptions import SubscribeOptions

        t = self.topics
        # retain as published: a retained command is seen as one, and refused, even live
        await client.subscribe(t.cmd, options=SubscribeOptions(qos=1, retainAsPublished=True))
        await self._publish(client, t.availability, ONLINE, qos=1, retain=True)
        m = self.section
        msgs = discovery_messages(m.discovery_prefix, t, self.station, self.profile, self.version) \
            if m.discovery else removal_messages(m.discovery_prefix, t)
        for topic, payload in msgs:
            await self._publish(client, topic, payload, qos=1, retain=True)
        self.gate.forget()
        tasks = [asyncio.create_task(self._telemetry(client), name="mqtt-telemetry"),
                 asyncio.create_task(self._commands(client), name="mqtt-commands"),
                 asyncio.create_task(stop.wait(), name="mqtt-stop")]
        try:
            done, _ = await asyncio.wait(tasks, return_when=asyncio.FIRST_COMPLETED)
        finally:
            for task in tasks:
                task.cancel()
            await asyncio.gather(*tasks, return_exceptions=True)
        for task in done:
            if task.get_name() != "mqtt-stop" and task.exception() is not None:
                raise task.exception()
        if stop.is_set():  # a clean stop: say so (the will is only sent on a lost connection)
            with contextlib.suppress(Exception):
                await asyncio.wait_for(self._publish(client, t.availability, OFFLINE, qos=1, retain=True), 2.0)

    async def _telemetry(self, client: Any) -> None:
        while True:
            try:
                s = self.status()
                p = status_payload(s, self.station, time.time())
                text = _json(p)
                events = self.watcher.events(s, p, self.procedure())
            except Exception:  # a status that cannot be read now: try the next sample
                log.exception("MQTT: status not built")
                events, p = [], None
            for ev in events:
                await self._publish(client, self.topics.event,
                                    _json({"station": self.station, "t_unix_s": round(time.time(), 2), **ev}), qos=1)
            now_s = time.monotonic()
            if p is not None and self.gate.due(p, now_s):
                await self._publish(client, self.topics.status, text, retain=True)
                self.gate.sent(p, now_s)
            await asyncio.sleep(SAMPLE_S)

    async def _commands(self, client: Any) -> None:
        # one at a time, in the order sent: a stop after a goto must win
        async for message in client.messages:
            if str(message.topic) != self.topics.cmd:
                continue
            payload = message.payload if isinstance(message.payload, bytes) else str(message.payload or "").encode()
            if message.retain:  # it would run again at every reconnection: never run
                result = {"id": None, "ok": False, "reason": "invalid",
                          "error": "a retained command is not run (publish commands without retain)"}
            else:
                result = await self.handler.handle(payload)
            await self._publish(client, self.topics.cmd_result, _json(result), qos=1)
