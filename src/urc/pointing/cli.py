"""``urc calibrate sun|moon|beacon [--apply]``: ask the running urc to scan, show the
progress, print the offset found (or why it was refused); --apply saves it."""

from __future__ import annotations

import time

import click

from ..cli import _client_options, _request


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
