"""The ``urc`` command line.

(Over 600 lines on purpose: one thin click command per verb, each only parsing options
and printing; the work is in the packages they call. ``passes``, ``tle`` and
``calibrate`` live in their own modules, loaded on use; ``fleet``'s commands are here, so
that urc.mqtt imports no command line, and its work is in urc.mqtt.fleet.)
"""

from __future__ import annotations

import os
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

from . import __version__, registrations  # noqa: F401  (before any configuration is read: see urc.registrations)
from .api_client import CLIENT_TIMEOUT_S, DEFAULT_URL, ClientError, base_url, field_name, invalid_fields
from .api_client import request as api_request
from .errors import ConfigError, StateFileError
from .status_text import format_tracking, render

if TYPE_CHECKING:
    from .mqtt.fleet import Target

def _load(config_path: str | None, profile: str | None = None):
    from .config import Config, load_config

    cfg = load_config(config_path)
    if profile is not None and profile != cfg.rotator.profile:
        data = cfg.to_dict()
        data.setdefault("rotator", {})["profile"] = profile
        cfg = Config.from_dict(data, source=f"{config_path or '<defaults>'} with --profile {profile}")
    return cfg


class _LazyGroup(click.Group):
    """Subcommands that live in heavy modules are imported only when used: `urc status`
    must not pay for numpy and skyfield (the tracking commands)."""

    LAZY = {"passes": "urc.tracking.cli:passes_command", "tle": "urc.tracking.cli:tle_command",
            "calibrate": "urc.pointing.cli:calibrate_command", "pointing": "urc.pointing.cli:pointing_command"}

    def list_commands(self, ctx: click.Context) -> list[str]:
        return sorted({*super().list_commands(ctx), *self.LAZY})

    def get_command(self, ctx: click.Context, name: str) -> click.Command | None:
        if name in self.LAZY and name not in self.commands:
            import importlib

            module, _, attr = self.LAZY[name].partition(":")
            self.add_command(getattr(importlib.import_module(module), attr), name)
        return super().get_command(ctx, name)


@click.group(cls=_LazyGroup)
@click.version_option(__version__, prog_name="urc")
def main() -> None:
    """urc — the Universal Rotator Controller."""


@main.command()
@click.option("--config", "config_path", type=click.Path(dir_okay=False), help="TOML configuration file.")
@click.option("--profile", help="Simulator/rotator profile (see `urc profiles`).")
@click.option("--state-dir", type=click.Path(file_okay=False), help="Where persistent state lives.")
@click.option("--port", type=int, help="HTTP API port (overrides [api] port).")
@click.option("--emulate", is_flag=True,
              help="gpio backend: run the real drivers on pins and chips emulated from the simulator.")
@click.option("--serve", "serve_specs", multiple=True, metavar="PROTOCOL=KIND:WHERE[,KEY=VALUE]",
              help="Serve a protocol; repeat for more. Replaces the configuration's [[serve]] for "
                   "this run (never saved). KIND is tcp, pty, serial or udp, e.g. "
                   "rotctld=tcp:127.0.0.1:4535, gs232b=pty:/tmp/urc-gs232b, "
                   "rot2prog=serial:/dev/ttyUSB0,baud=600, pstrotator=udp:0.0.0.0:12000; "
                   "other KEY=VALUE pairs are the protocol's options (urc=tcp:127.0.0.1:4540,variant=trc).")
@click.option("--lat", "lat_deg", type=click.FloatRange(-90, 90), metavar="DEG",
              help="Station latitude (north +), with --lon: the [station] position for this run "
                   "(never saved); tracking needs one.")
@click.option("--lon", "lon_deg", type=click.FloatRange(-180, 360), metavar="DEG",
              help="Station longitude (east +), with --lat.")
@click.option("-v", "--verbose", is_flag=True, help="Log debug detail.")
def run(config_path: str | None, profile: str | None, state_dir: str | None, port: int | None,
        emulate: bool, serve_specs: tuple[str, ...], lat_deg: float | None, lon_deg: float | None,
        verbose: bool) -> None:
    """Start the controller (the simulator with no arguments)."""
    import asyncio
    import logging

    from .app import ServiceFailed, serve
    from .link.instance import InstanceLocked

    logging.basicConfig(level=logging.DEBUG if verbose else logging.INFO,
                        format="%(asctime)s %(levelname)s %(name)s: %(message)s")
    try:
        if config_path is not None:
            from .config.user_copy import in_use

            used, note = in_use(config_path)
            if note:
                click.echo(note, err=True)
                config_path = str(used)
        cfg = _load(config_path, profile)
        if config_path is not None:
            from .config.secrets_mode import readable_by_others

            if warning := readable_by_others(config_path, cfg):
                logging.getLogger("urc").warning(warning)
        if port is not None:
            from .config import Config
            data = cfg.to_dict()
            data.setdefault("api", {})["port"] = port
            cfg = Config.from_dict(data, source="--port")
        if (lat_deg is None) != (lon_deg is None):
            raise click.UsageError("give --lat and --lon together")
        if lat_deg is not None:
            from .config import Config
            data = cfg.to_dict()
            data.setdefault("station", {}).update(lat_deg=lat_deg, lon_deg=lon_deg)
            cfg = Config.from_dict(data, source="--lat/--lon")
        if serve_specs:
            cfg = with_serve(cfg, serve_specs)
        if emulate:
            cfg = with_emulation(cfg)
        asyncio.run(serve(cfg, cfg.state.resolve_dir(state_dir),
                          config_path=Path(config_path) if config_path else None))
    except (ConfigError, ServiceFailed) as exc:
        raise click.ClickException(str(exc)) from None
    except (InstanceLocked, OSError, StateFileError) as exc:
        # another urc on this state dir or hardware, a port in use, a state dir holding
        # something other than files: nothing was started
        raise _Busy(f"cannot start: {exc}") from None
    finally:
        from .link.instance import skip_exit_collection

        skip_exit_collection()


SERVE_KINDS = ("tcp", "pty", "serial", "udp")


def serve_entry(spec: str) -> dict:
    """``PROTOCOL=KIND:WHERE[,KEY=VALUE...]`` (``--serve``) -> a [[serve]] table: baud and
    reply_port are the entry's own keys, any other KEY=VALUE a protocol option."""
    protocol, sep, rest = spec.partition("=")
    kind, colon, where_opts = rest.partition(":")
    where, *pairs = where_opts.split(",")
    if not (sep and protocol.strip() and colon and kind in SERVE_KINDS and where.strip()):
        raise ConfigError(f"--serve {spec!r}: expected PROTOCOL=KIND:WHERE with KIND one of "
                          f"{', '.join(SERVE_KINDS)}, e.g. rotctld=tcp:127.0.0.1:4535",
                          key="serve", expected="PROTOCOL=KIND:WHERE", found=spec)
    entry: dict = {"protocol": protocol.strip(), kind: where.strip()}
    for pair in pairs:
        key, eq, text = pair.partition("=")
        if not eq or not key.strip():
            raise ConfigError(f"--serve {spec!r}: expected KEY=VALUE after the address, got {pair!r}",
                              key="serve", expected="KEY=VALUE", found=pair)
        value = _setting_value(text.strip())
        if key.strip() in ("baud", "reply_port"):
            entry[key.strip()] = value
        else:
            entry.setdefault("options", {})[key.strip()] = value
    return entry


def with_serve(cfg, specs: tuple[str, ...]):
    """The configuration with ``[[serve]]`` replaced by the ``--serve`` entries."""
    from .config import Config
    data = cfg.to_dict()
    data["serve"] = [serve_entry(s) for s in specs]
    return Config.from_dict(data, source="--serve")


def with_emulation(cfg):
    """The configuration with ``[hardware.gpio] emulate = true`` (``--emulate``)."""
    from .config import Config
    if cfg.hardware.backend != "gpio":
        raise ConfigError("--emulate needs [hardware] backend = \"gpio\" (see examples/)",
                          key="hardware.backend", expected="gpio", found=cfg.hardware.backend)
    data = cfg.to_dict()
    data["hardware"]["gpio"]["emulate"] = True
    return Config.from_dict(data, source="--emulate")


@main.group()
def hw() -> None:
    """Commission the rotator's hardware (parts, sensors, wiring)."""


@hw.command("check")
@click.option("--config", "config_path", type=click.Path(dir_okay=False), help="TOML configuration file.")
@click.option("--profile", help="Rotator profile (overrides the config's).")
@click.option("--state-dir", type=click.Path(file_okay=False), help="Where persistent state lives.")
@click.option("--emulate", is_flag=True, help="gpio backend on emulated pins and chips.")
@click.option("--move", is_flag=True, help="Jog each axis briefly up and check the sensor counts up.")
def hw_check(config_path: str | None, profile: str | None, state_dir: str | None, emulate: bool,
             move: bool) -> None:
    """List the parts, read every sensor, check I2C ids, magnets and limit switches
    (bridge: identify the controller, read its position, measure the link latency)."""
    from .assembly import hardware_options, settings_from_config
    from .clock import RealClock, VirtualClock
    from .hardware import build_hardware
    from .hardware.check import check

    try:
        cfg = _load(config_path, profile)
        if emulate:
            cfg = with_emulation(cfg)
        if cfg.hardware.backend == "bridge":
            from .hardware.bridge.check import check_bridge

            result = check_bridge(cfg.hardware.bridge)
            click.echo("\n".join(result.lines))
            if not result.ok:
                raise SystemExit(1)
            return
        caps = settings_from_config(cfg).caps
        virtual = cfg.hardware.backend == "sim" or (cfg.hardware.gpio is not None and cfg.hardware.gpio.emulate)
        clock = VirtualClock(1000.0) if virtual else RealClock()
        d = cfg.state.resolve_dir(state_dir)
        d.mkdir(parents=True, exist_ok=True)
        hardware = build_hardware(cfg.hardware.backend, caps, clock, d, hardware_options(cfg))
    except ConfigError as exc:
        raise click.ClickException(str(exc)) from None
    try:
        hardware.poll(clock.now_s())
        kw = {"sleep": clock.advance, "now": clock.now_s} if virtual else {}
        problems = check(hardware, caps, gpio=cfg.hardware.gpio, move=move, out=click.echo, **kw)
    finally:
        hardware.close()
    if problems:
        sys.exit(1)


class _Busy(click.ClickException):
    exit_code = 3


@main.group()
def config() -> None:
    """Configuration helpers."""


@config.command("example")
def config_example() -> None:
    """Print a commented example configuration."""
    from .config import EXAMPLE_CONFIG

    click.echo(EXAMPLE_CONFIG, nl=False)


@config.command("check")
@click.argument("path", type=click.Path(dir_okay=False))
def config_check(path: str) -> None:
    """Validate a configuration file."""
    try:
        cfg = _load(path)
        cfg.check_serve_options()  # (as urc run does before it starts)
    except ConfigError as exc:
        raise click.ClickException(str(exc)) from None
    click.echo(f"{path}: ok (profile {cfg.rotator.profile})")
    from .config.secrets_mode import readable_by_others
    from .hardware.gpio.checks import gpio_warnings
    from .hardware.gpio.pwm import detect_pwm_chip, pwm_advice

    gpio = cfg.hardware.gpio
    # on a Pi 5 its own channel table (GPIO12/13/18/19 -> 0/1/2/3), as urc run uses
    table = detect_pwm_chip(gpio)[1] if gpio is not None and not gpio.emulate else None
    for note in pwm_advice(gpio, table) + gpio_warnings(cfg) + [w for w in [readable_by_others(path, cfg)] if w]:
        click.echo(f"warning: {note}")


@main.group()
def service() -> None:
    """Run urc as a systemd service."""


@service.command("install")
@click.option("--config", "config_path", type=click.Path(dir_okay=False, exists=True),
              help="Configuration the service runs with.")
@click.option("--state-dir", type=click.Path(file_okay=False), help="Where the service keeps its state.")
@click.option("--user", "run_as", help="Run the system service as this user (default: root).")
@click.option("--user-unit", is_flag=True, help="Install for the current user (systemctl --user).")
@click.option("--print", "print_only", is_flag=True, help="Print the unit instead of writing it.")
def service_install(config_path: str | None, state_dir: str | None, run_as: str | None, user_unit: bool,
                    print_only: bool) -> None:
    """Write the systemd unit (Type=notify, WatchdogSec) for `urc run`."""
    from .systemd_unit import unit_path, unit_text

    text = unit_text(Path(config_path) if config_path else None, Path(state_dir) if state_dir else None,
                     user=run_as, user_unit=user_unit)
    if print_only:
        click.echo(text, nl=False)
        return
    path = unit_path(user_unit)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    except OSError as exc:
        raise click.ClickException(f"cannot write {path}: {exc} (as root, or use --user-unit or --print)") \
            from None
    ctl = "systemctl --user" if user_unit else "sudo systemctl"
    click.echo(f"wrote {path}\nthen: {ctl} daemon-reload && {ctl} enable --now urc")


@main.command()
def profiles() -> None:
    """List the rotator profiles."""
    from .profiles import DEFAULT_PROFILE, PROFILES

    for name, caps in PROFILES.items():
        mark = " (default)" if name == DEFAULT_PROFILE else ""
        click.echo(f"{name:14s}{caps.description}{mark}")
        click.echo(" " * 14 + "   ".join(
            f"{ax.name} {ax.min_deg:g}..{ax.max_deg:g} deg, {ax.min_rate_deg_per_s:g}..{ax.max_rate_deg_per_s:g} deg/s"
            for ax in (caps.az, caps.el)))


# ---------------------------------------------------------------- client commands
def _remember_port(ctx: click.Context, _param: click.Parameter, value: int | None) -> None:
    ctx.meta["urc.api_port"] = value


def _remember_timeout(ctx: click.Context, _param: click.Parameter, value: float) -> None:
    ctx.meta["urc.timeout_s"] = value


def _client_options(f):
    f = click.option("--timeout", "timeout_s", type=click.FloatRange(min=0.1), default=CLIENT_TIMEOUT_S,
                     envvar="URC_TIMEOUT", show_default=True, expose_value=False, callback=_remember_timeout,
                     help="Seconds to wait for the controller's answer.")(f)
    f = click.option("--url", envvar="URC_URL", default=None,
                     help=f"Controller API address (default from --config, else {DEFAULT_URL}).")(f)
    # `urc run --port N` starts the API on N; the same --port reaches it (issue 13.8)
    f = click.option("--port", type=click.IntRange(1, 65535), default=None, expose_value=False,
                     callback=_remember_port,
                     help="Controller API port on this host (as given to `urc run --port`).")(f)
    f = click.option("--config", "config_path", type=click.Path(dir_okay=False),
                     help="Read the API address and token from this configuration.")(f)
    return f


def _request(url: str | None, config_path: str | None, method: str, path: str, body: dict | None = None,
             headers: dict[str, str] | None = None) -> dict:
    token = os.environ.get("URC_TOKEN", "")
    ctx = click.get_current_context(silent=True)
    port = ctx.meta.get("urc.api_port") if ctx is not None else None
    if url is not None and port is not None:
        raise click.UsageError("give --url or --port, not both")
    if url is None and config_path:
        try:
            cfg = _load(config_path)
        except ConfigError as exc:
            raise click.ClickException(str(exc)) from None
        host = "127.0.0.1" if cfg.api.host in ("0.0.0.0", "::") else cfg.api.host
        host = f"[{host}]" if ":" in host else host  # (an IPv6 address)
        url = f"http://{host}:{cfg.api.port if port is None else port}"
        token = token or cfg.api.token
    timeout_s = (ctx.meta.get("urc.timeout_s") if ctx is not None else None) or CLIENT_TIMEOUT_S
    try:
        return api_request(base_url(url, port), method, path, body, token=token, timeout_s=timeout_s,
                           headers=headers)
    except ClientError as exc:
        said = str(exc)
        if exc.code == 412:
            raise  # (the caller loads the settings again)
        if exc.code == 422 and path in ("/api/goto", "/api/set-position"):
            said = _outside_the_limits(base_url(url, port), token, timeout_s, exc.data) or said
        elif exc.code == 404 and path.startswith(("/api/track", "/api/passes")):
            said = _tracking_off(base_url(url, port), token, timeout_s) or said
        raise click.ClickException(said) from None


def _tracking_off(url: str, token: str, timeout_s: float) -> str | None:
    """A urc without a station position has no tracking routes (404): say so, and how."""
    try:
        info = api_request(url, "GET", "/api/info", token=token, timeout_s=timeout_s)
    except ClientError:
        return None
    if not isinstance(info, dict) or info.get("tracking_available") is not False:
        return None
    return (f"tracking is off: the urc at {url} has no station position. Add it to the "
            "configuration urc runs with, then restart it:\n\n"
            "  [station]\n  lat_deg = 58.38    # yours: degrees north\n  lon_deg = 26.72    # yours: degrees east\n\n"
            "(`urc settings set station.lat_deg=58.38 station.lon_deg=26.72` saves that from "
            "here), or start it with `urc run --lat 58.38 --lon 26.72`.")


def _outside_the_limits(url: str, token: str, timeout_s: float, data: object) -> str | None:
    """An angle beyond what the API takes (-360..720, -90..180) said as the rotator's own
    refusal of one beyond its limits says it: ``el 200 outside the limits el 0..180``."""
    entries = invalid_fields(data) if isinstance(data, dict) else []
    angles = {field_name(e).removesuffix("_deg"): e.get("input") for e in entries
              if field_name(e) in ("az_deg", "el_deg") and isinstance(e.get("input"), (int, float))}
    if not angles or len(angles) != len(entries):
        return None
    try:
        info = api_request(url, "GET", "/api/info", token=token, timeout_s=timeout_s)
        limits = {axis: (lo + info["offsets"].get(axis, 0.0), hi + info["offsets"].get(axis, 0.0))
                  for axis, (lo, hi) in info["limits"].items()}
    except (ClientError, KeyError, TypeError, ValueError, AttributeError):
        return None
    said = []
    for axis, value in angles.items():
        if axis not in limits:
            said.append(f"this rotator has no {axis} axis")
        else:
            lo, hi = limits[axis]
            said.append(f"{axis} {value:g} outside the limits {axis} {lo:g}..{hi:g}")
    return "refused (422): " + "; ".join(said)


@main.command()
@click.option("--json", "as_json", is_flag=True, help="Print the raw status snapshot as JSON.")
@_client_options
def status(as_json: bool, url: str | None, config_path: str | None) -> None:
    """Show the running controller's status."""
    data = _request(url, config_path, "GET", "/api/status")
    click.echo(render(data, as_json))


@main.command()
@click.argument("az", type=float)
@click.argument("el", type=float, required=False)
@_client_options
def goto(az: float, el: float | None, url: str | None, config_path: str | None) -> None:
    """Point the antenna at AZ [EL] (degrees; without EL the azimuth alone turns, as on
    a single-axis rotator)."""
    data = _request(url, config_path, "POST", "/api/goto", {"az_deg": az, "el_deg": el})
    route = " -> ".join(f"({a:.1f}, {e:.1f})" for a, e in data.get("route", []))
    where = f"az {az:g}" + ("" if el is None else f" el {el:g}")
    click.echo(f"going to {where}" + (f" via {route}" if route else ""))


@main.command()
@click.option("--axis", type=click.Choice(["az", "el"]), default=None,
              help="Stop this axis only (default: both).")
@_client_options
def stop(axis: str | None, url: str | None, config_path: str | None) -> None:
    """Stop the antenna."""
    _request(url, config_path, "POST", "/api/stop", {"axis": axis})
    click.echo("stopping")


@main.command()
@_client_options
def park(url: str | None, config_path: str | None) -> None:
    """Park the antenna."""
    _request(url, config_path, "POST", "/api/park")
    click.echo("parking")


@main.command("set-position")
@click.option("--az", type=float, default=None, metavar="DEG",
              help="The azimuth the antenna points at now (compass degrees, the mount offset "
                   "included). Past 360 or below 0 it names the cable-wrap turn, e.g. 400 on a "
                   "450 deg rotator: the overlap.")
@click.option("--el", type=float, default=None, metavar="DEG",
              help="The elevation the antenna points at now, degrees (past 90 on a rotator "
                   "that flips: over the top).")
@_client_options
def set_position(az: float | None, el: float | None, url: str | None, config_path: str | None) -> None:
    """Re-reference: declare where the antenna points now (nothing moves; an axis left
    out keeps its position). Clears that axis' uncertainty, as Tartu's WRAZ/WREL do."""
    _request(url, config_path, "POST", "/api/set-position", {"az_deg": az, "el_deg": el})
    click.echo("position set")


@main.command("clear-faults")
@_client_options
def clear_faults(url: str | None, config_path: str | None) -> None:
    """Clear latched faults."""
    _request(url, config_path, "POST", "/api/clear-faults")
    click.echo("faults cleared")


@main.command()
@click.argument("target", required=False)
@click.option("--norad", type=int, help="Satellite by NORAD catalog number.")
@click.option("--point", nargs=3, type=float, metavar="LAT LON ALT_M", help="A place on Earth.")
@click.option("--azel", nargs=2, type=float, metavar="AZ EL", help="A fixed direction.")
@click.option("--nmea", "nmea_source", metavar="SOURCE",
              help="A moving target reporting NMEA GGA (a balloon): device path or tcp:HOST:PORT.")
@click.option("--pass-aos", "pass_aos", help="Fly only the pass with this AOS (ISO time, UTC).")
@click.option("--stop", "stop_tracking", is_flag=True, help="Stop tracking.")
@_client_options
def track(target: str | None, norad: int | None, point, azel, nmea_source: str | None, pass_aos: str | None,
          stop_tracking: bool, url: str | None, config_path: str | None) -> None:
    """Track a target with the running controller: ISS (a name), --norad 25544, sun,
    moon, --point LAT LON ALT_M, --azel AZ EL or --nmea SOURCE. Satellites are flown pass by pass, each
    planned before it starts (see `urc status`)."""
    if stop_tracking:
        _request(url, config_path, "POST", "/api/track/stop")
        click.echo("tracking stopped")
        return
    if nmea_source:
        body = {"kind": "nmea", "source": nmea_source}
    elif point:
        body = {"kind": "point", "lat_deg": point[0], "lon_deg": point[1], "alt_m": point[2]}
    elif azel:
        body = {"kind": "azel", "az_deg": azel[0], "el_deg": azel[1]}
    elif norad is not None:
        body = {"kind": "satellite", "norad": norad}
    elif target and target.lower() in ("sun", "moon"):
        body = {"kind": target.lower()}
    elif target:
        body = {"kind": "satellite", "name": target}
    else:
        raise click.UsageError("name a target: a satellite, sun, moon, --norad, --point or --azel")
    if pass_aos:
        if body["kind"] != "satellite" or norad is None:
            raise click.UsageError("--pass-aos needs --norad")
        _request(url, config_path, "POST", "/api/track/pass", {"norad": norad, "aos": pass_aos})
    else:
        _request(url, config_path, "POST", "/api/track", body)
    # the command answers ok; what is being tracked, the plan and its warnings are the
    # tracker's status (it printed "tracking  None" from the bare ok). The next pass is
    # searched and planned in the background: its plan is shown once it is there.
    import time

    ctx = click.get_current_context()
    give_up_s = time.monotonic() + (ctx.meta.get("urc.timeout_s") or CLIENT_TIMEOUT_S)
    status = _request(url, config_path, "GET", "/api/status")
    while (status.get("tracking") or {}).get("state") == "planning" and time.monotonic() < give_up_s:
        time.sleep(0.25)
        status = _request(url, config_path, "GET", "/api/status")
    click.echo(format_tracking(status.get("tracking")))


@main.group()
def settings() -> None:
    """Read and change a running urc's settings (what the web settings page edits: the
    configuration file, kept across restarts; e.g. the BIG-RAS menu settings)."""


def _setting_value(text: str):
    """A value as TOML writes it (180, 1.5, true, "south"); a bare word is a string."""
    import tomllib

    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text


@settings.command("show")
@click.argument("key", required=False)
@_client_options
def settings_show(key: str | None, url: str | None, config_path: str | None) -> None:
    """Print the settings (as TOML), or one dotted KEY's value."""
    doc = _request(url, config_path, "GET", "/api/settings")["config"]
    if key is None:
        from .config import Config  # (about 1 s of imports: not for one KEY's value)
        from .config.applicable import applicable
        from .config.schema import dump_toml

        # what applies to this station's parts only (not reply_port on a TCP port)
        click.echo(dump_toml(applicable(Config.from_dict(doc, source="settings"))), nl=False)
        return
    value = doc
    for part in key.split("."):
        if not isinstance(value, dict) or part not in value:
            raise click.ClickException(f"{key}: not set (the default applies; `urc config example` lists them)")
        value = value[part]
    click.echo(value)


@settings.command("set")
@click.argument("assignments", nargs=-1, required=True, metavar="KEY=VALUE...")
@_client_options
def settings_set(assignments: tuple[str, ...], url: str | None, config_path: str | None) -> None:
    """Change settings, checked by the same rules as the file, saved and applied (those
    of [rotator], [hardware]... at the next start), e.g.
    `urc settings set rotator.pulses_per_deg=1 control.az.min_rate_deg_per_s=1.2`."""
    for _ in range(SETTINGS_TRIES):
        loaded = _request(url, config_path, "GET", "/api/settings")
        doc = loaded["config"]
        for a in assignments:
            key, sep, text = a.partition("=")
            if not sep or not key.strip():
                raise click.UsageError(f"expected KEY=VALUE, got {a!r}")
            *path, last = key.strip().split(".")
            table = doc
            for part in path:
                table = table.setdefault(part, {})
                if not isinstance(table, dict):
                    raise click.UsageError(f"{key}: {part} is not a table")
            table[last] = _setting_value(text.strip())
        # the revision read goes back in If-Match: a save made in between (the web page)
        # is refused with 412, and these keys are set again on top of it
        revision = loaded.get("revision")
        try:
            data = _request(url, config_path, "POST", "/api/settings", doc,
                            headers={"If-Match": revision} if revision else None)
        except ClientError as exc:
            if exc.code != 412:
                raise
            continue
        for msg in data.get("messages", []):
            click.echo(msg)
        return
    raise click.ClickException(f"the settings kept changing while saving ({SETTINGS_TRIES} tries): "
                               "someone else is saving them; try again")


#: how often ``urc settings set`` loads the settings again when a save came in between
SETTINGS_TRIES = 3


# ---------------------------------------------------------------- fleet (MQTT)
@main.group("fleet", invoke_without_command=True)
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
    from .mqtt.config import parse_url
    from .mqtt.fleet import Target, show

    auth: dict = {}
    if config_path is not None:
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
    ctx.obj = Target(broker, auth, prefix)
    if ctx.invoked_subcommand is None:
        _fleet_run(show(ctx.obj, once, wait_s, as_json, click.echo))


def _fleet_run(coro: Any) -> Any:
    import asyncio

    import aiomqtt

    try:
        return asyncio.run(coro)
    except aiomqtt.MqttError as exc:
        raise click.ClickException(f"MQTT broker: {exc}") from None
    except KeyboardInterrupt:
        return None


def _fleet_send(target: Target, station: str, command: dict) -> None:
    from .mqtt.fleet import CommandFailed, send_command

    base = target.base(station)
    try:
        result = _fleet_run(send_command(target.broker, base, command, **target.auth))
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
def fleet_stop(target: Target, station: str, axis: str | None) -> None:
    """Stop STATION: tracking, a calibration, both axes (always accepted)."""
    _fleet_send(target, station, {"command": "stop", **({"axis": axis} if axis else {})})


@fleet_command.command("park")
@click.argument("station")
@click.pass_obj
def fleet_park(target: Target, station: str) -> None:
    """Park STATION."""
    _fleet_send(target, station, {"command": "park"})


@fleet_command.command("goto")
@click.argument("station")
@click.argument("az", type=float)
@click.argument("el", type=float, required=False)
@click.pass_obj
def fleet_goto(target: Target, station: str, az: float, el: float | None) -> None:
    """Point STATION at AZ [EL] degrees."""
    _fleet_send(target, station, {"command": "goto", "az_deg": az, **({"el_deg": el} if el is not None else {})})


@fleet_command.command("clear-faults")
@click.argument("station")
@click.pass_obj
def fleet_clear_faults(target: Target, station: str) -> None:
    """Clear STATION's latched faults."""
    _fleet_send(target, station, {"command": "clear_faults"})


@fleet_command.command("track")
@click.argument("station")
@click.argument("target_name", metavar="TARGET")
@click.pass_obj
def fleet_track(target: Target, station: str, target_name: str) -> None:
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
    _fleet_send(target, station, cmd)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
