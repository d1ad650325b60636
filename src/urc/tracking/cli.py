"""``urc passes`` and ``urc tle ...``: click commands the main CLI registers.

    main.add_command(passes_command)   # urc passes [SAT ...] --hours 24 --min-el 10 ...
    main.add_command(tle_command)      # urc tle import FILE | update [GROUP ...] | list
"""

from __future__ import annotations

import json
import os
import sys
import time
from datetime import datetime, timezone
from pathlib import Path
from typing import Any, Callable

import click

from ..errors import UrcError

__all__ = ["default_catalog_dir", "passes_command", "tle_command"]

#: searches of more satellites than this show a progress bar.
_PROGRESS_MIN_SATS = 100


#: a running controller reads the catalog again within tracking.service.CATALOG_CHECK_S
RUNNING_NOTE = ("a running urc reads the catalog again within seconds and flies the new "
                "elements from the next pass on")


def default_catalog_dir() -> Path:
    import platformdirs

    return Path(platformdirs.user_data_dir("urc")) / "catalog"


def _catalog_dir_option(fn: Callable) -> Callable:
    return click.option("--catalog-dir", type=click.Path(file_okay=False), envvar="URC_CATALOG_DIR",
                        help="Where the element catalog lives (default: the per-user data "
                             "directory, urc/catalog; env URC_CATALOG_DIR).")(fn)


def _config_option(fn: Callable) -> Callable:
    return click.option("--config", "config_path", type=click.Path(dir_okay=False),
                        help="urc TOML configuration: [station] and [tracking] give the "
                             "defaults the options here override.")(fn)


def _load_config(config_path: str | None) -> Any:
    if not config_path:
        return None
    from ..config import load_config

    try:
        return load_config(config_path)
    except UrcError as exc:
        raise _fail(exc) from None


def _resolve_dir(catalog_dir: str | None, cfg: Any = None) -> Path:
    if catalog_dir:
        return Path(catalog_dir).expanduser()
    tracking: Any = getattr(cfg, "tracking", None)
    if tracking is not None and getattr(tracking, "catalog_dir", None):
        return Path(tracking.catalog_dir).expanduser()
    return default_catalog_dir()


def _running_urc(cfg: Any, url: str | None, port: int | None) -> str:
    """The running urc's address: --url or --port, else the configuration's [api]."""
    from ..api_client import DEFAULT_URL, base_url

    if url is not None and port is not None:
        raise click.UsageError("give --url or --port, not both")
    if url is None and port is None and cfg is not None:
        host = "127.0.0.1" if cfg.api.host in ("0.0.0.0", "::") else cfg.api.host
        host = f"[{host}]" if ":" in host else host
        return f"http://{host}:{cfg.api.port}"
    return base_url(url, port) if (url or port) else DEFAULT_URL


def _ask_running(url: str, path: str, cfg: Any, how: str) -> dict:
    from ..api_client import ClientError, request

    token = os.environ.get("URC_TOKEN", "") or getattr(getattr(cfg, "api", None), "token", "")
    try:
        answer = request(url, "GET", path, token=token, timeout_s=10.0)
    except ClientError as exc:
        raise click.UsageError(f"no station position: asked the running urc, and {exc}; {how}") from None
    return answer if isinstance(answer, dict) else {}


def _running_gps_fix(cfg: Any, url: str) -> tuple[float, float, float]:
    """[station] gps without lat/lon: the station is where the running controller's GPS
    receiver says (its status), else a clear error saying how to get a position."""
    how = ("give --lat, --lon and --alt, set [station] lat_deg/lon_deg, or run `urc run` with "
           "this configuration until its receiver has a fix (`urc status` shows it)")
    gps = (_ask_running(url, "/api/status", cfg, how).get("tracking") or {}).get("gps") or {}
    if gps.get("lat_deg") is None:
        raise click.UsageError(f"no station position: the running urc's GPS ({cfg.station.gps}) has no "
                               f"fix yet; {how}")
    return float(gps["lat_deg"]), float(gps["lon_deg"]), float(gps.get("alt_m") or 0.0)


def _running_station(cfg: Any, url: str) -> tuple[tuple[float, float, float], float]:
    """The running urc's [station] position and [tracking] min_el_deg (--url/--port)."""
    how = "give --lat and --lon, or add [station] lat_deg/lon_deg to that urc's configuration"
    info = _ask_running(url, "/api/info", cfg, how)
    st = info.get("station")
    if not isinstance(st, dict) or st.get("lat_deg") is None:
        raise click.UsageError(f"no station position: the urc at {url} has none; {how}")
    return ((float(st["lat_deg"]), float(st["lon_deg"]), float(st.get("alt_m") or 0.0)),
            float(info.get("tracking_min_el_deg", _default_min_el_deg())))


def _default_min_el_deg() -> float:
    """[tracking] min_el_deg's default: the passes the tracker flies (one default, with or
    without a configuration)."""
    from ..config.sections import TrackingSection

    return float(TrackingSection.model_fields["min_el_deg"].default)


def _fail(exc: Exception) -> click.ClickException:
    return click.ClickException(str(exc))


def _parse_start(text: str | None) -> datetime:
    if not text:
        return datetime.now(timezone.utc)
    try:
        t = datetime.fromisoformat(text.strip().replace("Z", "+00:00"))
    except ValueError:
        raise click.BadParameter(f"expected an ISO 8601 time like 2024-01-01T12:00Z, found "
                                 f"{text!r}", param_hint="--start") from None
    return t if t.tzinfo else t.replace(tzinfo=timezone.utc)


def _fmt_t(t: datetime) -> str:
    return t.strftime("%Y-%m-%d %H:%M:%S")


# --------------------------------------------------------------------------- passes


@click.command("passes")
@click.argument("sats", nargs=-1)
@click.option("--hours", type=click.FloatRange(min=0.01, max=24 * 30), default=24.0,
              show_default=True, help="How far ahead to search.")
@click.option("--min-el", "min_el_deg", type=click.FloatRange(-10.0, 89.0), default=None,
              help="Minimum elevation of a pass (degrees) [default: [tracking] min_el_deg of "
                   "--config, or of the running urc the station comes from; unset: 0, the "
                   "passes the tracker flies].")
@click.option("--all", "all_sats", is_flag=True, help="Every satellite in the catalog.")
@click.option("--tle", "tle_file", type=click.Path(dir_okay=False),
              help="Take elements from this TLE/OMM file instead of the catalog.")
@click.option("--lat", "lat_deg", type=click.FloatRange(-90, 90), help="Station latitude (deg).")
@click.option("--lon", "lon_deg", type=click.FloatRange(-180, 360),
              help="Station longitude (deg, east +).")
@click.option("--alt", "alt_m", type=float, default=None,
              help="Station height above the WGS84 ellipsoid (m) [default: [station] alt_m, "
                   "else 0].")
@click.option("--start", help="Search start, ISO 8601 UTC (default: now).")
@click.option("--json", "as_json", is_flag=True, help="Print JSON instead of a table.")
@click.option("--url", envvar="URC_URL", default=None,
              help="A running urc's API address: the station (and min elevation) come from it "
                   "when neither --lat/--lon nor --config gives one.")
@click.option("--port", type=click.IntRange(1, 65535), default=None,
              help="A running urc's API port on this host (as given to `urc run --port`), as --url.")
@_catalog_dir_option
@_config_option
def passes_command(sats: tuple[str, ...], hours: float, min_el_deg: float | None,
                   all_sats: bool, tle_file: str | None, lat_deg: float | None,
                   lon_deg: float | None, alt_m: float | None, start: str | None, as_json: bool,
                   url: str | None, port: int | None, catalog_dir: str | None, config_path: str | None) -> None:
    """List passes (AOS, TCA, LOS in UTC, max elevation, azimuth at AOS and LOS).

    SATS are names (any case, a unique prefix will do) or NORAD ids; --all searches the
    whole catalog. The station: --lat/--lon, else --config's [station], else the running
    urc's (--url/--port, or --config's [station] gps: its receiver's fix).
    """
    from .elements import Catalog, load_elements
    from .passes import search_passes
    from .station import Station

    cfg = _load_config(config_path)
    conf_st: Any = getattr(cfg, "station", None)
    if lat_deg is None and lon_deg is None and getattr(conf_st, "lat_deg", None) is not None:
        lat_deg, lon_deg = conf_st.lat_deg, conf_st.lon_deg
        alt_m = conf_st.alt_m if alt_m is None else alt_m
    running_min_el_deg = None
    if lat_deg is None and lon_deg is None and getattr(conf_st, "gps", None):
        lat_deg, lon_deg, fix_alt_m = _running_gps_fix(cfg, _running_urc(cfg, url, port))
        alt_m = fix_alt_m if alt_m is None else alt_m
    elif lat_deg is None and lon_deg is None and (url is not None or port is not None):
        (lat_deg, lon_deg, run_alt_m), running_min_el_deg = _running_station(cfg, _running_urc(cfg, url, port))
        alt_m = run_alt_m if alt_m is None else alt_m
    if lat_deg is None or lon_deg is None:
        raise click.UsageError("no station position: give --lat and --lon (degrees) and "
                               "--alt (metres), a --config with a [station] section, or "
                               "--port/--url of a running urc that has one")
    alt_m = 0.0 if alt_m is None else alt_m
    if min_el_deg is None:
        min_el_deg = (float(cfg.tracking.min_el_deg) if cfg is not None else
                      running_min_el_deg if running_min_el_deg is not None else _default_min_el_deg())
    where = _resolve_dir(catalog_dir, cfg)
    try:
        station = Station(lat_deg, lon_deg, alt_m)
        if tle_file:
            catalog = Catalog(load_elements(tle_file))
        else:
            catalog = Catalog.load(where)
        if not len(catalog):
            raise click.ClickException(
                f"the catalog in {where} is empty: run `urc tle update` "
                "or `urc tle import FILE`, or pass --tle FILE")
        if sats:
            chosen = catalog.select(sats)
        elif all_sats or tle_file:
            chosen = list(catalog)
        else:
            raise click.UsageError("name satellites (names or NORAD ids) or use --all")
        t0 = _parse_start(start)
        if len(chosen) > _PROGRESS_MIN_SATS:  # on stderr: JSON on stdout stays clean
            with click.progressbar(length=len(chosen), label="Searching passes",
                                   file=sys.stderr, show_pos=True) as bar:
                state = {"done": 0}

                def progress(done: int, total: int) -> None:
                    bar.update(done - state["done"])
                    state["done"] = done

                res = search_passes(chosen, station, t0, duration_s=hours * 3600.0,
                                    min_el_deg=min_el_deg, progress=progress, chunk_size=250)
        else:
            res = search_passes(chosen, station, t0, duration_s=hours * 3600.0,
                                min_el_deg=min_el_deg)
    except UrcError as exc:
        raise _fail(exc) from None
    stale = _stale_elements(chosen, t0)
    if as_json:
        click.echo(json.dumps({
            "station": {"lat_deg": lat_deg, "lon_deg": lon_deg, "alt_m": alt_m},
            "start": res.start.isoformat(), "end": res.end.isoformat(),
            "min_el_deg": min_el_deg, "satellites": len(chosen),
            "passes": [p.to_dict() for p in res.passes], "errors": {
                str(k): v for k, v in res.errors.items()},
            "warnings": stale}, indent=1))
        return
    _print_passes(res, len(chosen))
    for text in stale:
        click.echo(f"warning: {text}", err=True)


def _stale_elements(sats: list[Any], t0: datetime) -> list[str]:
    """A warning per satellite whose elements are older than the tracker accepts quietly
    (tracker.STALE_ELEMENTS_DAYS) at the search start: its pass times drift."""
    from .tracker import STALE_ELEMENTS_DAYS

    out = []
    for es in sats:
        age_days = (t0.timestamp() - es.epoch_unix_s) / 86400.0
        if age_days > STALE_ELEMENTS_DAYS:
            out.append(f"{es.label} (NORAD {es.norad_id}): elements {age_days:.0f} days old (epoch "
                       f"{es.epoch:%Y-%m-%d}); its pass times and directions drift: `urc tle update`")
    return out


def _print_passes(res: Any, n_sats: int) -> None:
    click.echo(f"{len(res.passes)} pass{'es' if len(res.passes) != 1 else ''} of {n_sats} "
               f"satellite{'s' if n_sats != 1 else ''} above {res.min_el_deg:g} deg, "
               f"{_fmt_t(res.start)} to {_fmt_t(res.end)} UTC")
    if res.passes:
        name_w = min(max(9, *(len(p.name) for p in res.passes)), 24)
        head = (f"{'satellite':<{name_w}} {'norad':>6}  {'AOS (UTC)':<20} {'TCA':<8}  "
                f"{'LOS':<9} {'max el':>6} {'az AOS':>6} {'az LOS':>6} {'min':>5}")
        click.echo(head)
        click.echo("-" * len(head))
        for p in res.passes:
            if p.always_up:  # geostationary: no rise, no set, one "pass" the window long
                click.echo(f"{p.name[:name_w]:<{name_w}} {p.norad_id:>6}  always above the horizon "
                           f"(el {p.max_el_deg:.1f} at most, az {p.tca_az_deg:.1f} then)")
                continue
            aos = ("<" if p.aos_clipped else " ") + _fmt_t(p.aos)
            los = p.los.strftime("%H:%M:%S") + (">" if p.los_clipped else " ")
            click.echo(f"{p.name[:name_w]:<{name_w}} {p.norad_id:>6} {aos:<20} "
                       f"{p.tca.strftime('%H:%M:%S'):<8}  {los:<9} {p.max_el_deg:>6.1f} "
                       f"{p.aos_az_deg:>6.1f} {p.los_az_deg:>6.1f} {p.duration_s / 60:>5.1f}")
        if any((p.aos_clipped or p.los_clipped) and not p.always_up for p in res.passes):
            click.echo("< already up at the start   > still up at the end")
    for norad, why in sorted(res.errors.items()):
        click.echo(f"warning: NORAD {norad}: {why}", err=True)


# --------------------------------------------------------------------------- tle


@click.group("tle")
def tle_command() -> None:
    """The orbital element catalog: import files, update from CelesTrak, list."""


@tle_command.command("import")
@click.argument("files", nargs=-1, required=True, type=click.Path(dir_okay=False))
@click.option("--no-checksum", is_flag=True, help="Accept TLE lines with wrong checksums.")
@_catalog_dir_option
@_config_option
def tle_import(files: tuple[str, ...], no_checksum: bool, catalog_dir: str | None,
               config_path: str | None) -> None:
    """Import TLE/3LE, OMM JSON or OMM CSV files (newest epoch per satellite wins)."""
    from .elements import StreamingImport, iter_elements

    where = _resolve_dir(catalog_dir, _load_config(config_path))
    # streaming: a 50 MB file of 350k sets is read set by set, never held whole
    try:
        cat = StreamingImport(where)
    except UrcError as exc:
        raise _fail(exc) from None
    try:
        for f in files:
            counted = {"n": 0}

            def usable(sets):
                for es in sets:
                    counted["n"] += 1
                    if es.sgp4_error:  # kept out: the catalog's older set, if any, stays usable
                        click.echo(f"warning: {es.label} (NORAD {es.norad_id}) not imported: "
                                   f"{es.sgp4_error} at its epoch {es.epoch:%Y-%m-%d}", err=True)
                        continue
                    yield es
            r = cat.merge(usable(iter_elements(f, checksum=not no_checksum)))
            click.echo(f"{f}: {counted['n']} element sets: {len(r.added)} new, "
                       f"{len(r.updated)} newer, {len(r.kept)} not newer (kept the catalog's)")
        size = len(cat)
        cat.save()
    except UrcError as exc:
        cat.close()
        raise _fail(exc) from None
    click.echo(f"catalog: {size} satellites in {where}")
    click.echo(RUNNING_NOTE)


@tle_command.command("update")
@click.argument("groups", nargs=-1)
@click.option("--force", is_flag=True, help="Download even if the cached copy is < 2 h old.")
@click.option("--timeout", "timeout_s", type=click.FloatRange(min=1.0), default=30.0,
              show_default=True, help="Network timeout per group (s).")
@_catalog_dir_option
@_config_option
def tle_update(groups: tuple[str, ...], force: bool, timeout_s: float,
               catalog_dir: str | None, config_path: str | None) -> None:
    """Download CelesTrak GROUPS (default: [tracking] groups, else stations amateur
    weather noaa cubesat)."""
    from . import download
    from .errors import DownloadError

    cfg = _load_config(config_path)
    where = _resolve_dir(catalog_dir, cfg)
    names = list(groups) or list(getattr(getattr(cfg, "tracking", None), "groups", ())
                                 or download.DEFAULT_GROUPS)
    try:
        with click.progressbar(length=len(names), label="Updating", file=sys.stderr,
                               item_show_func=lambda g: g or "") as bar:
            def progress(done: int, total: int, group: str) -> None:
                bar.current_item = group
                bar.update(1)

            # looked up now, not at import: tests swap in a fake network
            report = download.update_catalog(names, where, fetch=download.fetch_url,
                                             force=force, timeout_s=timeout_s,
                                             progress=progress)
    except DownloadError as exc:
        partial = getattr(exc, "report", None)
        if partial is not None:
            _print_update(partial, where)
        raise _fail(exc) from None
    except UrcError as exc:
        raise _fail(exc) from None
    _print_update(report, where)


def _print_update(report: Any, where: Path) -> None:
    for g in report.groups:
        if g.status == "failed":
            continue
        how = "downloaded" if g.status == "downloaded" else "cached copy (< 2 h old)"
        click.echo(f"{g.group}: {g.count} element sets, {how}")
    m = report.merge
    click.echo(f"catalog: {report.catalog_size} satellites in {where} ({len(m.added)} new, "
               f"{len(m.updated)} updated)")
    click.echo(RUNNING_NOTE)


@tle_command.command("list")
@click.argument("pattern", required=False)
@click.option("--json", "as_json", is_flag=True, help="Print JSON.")
@_catalog_dir_option
@_config_option
def tle_list(pattern: str | None, as_json: bool, catalog_dir: str | None,
             config_path: str | None) -> None:
    """List the catalog (optionally only names containing PATTERN, or one NORAD id)."""
    from .elements import Catalog

    where = _resolve_dir(catalog_dir, _load_config(config_path))
    try:
        cat = Catalog.load(where)
    except UrcError as exc:
        raise _fail(exc) from None
    sets = list(cat)
    if pattern:
        want = pattern.casefold()
        sets = [es for es in sets if want in es.name.casefold() or pattern == str(es.norad_id)]
    now = time.time()
    if as_json:
        click.echo(json.dumps([{"norad_id": es.norad_id, "name": es.name,
                                "epoch": es.epoch.isoformat(),
                                "age_days": round((now - es.epoch_unix_s) / 86400.0, 3),
                                "source": es.source} for es in sets], indent=1))
        return
    if not sets:
        click.echo(f"no element sets{' matching ' + repr(pattern) if pattern else ''} in "
                   f"{where}")
        return
    click.echo(f"{'norad':>6}  {'name':<24} {'epoch (UTC)':<19} {'age d':>6}")
    for es in sets:
        age_d = (now - es.epoch_unix_s) / 86400.0
        flag = "  (old: update it)" if age_d > 14 else ""
        click.echo(f"{es.norad_id:>6}  {es.label[:24]:<24} {_fmt_t(es.epoch):<19} "
                   f"{age_d:>6.1f}{flag}")
    click.echo(f"{len(sets)} of {len(cat)} satellites, {where}")
