"""The calibration scan's plot (static/js/scanplot.js) in Debian's chromium: a scan report
as GET /api/calibration/scan gives it, drawn as power against offset, each leg's dots,
the fitted peaks where the fit put them. The page is a harness around the module (its
files served from the package by route interception): no urc process is needed. (Before
this the module did not exist: the test fails there.)"""

from __future__ import annotations

import math
from pathlib import Path
from urllib.parse import urlparse

import urc.web

STATIC = Path(urc.web.__file__).parent / "static"
HARNESS = """<!doctype html><html><body>
<section id="view-calibration"><div class="grid"></div></section>
<script type="module">
import { showScan } from "/static/js/scanplot.js";
await showScan();
document.body.dataset.drawn = "1";
</script></body></html>"""


def report() -> dict:
    """A cross scan of a 10 deg beam peaking at +1.5 deg across and -0.8 deg up."""
    samples = []
    for leg, peak in (("az", 1.5), ("el", -0.8)):
        for i in range(-8, 9):
            off = i * 2.5
            value = 10 * math.log10(1 + 30 * math.exp(-((off - peak) ** 2) / (2 * 4.25 ** 2)))
            samples.append({"leg": leg, "dx_deg": off if leg == "az" else 0.0, "dy_deg": off if leg == "el" else 0.0,
                            "value": value, "unit": "dB", "t_unix_s": 0.0, "target_el_deg": 30.0})
    return {"kind": "scan", "state": "done", "step": "done", "progress": 1.0, "error": "", "target": "beacon",
            "samples": samples, "result": {"dx_deg": 1.5, "dy_deg": -0.8, "az_offset_deg": 1.73, "el_offset_deg": -0.8}}


def test_the_scan_is_drawn_as_power_against_offset(browser, artifacts):
    ctx = browser.new_context(viewport={"width": 900, "height": 600})
    page = ctx.new_page()
    errors: list[str] = []
    page.on("pageerror", lambda e: errors.append(str(e)))

    def serve(route):
        path = urlparse(route.request.url).path
        if path == "/harness.html":
            route.fulfill(body=HARNESS, content_type="text/html")
        elif path.startswith("/static/js/") and (STATIC / path[len("/static/"):]).is_file():
            route.fulfill(path=str(STATIC / path[len("/static/"):]), content_type="text/javascript")
        elif path == "/api/calibration/scan":
            route.fulfill(json={"ok": True, "scan": report()})
        else:
            route.fulfill(status=404, body="")
    try:
        page.route("http://urc.test/**", serve)
        page.goto("http://urc.test/harness.html")
        page.wait_for_selector("body[data-drawn='1']", timeout=15_000)
        assert not errors, errors
        assert page.locator("#scan-card svg").count() == 1
        assert page.locator("#scan-card g[data-leg='az'] circle").count() == 17
        assert page.locator("#scan-card g[data-leg='el'] circle").count() == 17
        # the fitted peaks drawn where the offsets are: the az one right of 0, the el one left
        peaks = page.eval_on_selector_all("#scan-card .scan-peak", "ls => ls.map(l => [l.closest('g').dataset.leg,"
                                          " +l.dataset.offset, +l.getAttribute('x1')])")
        zero_x = float(page.eval_on_selector("#scan-card svg line[stroke-dasharray]", "l => +l.getAttribute('x1')"))
        by_leg = {leg: (off, x) for leg, off, x in peaks}
        assert by_leg["az"][0] == 1.5 and by_leg["az"][1] > zero_x
        assert by_leg["el"][0] == -0.8 and by_leg["el"][1] < zero_x
        # the highest dot of the az leg is the one nearest its peak (up is up)
        top = page.eval_on_selector_all("#scan-card g[data-leg='az'] circle",
                                        "cs => cs.reduce((a, c) => +c.getAttribute('cy') < +a.getAttribute('cy') ? c : a)"
                                        ".getAttribute('cx')")
        assert abs(float(top) - by_leg["az"][1]) < 30
        text = page.inner_text("#scan-card")
        assert "dB" in text and "1.730" in text and "beacon" in text
        page.screenshot(path=str(artifacts / "calibration-scan-plot.png"))
    finally:
        ctx.close()
