"""The dashboard of a single-axis rotator ([rotator] elevation = false) in Debian's
chromium against a real ``urc run``: no elevation control or readout is shown, the
azimuth controls work, the sky plot draws the beam on the horizon ring."""

from __future__ import annotations

import math

import pytest
from urc_process import UrcProcess, wait_until


@pytest.fixture(scope="module")
def urc(tmp_path_factory):
    u = UrcProcess(tmp_path_factory.mktemp("web-az-only"), profile="tartu-urc")
    u.config.write_text(u.config.read_text().replace('profile = "tartu-urc"\n',
                                                     'profile = "tartu-urc"\nelevation = false\n'))
    u.start()
    yield u
    u.kill()     # (at once: the page's tests do not test urc's orderly stop, test_cli does)


def test_elevation_controls_are_hidden_and_azimuth_works(urc, shared_page, artifacts):
    page = shared_page(urc.url + "/")
    page.wait_for_function("document.body.classList.contains('az-only')")
    for sel in ("#goto-el", ".jog-btn.up", ".jog-btn.down", "#ro-el", "#ro-tel", "#ro-mel", "#ro-modeel",
                "#chart-el"):
        assert page.locator(sel).is_hidden(), sel
    for sel in ("#goto-az", ".jog-btn.cw", ".jog-btn.ccw", "#ro-az", "#chart-az"):
        assert page.locator(sel).is_visible(), sel
    page.fill("#goto-az", "10")                # (6 deg/s: a short move, away from park at 0)
    page.click("#goto-form button[type=submit]")
    s = urc.wait(lambda s: abs(s["az_deg"] - 10.0) < 0.3 and not s["moving"], 30)
    assert s["el"] is None
    m = page.locator("#sky-antenna")
    # (the page draws a status a frame or two after urc sent it)
    wait_until(lambda: float(m.get_attribute("data-az-deg")) == pytest.approx(s["az_deg"], abs=0.2), 10,
               f"the marker at the standing antenna's az {s['az_deg']}")
    assert m.get_attribute("data-el-deg") is None  # no elevation presented as measured
    # the beam is drawn on the horizon ring in the direction of the azimuth
    cx, cy = float(m.get_attribute("cx")), float(m.get_attribute("cy"))
    assert math.hypot(cx - 100 * math.sin(math.radians(10)), cy + 100 * math.cos(math.radians(10))) < 1.0
    # the arrow keys up/down do nothing (no elevation to jog), and nothing faults
    page.locator("body").click(position={"x": 5, "y": 300})
    page.keyboard.down("ArrowUp")
    page.wait_for_timeout(500)
    page.keyboard.up("ArrowUp")
    s = urc.status()
    assert not s["moving"] and not s["faults"]
    page.screenshot(path=str(artifacts / "dashboard-az-only.png"), full_page=True)
    page.problems.check()


def test_settings_page_shows_the_elevation_switch(urc, shared_page):
    page = shared_page(urc.url + "/#settings")
    sel = page.locator("#f-rotator\\.elevation")
    sel.wait_for()
    assert sel.input_value() == "false"
    # the rest of the BIG-RAS menu is there too
    assert page.locator("#f-rotator\\.zero").input_value() == "north"
    assert page.locator("#f-rotator\\.pulses_per_deg").count() == 1
    assert page.locator("#f-control\\.az\\.min_rate_deg_per_s").count() == 1
    page.click("#settings-validate")
    # urc's answer shown: "valid" in the result list, or a field's error
    page.locator("#settings-result li, .field-error:not(:empty)").first.wait_for()
    assert page.locator(".field-error:not(:empty)").count() == 0  # the az-only document is valid as shown
    page.problems.check()
