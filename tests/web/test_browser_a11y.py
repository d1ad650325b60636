"""Accessibility and self-containment of the pages, in Debian's chromium: axe-core's rules
(the npm package, installed by scripts/test.sh from tests/web/package-lock.json and loaded
from that file, never from the network) find nothing on any view of the dashboard, with
every card, banner and table shown; the API's own documentation pages fetch nothing
from another origin (issue 22)."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest
from playwright.sync_api import expect
from urc_process import HTTP, wait_until

from .conftest import release_when_unused
from .fake_tracker import FakeTracker
from .test_browser import TWO_FRAMES, InProcessUrc

AXE = Path(__file__).resolve().parent / "node_modules" / "axe-core" / "axe.min.js"
if not AXE.exists():  # scripts/test.sh installs it: missing is a failure, not a skip
    pytest.fail(f"axe-core not found at {AXE}: run `npm ci --prefix tests/web` (scripts/test.sh does)",
                pytrace=False)

VIEWS = ("dashboard", "settings", "calibration")


def axe_violations(page) -> list[dict]:
    """axe.run over the whole document; each violation with the nodes it names. (axe is
    injected once per document: each run starts afresh, and a second copy of the large
    bundle only cost time.)"""
    if not page.evaluate("() => typeof window.axe === 'object' && typeof window.axe.run === 'function'"):
        page.add_script_tag(path=str(AXE))
    result = page.evaluate("() => axe.run(document, { resultTypes: ['violations'] })")
    return [{"id": v["id"], "impact": v["impact"], "help": v["help"],
             "nodes": [n["target"] for n in v["nodes"]][:5]} for v in result["violations"]]


@pytest.fixture(scope="module")
def busy_urc(tmp_path_factory, request):
    """A urc with everything on screen: a tracker with passes, a pass planned (the track
    banner and its notes), a keep-out zone, and a latched fault (the fault banner). Ended
    after the last test that asks for it (its control loop runs in this process)."""
    trk = FakeTracker()
    srv = InProcessUrc(tmp_path_factory.mktemp("a11y") / "state", trk).__enter__()
    srv.trk = trk
    running = [True]

    def close():
        if running:
            running.clear()
            srv.__exit__(None, None, None)
    release_when_unused(request, close)
    try:
        yield srv
    finally:
        close()


@pytest.mark.parametrize("width,height", [(390, 844), (1366, 768)], ids=["phone", "desktop"])
def test_axe_finds_no_violation_on_any_view(busy_urc, open_page, width, height):
    srv = busy_urc
    # bypass_csp: the page's policy forbids inline scripts, and axe is injected as one
    page = open_page(srv.url + "/", width, height, bypass_csp=True)
    page.wait_for_selector("#passes-body tr", timeout=5000)
    page.locator('#passes-body tr[data-norad="25544"] button.track-pass').click()
    expect(page.locator("#track-banner")).to_be_visible(timeout=5000)
    assert HTTP.post(srv.url + "/api/sim/fault", json={"axis": "el", "kind": "sensor_dead"}).status_code == 200
    try:
        expect(page.locator("#fault-banner")).to_be_visible(timeout=5000)
        found = {}
        for view in VIEWS:
            page.click(f'nav a[data-view="{view}"]')
            expect(page.locator(f"#view-{view}")).to_be_visible()
            if view == "settings":
                page.locator(".zone-row").first.wait_for()
                rows = page.locator(".serve-row").count()  # (the default [[serve]] list)
                page.click("#add-serve")                   # one more, with its selects
                expect(page.locator(".serve-row")).to_have_count(rows + 1)
            elif view == "calibration":                    # (its sensor table, loaded on the way in)
                expect(page.locator("#cal-sensors tr").first).to_be_attached()
            page.evaluate(TWO_FRAMES)
            found[view] = axe_violations(page)
        assert found == {v: [] for v in VIEWS}, json.dumps(found, indent=1)
    finally:
        HTTP.post(srv.url + "/api/sim/clear", json={"axis": "el"})
        HTTP.post(srv.url + "/api/clear-faults", json={})
    page.problems.check()


DRAWN_LAST = {"/redoc": 'a[href="https://redocly.com/redoc/"]', "/docs": ".opblock"}


@pytest.mark.parametrize("path,shows", [("/redoc", "urc control API"), ("/docs", "urc control API")])
def test_api_docs_fetch_nothing_from_elsewhere(busy_urc, open_page, path, shows):
    """/redoc's bundle loaded Redocly's logo from cdn.redoc.ly; nothing may leave."""
    srv = busy_urc
    page = open_page(None)                                # (no dashboard first: straight to the docs)
    asked: list[str] = []
    page.on("request", lambda r: asked.append(r.url))
    page.goto(srv.url + path)
    # (the bundles are large: on a loaded machine drawing takes a while)
    expect(page.get_by_role("heading", name=re.compile(shows)).first).to_be_visible(timeout=90_000)
    # then what each draws last: ReDoc its side menu, whose foot holds Redocly's logo (its
    # request could come after the heading), Swagger UI its operations; the logo goes in
    # just after its link: two frames. (With fastapi-offline's own bundle served, the
    # request to cdn.redoc.ly has been seen by then, in each of three tries.)
    expect(page.locator(DRAWN_LAST[path]).first).to_be_attached(timeout=30_000)
    page.evaluate(TWO_FRAMES)
    foreign = [u for u in asked if not (u.startswith(srv.url) or u.startswith(("data:", "blob:")))]
    assert foreign == [], foreign
    assert any(u.endswith("/openapi.json") for u in asked), asked
    page.problems.check()


@pytest.mark.parametrize("profile", ["g4jnt", "sarcnet-mini", "bigras"])
def test_axe_finds_no_violation_on_each_calibration_card(tmp_path, open_page, profile):
    """Each seed machine's own calibration card (two-point pot, magnetometer, homing);
    with a state record that cannot be read, the BIG-RAS pulse counter's position is
    uncertain: its banner is shown too (the pot and the compass read absolutely)."""
    from urc_process import UrcProcess

    u = UrcProcess(tmp_path, profile=profile)
    u.state_dir.mkdir(parents=True)
    (u.state_dir / "state.json").write_text("{ not a state record")
    u.start(timeout_s=120)
    try:
        page = open_page(u.url + "/#calibration", bypass_csp=True)
        card = {"g4jnt": "#pot-card", "sarcnet-mini": "#mag-card", "bigras": "#home-card"}[profile]
        # (the card is shown with the sensor table, once the calibration page has loaded)
        expect(page.locator(card)).to_be_visible(timeout=5000)
        if profile == "bigras":
            expect(page.locator("#warn-banner")).to_be_visible(timeout=5000)
        page.evaluate(TWO_FRAMES)
        assert axe_violations(page) == []
        page.click('nav a[data-view="dashboard"]')
        expect(page.locator("#view-dashboard")).to_be_visible()
        page.evaluate(TWO_FRAMES)
        assert axe_violations(page) == []
        page.problems.check()
    finally:
        u.kill()     # (at once: the orderly stop is test_cli's subject, not the page's)


def axe_in(page, state: str, found: dict) -> None:
    page.evaluate(TWO_FRAMES)
    found[state] = axe_violations(page)


def test_axe_finds_no_violation_in_use(busy_urc, open_page):
    """Issue 36.7: axe on the page at rest missed what use shows. Moving with the events
    overflowing their list (a scrolling region a keyboard must reach), tracking, with a
    fault latched, and re-referencing (its confirmation is a modal dialog: named, the
    focus in it and kept there, STOP still taking it)."""
    srv = busy_urc
    page = open_page(srv.url + "/", 1366, 768, bypass_csp=True)
    page.wait_for_selector("#passes-body tr", timeout=5000)
    found: dict[str, list] = {}
    events = page.locator("#events")
    # events enough to overflow their list: faults latched and cleared (each is one or more)
    for _ in range(12):
        if len(HTTP.get(srv.url + "/api/status").json()["events"]) >= 16:
            break
        HTTP.post(srv.url + "/api/sim/fault", json={"axis": "el", "kind": "sensor_dead"})
        wait_until(lambda: HTTP.get(srv.url + "/api/status").json()["faults"], 5)
        HTTP.post(srv.url + "/api/sim/clear", json={"axis": "el"})
        HTTP.post(srv.url + "/api/clear-faults", json={})
        wait_until(lambda: not HTTP.get(srv.url + "/api/status").json()["faults"], 5)
    # moving
    assert HTTP.post(srv.url + "/api/goto", json={"az_deg": 20, "el_deg": 60}).status_code == 200
    expect(page.locator("#state-line .pill.on").first).to_have_text("moving", timeout=5000)
    page.wait_for_function("() => { const e = document.getElementById('events');"
                           " return e.scrollHeight > e.clientHeight; }", timeout=5000)
    axe_in(page, "moving", found)
    events.focus()                                # reachable by the keyboard, and scrolled by it
    page.keyboard.press("End")
    page.wait_for_function("() => document.getElementById('events').scrollTop > 0", timeout=3000)
    # tracking (the stand-in tracker's pass: the track banner and its notes)
    page.locator('#passes-body tr[data-norad="25544"] button.track-pass').click()
    expect(page.locator("#track-banner")).to_be_visible(timeout=5000)
    axe_in(page, "tracking", found)
    HTTP.post(srv.url + "/api/track/stop", json={})
    # a fault latched
    assert HTTP.post(srv.url + "/api/sim/fault", json={"axis": "el", "kind": "sensor_dead"}).status_code == 200
    try:
        expect(page.locator("#fault-banner")).to_be_visible(timeout=5000)
        axe_in(page, "fault", found)
    finally:
        HTTP.post(srv.url + "/api/sim/clear", json={"axis": "el"})
        HTTP.post(srv.url + "/api/clear-faults", json={})
    expect(page.locator("#fault-banner")).to_be_hidden(timeout=5000)
    # re-referencing: the confirmation open
    page.click('nav a[data-view="calibration"]')
    page.fill("#zero-az", "12")
    page.click("#zero-form button[type=submit]")
    dialog = page.locator("#zero-confirm")
    expect(dialog).to_be_visible()
    axe_in(page, "re-reference", found)
    assert found == {s: [] for s in found}, json.dumps(found, indent=1)
    expect(page.get_by_role("alertdialog", name="Re-reference the position?")).to_be_visible()
    focused = "() => document.activeElement && document.activeElement.id"
    assert page.evaluate(focused) == "zero-no"    # the safe answer first
    seen = set()
    for key in ["Tab"] * 3 + ["Shift+Tab"] * 3:
        page.keyboard.press(key)
        seen.add(page.evaluate(focused))
    assert seen == {"zero-yes", "zero-no"}, seen  # never out of the dialog
    page.locator("#zero-az").focus()              # a click elsewhere: the focus comes back
    assert page.evaluate(focused) in ("zero-yes", "zero-no")
    page.locator("#stop-btn").focus()             # STOP alone may take it
    assert page.evaluate(focused) == "stop-btn"
    page.click("#zero-no")
    expect(dialog).to_be_hidden()
    assert page.evaluate(focused) == "zero-submit"
    page.problems.check()
