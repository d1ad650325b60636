"""``urc fleet``: every urc station on an MQTT broker, live, and commands to one of them."""

from __future__ import annotations

import asyncio
import json
import sys
from dataclasses import dataclass
from typing import Any

import click


@dataclass
class _Target:
    broker: Any
    auth: dict
    prefix: str

    def base(self, station: str) -> str:
        from .config import topic_level

        return station.rstrip("/") if "/" in station else f"{self.prefix}/{topic_level(station)}"


@click.group("fleet", invoke_without_command=True)
@click.option("--mqtt", "url", envvar="URC_MQTT_URL", metavar="URL",
              help="Broker: mqtt://[user:password@]host[:port] or mqtts://... (default: [mqtt] url of --config).")
@click.option("--config", "config_path", type=click.Path(dir_okay=False),
              help="Take the broker, user, password and TLS files from this file's [mqtt].")
@click.option("--user", default=None, help="Broker user name.")
@click.option("--password", envvar="URC_MQTT_PASSWORD", default=None, help="Broker password (or URC_MQTT_PASSWORD).")
@click.option("--prefix", default="urc", show_default=True, help="Stations' base topics are PREFIX/<station>.")
@click.option("--once", is_flag=True, help="Print the table once (after --wait-s) and exit.")
@click.option("--wait-s", type=click.FloatRange(0.1, 600.0), default=2.0, show_default=True,
              help="With --once: how long to gather the stations' messages.")
@click.option("--json", "as_json", is_flag=True, help="With --once: the stations as JSON.")
@click.pass_context
def fleet_command(ctx: click.Context, url: str | None, config_path: str | None, user: str | None,
                  password: str | None, prefix: str, once: bool, wait_s: float, as_json: bool) -> None:
    """Every urc station on an MQTT broker: name, online, az/el, state, faults, tracking,
    next pass (live; Ctrl-C ends). With a subcommand: send it to one station, e.g.
    `urc fleet --mqtt mqtt://broker stop dish`."""
    from .config import parse_url

    auth: dict = {}
    if config_path is not None:
        from ..cli import _load

        section = _load(config_path).mqtt
        if section is None:
            raise click.UsageError(f"{config_path} has no [mqtt] section")
        url = url or section.url
        auth = {"username": section.username, "password": section.password, "ca_file": section.ca_file,
                "cert_file": section.cert_file, "key_file": section.key_file}
    if not url:
        raise click.UsageError("which broker? --mqtt URL (or URC_MQTT_URL, or --config with an [mqtt] section)")
    try:
        broker = parse_url(url)
    except ValueError as exc:
        raise click.BadParameter(f"{url}: {exc}", param_hint="--mqtt") from None
    if user is not None:
        auth["username"] = user
    if password is not None:
        auth["password"] = password
    ctx.obj = _Target(broker, auth, prefix)
    if ctx.invoked_subcommand is None:
        _run(_show(ctx.obj, once, wait_s, as_json))


def _run(coro: Any) -> Any:
    import aiomqtt

    try:
        return asyncio.run(coro)
    except aiomqtt.MqttError as exc:
        raise click.ClickException(f"MQTT broker: {exc}") from None
    except KeyboardInterrupt:
        return None


async def _show(target: _Target, once: bool, wait_s: float, as_json: bool) -> None:
    from .fleet import Fleet, plain_table, rich_table, watch

    fleet = Fleet(target.prefix)
    if once:
        await watch(target.broker, fleet, lambda: None, seconds=wait_s, **target.auth)
        if as_json:
            click.echo(json.dumps({k: {"online": s.online, "status": s.status} for k, s in fleet.stations.items()},
                                  indent=2))
        else:
            click.echo(plain_table(fleet.rows()))
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
                click.echo(text + "\n")
                last = text
    printer = asyncio.create_task(reprint())
    try:
        await watch(target.broker, fleet, lambda: None, **target.auth)
    finally:
        printer.cancel()


def _send(target: _Target, station: str, command: dict) -> None:
    from .fleet import CommandFailed, send_command

    base = target.base(station)
    try:
        result = _run(send_command(target.broker, base, command, **target.auth))
    except CommandFailed as exc:
        raise click.ClickException(str(exc)) from None
    if result is None:
        return
    if not result.get("ok"):
        raise click.ClickException(f"{base}: {command['command']} refused: {result.get('error')}")
    click.echo(f"{base}: {command['command']} accepted")


@fleet_command.command("stop")
@click.argument("station")
@click.option("--axis", type=click.Choice(["az", "el"]), default=None, help="One axis only (default: everything).")
@click.pass_obj
def fleet_stop(target: _Target, station: str, axis: str | None) -> None:
    """Stop STATION: tracking, a calibration, both axes (always accepted)."""
    _send(target, station, {"command": "stop", **({"axis": axis} if axis else {})})


@fleet_command.command("park")
@click.argument("station")
@click.pass_obj
def fleet_park(target: _Target, station: str) -> None:
    """Park STATION."""
    _send(target, station, {"command": "park"})


@fleet_command.command("goto")
@click.argument("station")
@click.argument("az", type=float)
@click.argument("el", type=float, required=False)
@click.pass_obj
def fleet_goto(target: _Target, station: str, az: float, el: float | None) -> None:
    """Point STATION at AZ [EL] degrees."""
    _send(target, station, {"command": "goto", "az_deg": az, **({"el_deg": el} if el is not None else {})})


@fleet_command.command("clear-faults")
@click.argument("station")
@click.pass_obj
def fleet_clear_faults(target: _Target, station: str) -> None:
    """Clear STATION's latched faults."""
    _send(target, station, {"command": "clear_faults"})


@fleet_command.command("track")
@click.argument("station")
@click.argument("target_name", metavar="TARGET")
@click.pass_obj
def fleet_track(target: _Target, station: str, target_name: str) -> None:
    """STATION tracks TARGET: sun, moon, a NORAD id or a satellite's name; `none` stops tracking."""
    t = target_name.strip()
    if t.lower() == "none":
        cmd: dict = {"command": "track_stop"}
    elif t.lower() in ("sun", "moon"):
        cmd = {"command": "track", "kind": t.lower()}
    elif t.isdigit():
        cmd = {"command": "track", "kind": "satellite", "norad": int(t)}
    else:
        cmd = {"command": "track", "kind": "satellite", "name": t}
    _send(target, station, cmd)
