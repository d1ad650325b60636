"""``urc calibrate sun|moon|beacon [--apply]``: ask the running urc to scan, show the
progress, print the offset found (or why it was refused); --apply saves it.
``urc pointing show|fit|clear``: the pointing model the running urc keeps and applies."""

from __future__ import annotations

import time

import click

from .cli import _client_options, _request


@click.command("calibrate")
@click.argument("target", type=click.Choice(["sun", "moon", "beacon"]))
@click.option("--az", "az_deg", type=float, help="The beacon's azimuth (degrees).")
@click.option("--el", "el_deg", type=float, help="The beacon's elevation (degrees).")
@click.option("--apply", "apply_", is_flag=True, help="Save the offsets found as the new [offsets].")
@_client_options
def calibrate_command(target: str, az_deg: float | None, el_deg: float | None, apply_: bool,
                      url: str | None, config_path: str | None) -> None:
    """Scan across the Sun, the Moon or a beacon and measure the pointing offset."""
    body = {"target": target, "az_deg": az_deg, "el_deg": el_deg}
    _request(url, config_path, "POST", "/api/calibration/scan", body)
    last = ""
    try:
        while True:
            proc = _request(url, config_path, "GET", "/api/calibration/procedure")["procedure"] or {}
            line = f"[{proc.get('progress', 0) * 100:3.0f}%] {proc.get('step', '')}"
            if line != last:
                click.echo(line)
                last = line
            if proc.get("state") != "running":
                break
            time.sleep(1.0)
    except KeyboardInterrupt:
        _request(url, config_path, "POST", "/api/calibration/procedure/cancel")
        raise click.ClickException("cancelled: the antenna was stopped") from None
    scan = _request(url, config_path, "GET", "/api/calibration/scan")["scan"] or {}
    res = scan.get("result") or {}
    if scan.get("state") != "done":
        raise click.ClickException(f"no offset: {scan.get('error') or scan.get('state')}")
    click.echo(f"offset: az {res['az_offset_deg']:+.3f} +- {res['az_offset_err_deg']:.3f} deg, "
               f"el {res['el_offset_deg']:+.3f} +- {res['el_offset_err_deg']:.3f} deg "
               f"(beam {res['fwhm_deg'][0]:.2f} x {res['fwhm_deg'][1]:.2f} deg)")
    new = res["offsets_suggested"]
    click.echo(f"new [offsets]: az_deg = {new['az_deg']:.3f}, el_deg = {new['el_deg']:.3f}")
    if apply_:
        saved = _request(url, config_path, "POST", "/api/calibration/scan/apply")
        for msg in saved.get("messages", []):
            click.echo(msg)
    else:
        click.echo(f"(urc calibrate {target} --apply saves them)")


# ----------------------------------------------------------------------- urc pointing
@click.group("pointing")
def pointing_command() -> None:
    """The pointing model: show it, fit it to the calibration scans, clear it."""


def _print_model(model: dict | None, in_force: list[float] | None, order: list[str], problem: str = "") -> None:
    """``in_force``: the terms the running urc points with (None: not shown)."""
    if problem:
        click.echo(f"stored model unusable: {problem}")
    if model is None:
        click.echo("no pointing model stored" + ("; one is in force (stored before)" if any(in_force or ()) else ""))
        return
    click.echo(f"pointing model fitted {model['date']} from {model.get('source') or str(model['scans']) + ' scans'}")
    for name in order:
        t = model["terms"][name]
        err = t.get("err_deg")
        click.echo(f"  {name.upper():5s}{t['value_deg']:+8.4f} deg " + (f"+- {err:.4f}" if err is not None else "(not fitted)"))
    click.echo(f"residual RMS {model['residual_rms_deg']:.4f} deg on the sky over {model['scans']} scans "
               f"(reduced chi-square {model.get('chi2_reduced', float('nan')):.2f})")
    if in_force is None:
        return
    stored = [model["terms"][n]["value_deg"] for n in order]
    same = len(in_force) == len(stored) and all(abs(a - b) < 1e-9 for a, b in zip(in_force, stored))
    click.echo("in force: yes" if same else "in force: no (the running urc points with "
               + (", ".join(f"{n.upper()} {v:+.4f}" for n, v in zip(order, in_force)) if in_force else "no model") + ")")


@pointing_command.command("show")
@_client_options
def pointing_show(url: str | None, config_path: str | None) -> None:
    """The stored pointing model, each term with its uncertainty, and the one in force."""
    r = _request(url, config_path, "GET", "/api/calibration/pointing-model")
    _print_model(r.get("model"), r.get("in_force") or [], r.get("terms_order") or [], r.get("problem", ""))
    click.echo(f"scans stored: {r.get('scans_stored', 0)}")


@pointing_command.command("fit")
@click.option("--scans", "scans_file", type=click.Path(dir_okay=False),
              help="Fit to the scans in this file (JSON lines, a list, or a saved model) instead of the stored ones.")
@click.option("--terms", help="The terms to fit, comma separated (IA,IE,CA,NPAE,AN,AW,TF; default all).")
@_client_options
def pointing_fit(scans_file: str | None, terms: str | None, url: str | None, config_path: str | None) -> None:
    """Fit the pointing model to the calibration scans, save it and apply it."""
    from .pointing.store import POINTING_TERMS, PointingStoreError, read_scans

    body: dict = {}
    if terms:
        names = [t.strip().lower() for t in terms.split(",") if t.strip()]
        unknown = [t for t in names if t not in POINTING_TERMS]
        if unknown or not names:
            raise click.BadParameter(f"unknown term(s) {', '.join(unknown) or '(none given)'}; expected "
                                     f"{','.join(t.upper() for t in POINTING_TERMS)}", param_hint="--terms")
        body["terms"] = names
    if scans_file:
        try:
            body["scans"] = read_scans(scans_file)
        except PointingStoreError as exc:
            raise click.ClickException(str(exc)) from None
    r = _request(url, config_path, "POST", "/api/calibration/pointing-model/fit", body)
    _print_model(r.get("model"), None, list(POINTING_TERMS))
    for msg in r.get("messages", []):
        click.echo(msg)


@pointing_command.command("clear")
@_client_options
def pointing_clear(url: str | None, config_path: str | None) -> None:
    """Remove the stored pointing model (the scans stay) and point without it."""
    r = _request(url, config_path, "DELETE", "/api/calibration/pointing-model")
    for msg in r.get("messages", []):
        click.echo(msg)
