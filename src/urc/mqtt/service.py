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
from collections import deque
from collections.abc import Callable
from typing import Any

from .commands import CommandHandler
from .config import MqttSection, parse_url
from .outcomes import MotionOutcomes
from .connect import make_client
from .discovery import discovery_messages, removal_messages
from .telemetry import EventWatcher, StatusGate, status_payload
from .topics import OFFLINE, ONLINE, Topics

log = logging.getLogger("urc.mqtt")

#: how often the status is sampled (it is published far less often: StatusGate)
SAMPLE_S = 0.1
#: at a stop, the longest the client may take to publish "offline" and disconnect
STOP_GRACE_S = 2.0
#: commands waiting to run; beyond this a command is refused at once, reason "busy" (a
#: stop is always taken). 3000 gotos at 1000/s waited in an unbounded queue while urc
#: read the broker more slowly than they came: the broker dropped 2446 of them unanswered
#: (its per-client queue holds 1000), issue 36.2
MAX_PENDING_COMMANDS = 32
#: results waiting to be published; a command arriving while this many wait gets none:
#: it is dropped, and one event per wave says how many and which ids
MAX_PENDING_RESULTS = 2000
#: results published at once (each waits for the broker's PUBACK; paho's window is 20)
RESULTS_IN_FLIGHT = 16


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
        #: how each accepted goto and park ended, published as one more cmd/result
        self.outcomes = MotionOutcomes()
        if handler is not None:
            handler.on_motion = lambda cmd_id, command, target: self.outcomes.accepted(
                cmd_id, command, target, self.status(), time.time())
        #: the connected session's command pipe (None between connections: those ends are lost)
        self._pipe: _CommandPipe | None = None
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
            failure = task.exception() if task.get_name() != "mqtt-stop" else None
            if failure is not None:
                raise failure
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
                ends = self.outcomes.update(s, time.time()) if len(self.outcomes) else []
            except Exception:  # a status that cannot be read now: try the next sample
                log.exception("MQTT: status not built")
                events, p, ends = [], None, []
            for end in ends:
                if self._pipe is not None:
                    self._pipe.answer(end)
            for ev in events:
                await self._publish(client, self.topics.event,
                                    _json({"station": self.station, "t_unix_s": round(time.time(), 2), **ev}), qos=1)
            now_s = time.monotonic()
            if p is not None and self.gate.due(p, now_s):
                await self._publish(client, self.topics.status, text, retain=True)
                self.gate.sent(p, now_s)
            await asyncio.sleep(SAMPLE_S)

    async def _commands(self, client: Any) -> None:
        """Three tasks, so that reading the broker never waits on a command or a PUBACK:
        the reader takes every message at once (the broker's queue for urc never
        fills), the runner runs commands one at a time in the order sent (a stop after
        a goto must win), the publisher sends their results."""
        pipe = self._pipe = _CommandPipe()
        tasks = [asyncio.create_task(self._read_commands(client, pipe), name="mqtt-cmd-read"),
                 asyncio.create_task(self._run_commands(pipe), name="mqtt-cmd-run"),
                 asyncio.create_task(self._publish_results(client, pipe), name="mqtt-cmd-results")]
        try:
            done, _ = await asyncio.wait(tasks, return_when=asyncio.FIRST_EXCEPTION)
            for task in done:
                task.result()
        finally:
            for task in tasks:
                task.cancel()
            await asyncio.gather(*tasks, return_exceptions=True)

    async def _read_commands(self, client: Any, pipe: _CommandPipe) -> None:
        async for message in client.messages:
            if str(message.topic) != self.topics.cmd:
                continue
            payload = message.payload if isinstance(message.payload, bytes) else str(message.payload or "").encode()
            if message.retain:  # it would run again at every reconnection: never run
                pipe.answer({"id": None, "ok": False, "reason": "invalid",
                             "error": "a retained command is not run (publish commands without retain)"})
            elif len(pipe.commands) < MAX_PENDING_COMMANDS or _is_stop(payload):
                pipe.commands.append(payload)
                pipe.command_waiting.set()
            else:
                pipe.answer({"id": _command_id(payload), "ok": False, "reason": "busy",
                             "error": f"{MAX_PENDING_COMMANDS} commands already waiting to run; "
                                      "this one was not run"})

    async def _run_commands(self, pipe: _CommandPipe) -> None:
        while True:
            while not pipe.commands:
                pipe.command_waiting.clear()
                await pipe.command_waiting.wait()
            payload = pipe.commands.popleft()
            pipe.answer(await self.handler.handle(payload))

    async def _publish_results(self, client: Any, pipe: _CommandPipe) -> None:
        window = asyncio.Semaphore(RESULTS_IN_FLIGHT)
        sending: set[asyncio.Task] = set()
        failed: list[BaseException] = []

        async def send(topic: str, payload: str) -> None:
            try:
                await self._publish(client, topic, payload, qos=1)
            except Exception as exc:  # (the connection is lost: the session starts again)
                failed.append(exc)
                pipe.result_waiting.set()
            finally:
                window.release()

        def start(topic: str, payload: str) -> None:
            task = asyncio.create_task(send(topic, payload))
            sending.add(task)  # (a reference until it is done)
            task.add_done_callback(sending.discard)

        try:
            while not failed:
                if not pipe.results and pipe.dropped:  # the end of a wave of drops: one event
                    await window.acquire()
                    start(self.topics.event, _json(pipe.drop_event(self.station, time.time())))
                elif not pipe.results:
                    pipe.result_waiting.clear()
                    await pipe.result_waiting.wait()
                else:
                    await window.acquire()
                    start(self.topics.cmd_result, _json(pipe.results.popleft()))
            raise failed[0]
        finally:
            for task in sending:
                task.cancel()


def _is_stop(payload: bytes) -> bool:
    """A stop is never refused as busy (parsed again, strictly, when it runs)."""
    try:
        doc = json.loads(payload)
    except (ValueError, RecursionError):
        return False
    return isinstance(doc, dict) and doc.get("command") == "stop"


def _command_id(payload: bytes) -> Any:
    """The id of a command refused unread, if it has one that can be echoed."""
    try:
        doc = json.loads(payload)
    except (ValueError, RecursionError):
        return None
    cmd_id = doc.get("id") if isinstance(doc, dict) else None
    ok = (isinstance(cmd_id, str) and len(cmd_id) <= 64) or (isinstance(cmd_id, int) and not isinstance(cmd_id, bool))
    return cmd_id if ok else None


class _CommandPipe:
    """Commands waiting to run, results waiting to be published, and the wave of
    commands dropped because MAX_PENDING_RESULTS results were waiting."""

    def __init__(self) -> None:
        self.commands: deque[bytes] = deque()
        self.command_waiting = asyncio.Event()
        self.results: deque[dict] = deque()
        self.result_waiting = asyncio.Event()
        self.dropped = 0
        self.dropped_ids: list[Any] = []

    def answer(self, result: dict) -> None:
        if len(self.results) >= MAX_PENDING_RESULTS:
            self.dropped += 1
            if len(self.dropped_ids) < 2:
                self.dropped_ids.append(result.get("id"))
            else:
                self.dropped_ids[1] = result.get("id")
            return
        self.results.append(result)
        self.result_waiting.set()

    def drop_event(self, station: str, now_unix_s: float) -> dict:
        ids = self.dropped_ids
        event = {"station": station, "t_unix_s": round(now_unix_s, 2), "type": "commands_dropped",
                 "count": self.dropped, "first_id": ids[0] if ids else None, "last_id": ids[-1] if ids else None,
                 "reason": f"{MAX_PENDING_RESULTS} results already waiting to be published: these commands "
                           "got no result (the busy ones were not run)"}
        self.dropped = 0
        self.dropped_ids = []
        return event
