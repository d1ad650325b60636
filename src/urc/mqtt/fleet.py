"""The fleet view: every station seen on a broker, from their retained availability and
status, and one command sent to one station with its result awaited."""

from __future__ import annotations

import asyncio
import json
import sys
import time
import uuid
from dataclasses import dataclass, field
from typing import Any, Callable

from .config import Broker, topic_level
from .connect import make_client
from .topics import OFFLINE, ONLINE, Topics, fleet_patterns, station_of

#: columns of the table: (title, function of a Station)
COLUMNS = ("station", "online", "az", "el", "state", "faults", "tracking", "next pass", "age")


@dataclass
class Station:
    key: str                      # its topic level under the prefix
    online: bool | None = None    # None: no availability seen
    status: dict[str, Any] = field(default_factory=dict)
    seen_unix_s: float = 0.0

    def row(self, now_unix_s: float) -> dict[str, str]:
        s = self.status
        faults = s.get("faults") or []
        trk = s.get("tracking") or {}
        nxt = s.get("next_pass") or {}
        t = s.get("t_unix_s")
        return {"station": s.get("station") or self.key,
                "online": {True: ONLINE, False: OFFLINE, None: "?"}[self.online],
                "az": _deg(s.get("az_deg")), "el": _deg(s.get("el_deg")),
                "state": s.get("state", "?"),
                "faults": "; ".join(f"{f.get('kind')}: {f.get('reason')}" for f in faults) or "-",
                "tracking": trk.get("target") or "-",
                "next pass": (nxt.get("aos") or "-")[:19].replace("T", " "),
                "age": "-" if t is None else f"{max(now_unix_s - t, 0.0):.0f} s"}


def _deg(x: Any) -> str:
    return "-" if x is None else f"{x:.1f}"


class Fleet:
    """Stations under ``prefix`` (``urc`` unless their base topics say otherwise)."""

    def __init__(self, prefix: str = "urc"):
        self.prefix = prefix.rstrip("/")
        self.stations: dict[str, Station] = {}

    def feed(self, topic: str, payload: bytes) -> None:
        where = station_of(topic, self.prefix)
        if where is None:
            return
        key, kind = where
        if not payload:   # a cleared retained message: nothing to show
            return
        st = self.stations.setdefault(key, Station(key))
        if kind == "availability":
            st.online = payload.decode(errors="replace") == ONLINE
        elif kind == "status":
            try:
                doc = json.loads(payload)
            except ValueError:
                return
            if isinstance(doc, dict):
                st.status, st.seen_unix_s = doc, time.time()

    def rows(self, now_unix_s: float | None = None) -> list[dict[str, str]]:
        now = time.time() if now_unix_s is None else now_unix_s
        return [self.stations[k].row(now) for k in sorted(self.stations)]


def plain_table(rows: list[dict[str, str]]) -> str:
    if not rows:
        return "no stations seen"
    widths = {c: max(len(c), *(len(r[c]) for r in rows)) for c in COLUMNS}
    lines = ["  ".join(c.upper().ljust(widths[c]) for c in COLUMNS)]
    lines += ["  ".join(r[c].ljust(widths[c]) for c in COLUMNS) for r in rows]
    return "\n".join(line.rstrip() for line in lines)


def rich_table(rows: list[dict[str, str]]) -> Any:
    from rich.table import Table

    table = Table(title="urc fleet", expand=False)
    for c in COLUMNS:
        table.add_column(c, justify="right" if c in ("az", "el", "age") else "left", no_wrap=c != "faults")
    for r in rows:
        style = "red" if r["faults"] != "-" or r["state"] == "fault" else ("dim" if r["online"] != ONLINE else None)
        table.add_row(*(r[c] for c in COLUMNS), style=style)
    return table


def _client(broker: Broker, **auth: Any) -> Any:
    return make_client(broker, identifier=f"urc-fleet-{uuid.uuid4().hex[:8]}", **auth)


#: at the end of a window, how long a read under way may take to finish (it is one
#: message off the queue already, or the queue is empty and nothing is coming)
DRAIN_S = 0.05


async def watch(broker: Broker, fleet: Fleet, on_change, stop: asyncio.Event | None = None,
                seconds: float | None = None, **auth: Any) -> None:
    """Feed ``fleet`` from the broker; ``on_change()`` after each message. Until
    ``stop`` is set, or for ``seconds`` (the retained messages arrive at once)."""
    async with _client(broker, **auth) as client:
        for pattern in fleet_patterns(fleet.prefix).values():
            await client.subscribe(pattern, qos=1)

        closing = False

        async def read() -> None:
            async for msg in client.messages:
                fleet.feed(str(msg.topic), msg.payload if isinstance(msg.payload, bytes) else b"")
                on_change()
                if closing and not len(client.messages):
                    return
        reader = asyncio.create_task(read())
        waits: list[asyncio.Task[Any]] = [reader]
        if stop is not None:
            waits.append(asyncio.create_task(stop.wait()))
        try:
            await asyncio.wait(waits, timeout=seconds, return_when=asyncio.FIRST_COMPLETED)
            if not reader.done():
                # the window is over, but what arrived in it is still this window's (queued
                # behind a slow on_change, or taken off the queue and not yet returned:
                # cancelling the read then would lose it): read on until the queue is empty
                closing = True
                await asyncio.wait([reader], timeout=DRAIN_S)
        finally:
            for t in waits:
                t.cancel()
            await asyncio.gather(*waits, return_exceptions=True)
        failure = reader.exception() if reader.done() and not reader.cancelled() else None
        if failure is not None:
            raise failure


class CommandFailed(Exception):
    pass


async def send_command(broker: Broker, base: str, command: dict[str, Any], timeout_s: float = 10.0,
                       **auth: Any) -> dict[str, Any]:
    """Publish one command to the station at ``base`` and return its result."""
    topics = Topics(base)
    cmd_id = f"fleet-{uuid.uuid4().hex[:12]}"
    async with _client(broker, **auth) as client:
        await client.subscribe(topics.cmd_result, qos=1)
        await client.subscribe(topics.availability, qos=1)
        await client.publish(topics.cmd, json.dumps({"id": cmd_id, **command}), qos=1)

        async def result() -> dict[str, Any]:
            async for msg in client.messages:
                if str(msg.topic) == topics.availability and msg.payload == OFFLINE.encode():
                    raise CommandFailed(f"{base} is offline")
                if str(msg.topic) == topics.cmd_result:
                    try:
                        doc = json.loads(msg.payload)
                    except ValueError:
                        continue
                    if isinstance(doc, dict) and doc.get("id") == cmd_id:
                        return doc
            raise CommandFailed("the broker closed the connection")
        try:
            return await asyncio.wait_for(result(), timeout_s)
        except TimeoutError:
            raise CommandFailed(f"no answer from {base} within {timeout_s:g} s (is it running and connected?)") \
                from None


@dataclass
class Target:
    """The broker ``urc fleet`` reaches the stations on, its credentials, and the prefix
    of the stations' base topics."""

    broker: Any
    auth: dict
    prefix: str

    def base(self, station: str) -> str:
        return station.rstrip("/") if "/" in station else f"{self.prefix}/{topic_level(station)}"


async def show(target: Target, once: bool, wait_s: float, as_json: bool, echo: Callable[[str], None]) -> None:
    """``urc fleet``'s table: once (after ``wait_s``, plain or JSON), or live until
    cancelled (rich on a terminal, else the plain table whenever it changed)."""
    fleet = Fleet(target.prefix)
    if once:
        await watch(target.broker, fleet, lambda: None, seconds=wait_s, **target.auth)
        if as_json:
            echo(json.dumps({k: {"online": s.online, "status": s.status} for k, s in fleet.stations.items()},
                                  indent=2))
        else:
            echo(plain_table(fleet.rows()))
        return
    try:
        from rich.live import Live
        has_live = True
    except ImportError:
        has_live = False
    if has_live and sys.stdout.isatty():
        with Live(rich_table(fleet.rows()), refresh_per_second=4, transient=False) as live:
            async def repaint() -> None:
                while True:
                    live.update(rich_table(fleet.rows()))
                    await asyncio.sleep(0.5)
            painter = asyncio.create_task(repaint())
            try:
                await watch(target.broker, fleet, lambda: None, **target.auth)
            finally:
                painter.cancel()
        return
    # not a terminal: the table again whenever it changed, checked once a second
    async def reprint() -> None:
        last = ""
        while True:
            await asyncio.sleep(1.0)
            text = plain_table(fleet.rows())
            if text != last:
                echo(text + "\n")
                last = text
    printer = asyncio.create_task(reprint())
    try:
        await watch(target.broker, fleet, lambda: None, **target.auth)
    finally:
        printer.cancel()
