"""The dashboard on a phone and everywhere (issue 22), in Debian's chromium against a real
``urc run``: STOP on screen in every view at every scroll position and width, banners
whole and foldable, the first phone screen saying where the antenna points, what it does
and why, the position marked unconfirmed while it is, Space and Escape, UTC times."""

from __future__ import annotations

import re
import time
from datetime import datetime

import pytest
from playwright.sync_api import TimeoutError as PlaywrightTimeout
from playwright.sync_api import expect
from urc_process import HTTP, UrcProcess, free_port

from .conftest import release_when_unused
from .fake_tracker import KEYHOLE_NOTE, FakeTracker
from .test_browser import TWO_FRAMES, InProcessUrc, reset, standing

TOKEN = "layout-token"
WIDTHS = {320: (320, 640), 390: (390, 844), 1366: (1366, 768)}
VIEWS = ("dashboard", "settings", "calibration")
ZONE = ('[[keepout]]\nname = "a tree with a rather long name by the mast"\naz_min_deg = 80.0\n'
        'az_max_deg = 100.0\nel_min_deg = 0.0\nel_max_deg = 30.0\n')
AUTH = {"Authorization": f"Bearer {TOKEN}"}


@pytest.fixture(scope="module")
def remote_urc(tmp_path_factory, request):
    """A urc listening beyond loopback (the token field shows: the tallest header), with
    a keep-out zone and two [[serve]] entries (the settings page's widest rows)."""
    serve = [{"protocol": "rotctld", "tcp": f"127.0.0.1:{free_port()}"},
             {"protocol": "gs232b", "tcp": f"127.0.0.1:{free_port()}"}]
    u = UrcProcess(tmp_path_factory.mktemp("layout"), profile="berkeley", serve=serve,
                   extra=f'host = "0.0.0.0"\ntoken = "{TOKEN}"\n{ZONE}').start(timeout_s=120)
    release_when_unused(request, u.kill)
    yield u
    u.kill()     # (at once: the page's tests do not test urc's orderly stop, test_cli does)


@pytest.fixture(scope="module")
def plain_urc(tmp_path_factory, request):
    """A urc on loopback with nothing configured (each test that uses it resets it:
    stopped, no fault latched)."""
    u = UrcProcess(tmp_path_factory.mktemp("layout-plain"), profile="berkeley").start(timeout_s=120)
    release_when_unused(request, u.kill)
    yield u
    u.kill()


def in_viewport(page, selector: str) -> bool:
    box = page.locator(selector).bounding_box()
    vw, vh = page.viewport_size["width"], page.viewport_size["height"]
    return box is not None and box["x"] >= 0 and box["y"] >= 0 and \
        box["x"] + box["width"] <= vw + 0.5 and box["y"] + box["height"] <= vh + 0.5


#: every visible element whose box reaches past the screen's right edge (those inside an
#: element that scrolls or clips sideways are that element's business)
STICKING_OUT = """() => {
  const out = [], vw = document.documentElement.clientWidth;
  const clipped = (el) => {
    for (let p = el.parentElement; p && p !== document.body && p !== document.documentElement; p = p.parentElement) {
      if (getComputedStyle(p).overflowX !== "visible") return true;
    }
    return false;
  };
  for (const el of document.body.querySelectorAll("*")) {
    const r = el.getBoundingClientRect();
    if (r.width === 0 || r.height === 0 || clipped(el)) continue;
    if (r.right > vw + 0.5 || r.left < -0.5) out.push(`${el.tagName}#${el.id}.${el.className} ${r.left}..${r.right}`);
  }
  return out;
}"""


#: scroll by script, wait two animation frames, and say how far the page scrolled sideways
SCROLL_TO = """([x, y]) => new Promise((done) => {
  window.scrollTo(x, y);
  requestAnimationFrame(() => requestAnimationFrame(() => done(window.scrollX)));
})"""


def show_view(page, view: str) -> None:
    """Switch to ``view`` and wait until it is shown whole: what it loads on the way in
    (the settings form, the calibration page's sensor table) arrived and laid out."""
    page.click(f'nav a[data-view="{view}"]')
    expect(page.locator(f"#view-{view}")).to_be_visible()
    if view == "settings":
        expect(page.locator(".zone-row")).to_have_count(1)
        expect(page.locator(".serve-row")).to_have_count(2)
    elif view == "calibration":
        expect(page.locator("#cal-sensors tr").first).to_be_attached()
    page.evaluate(TWO_FRAMES)


def scroll_everywhere_and_check(page, what: str) -> None:
    """Down to the end, up, sideways both ways: STOP in view after each."""
    for x, y in ((0, 100_000), (0, 0), (100_000, 0), (0, 0), (100_000, 100_000), (0, 100_000)):
        # (a script's scrollTo is instant; two frames later every scroll handler has run
        # and the page is drawn there: a condition, where a fixed 50 ms wait was a guess)
        scroll_x = page.evaluate(SCROLL_TO, [x, y])
        assert scroll_x == 0, f"{what}: the page scrolled sideways"
        assert in_viewport(page, "#stop-btn"), f"{what}: STOP off screen after scrolling to {x},{y}"
    # a finger swipe, not only a script: down from the top, sideways, then back up
    # (down first: a sideways wheel first latched the gesture to a scroller that cannot
    # scroll down, and the page never moved)
    page.evaluate(SCROLL_TO, [0, 0])
    page.mouse.move(page.viewport_size["width"] / 2, page.viewport_size["height"] * 0.7)
    page.mouse.wheel(0, 3000)
    # (a view no taller than the screen has nothing to scroll: the calibration view)
    swiped_to(page, "window.scrollY > 0 || document.documentElement.scrollHeight <= window.innerHeight", what)
    assert in_viewport(page, "#stop-btn"), what
    page.mouse.wheel(800, 0)
    page.wait_for_timeout(100)
    assert page.evaluate("() => window.scrollX") == 0 and in_viewport(page, "#stop-btn"), what
    page.mouse.wheel(0, -6000)
    swiped_to(page, "window.scrollY == 0", what)
    assert in_viewport(page, "#stop-btn"), what


def swiped_to(page, where: str, what: str) -> None:
    """Wait until a swipe (a wheel, which scrolls after it returns) has taken the page
    ``where`` (a JavaScript condition): a swipe that scrolled nothing checks nothing."""
    try:
        page.wait_for_function(f"() => {where}", timeout=5000)
    except PlaywrightTimeout:
        at = page.evaluate("() => [window.scrollY, document.documentElement.scrollHeight, window.innerHeight]")
        raise AssertionError(f"{what}: a swipe did not take the page to {where} (scrollY, height, "
                             f"screen: {at})") from None
    page.evaluate(TWO_FRAMES)   # (the scroll handlers have run: the page drawn there)


@pytest.fixture(scope="module", params=list(WIDTHS), ids=[f"{w}px" for w in WIDTHS])
def width(request):
    """The screen widths of the two tests below, a module's parameter: pytest runs both
    at one width before the next, and the second is handed the first's page."""
    return request.param


def test_stop_is_on_screen_in_every_view_at_every_scroll_position(remote_urc, shared_page, artifacts, width):
    u = remote_urc
    size = WIDTHS[width]
    page = shared_page(u.url + "/", *size, has_touch=width < 1000, extra_http_headers=AUTH)  # (reads: issue 36.8)
    expect(page.locator("#token-form")).to_be_visible(timeout=5000)
    for view in VIEWS:
        show_view(page, view)
        assert page.evaluate(STICKING_OUT) == [], f"{view} at {width} px"
        assert page.evaluate("() => document.documentElement.scrollWidth") <= size[0], view
        scroll_everywhere_and_check(page, f"{view} at {width} px")
        if view == "settings":
            # the last [[serve]] entry's "remove": reachable without a sideways swipe
            remove = page.locator(".serve-row").nth(1).locator("button", has_text="remove")
            remove.scroll_into_view_if_needed()
            assert in_viewport(page, ".serve-row:nth-child(2) button") and in_viewport(page, "#stop-btn")
            page.screenshot(path=str(artifacts / f"settings-{width}.png"))
    page.problems.check()


def test_a_fault_banner_is_whole_foldable_and_leaves_stop_on_screen(remote_urc, shared_page, artifacts, width):
    """The banner says the whole reason (wrapped, never cut), folds to its title and
    opens again; with it open STOP stays on screen in every view and scroll position,
    and all banners together take at most a third of the screen."""
    u = remote_urc
    size = WIDTHS[width]
    page = shared_page(u.url + "/", *size, has_touch=width < 1000, extra_http_headers=AUTH)  # (reads: issue 36.8)
    HTTP.post(u.url + "/api/stop", json={}, headers=AUTH)
    assert HTTP.post(u.url + "/api/sim/fault", json={"axis": "el", "kind": "sensor_dead"}, headers=AUTH).status_code == 200
    try:
        reason = u.wait(lambda s: bool(s["faults"]), 10)["faults"][0]["reason"]
        text = page.locator("#fault-text")
        expect(text).to_contain_text(reason, timeout=5000)
        # whole: not cut by an ellipsis, nothing hidden to the right, several lines on a phone
        assert page.evaluate("() => { const e = document.getElementById('fault-text'); "
                             "return e.scrollWidth <= e.clientWidth + 1 || getComputedStyle(e).display === 'inline'; }")
        assert page.evaluate("() => getComputedStyle(document.getElementById('fault-text')).textOverflow") != "ellipsis"
        banners = page.locator("#banners").bounding_box()
        assert banners["height"] <= size[1] / 3 + 1
        toggle = page.locator("#fault-banner .banner-toggle")
        expect(toggle).to_have_attribute("aria-expanded", "true")
        page.screenshot(path=str(artifacts / f"fault-open-{width}.png"))
        toggle.click()                                     # fold
        expect(page.locator("#fault-body")).to_be_hidden()
        expect(toggle).to_have_attribute("aria-expanded", "false")
        folded = page.locator("#banners").bounding_box()["height"]
        assert folded < banners["height"] or width == 1366
        expect(page.locator("#clear-fault-btn")).to_be_visible()   # still one tap away
        toggle.click()                                     # and open again
        expect(page.locator("#fault-body")).to_be_visible()
        for view in VIEWS:
            show_view(page, view)
            assert page.evaluate(STICKING_OUT) == [], f"{view} at {width} px"
            scroll_everywhere_and_check(page, f"{view} at {width} px with the fault banner open")
            assert in_viewport(page, "#fault-banner .banner-head")
        page.screenshot(path=str(artifacts / f"fault-open-scrolled-{width}.png"))
    finally:
        reset(u, TOKEN)
    expect(page.locator("#fault-banner")).to_be_hidden(timeout=5000)
    page.problems.check()


def test_tracking_banner_whole_foldable_and_reopened_by_news(tmp_path, open_page, artifacts):
    """The plan's notes (a keyhole...) in full on a phone, folded on request, opened again
    when what they say changes."""
    trk = FakeTracker()
    with InProcessUrc(tmp_path / "state", trk) as srv:
        page = open_page(srv.url + "/", 390, 844, has_touch=True)
        page.wait_for_selector("#passes-body tr", timeout=5000)
        page.locator('#passes-body tr[data-norad="25544"] button.track-pass').click()
        banner = page.locator("#track-banner")
        expect(banner).to_contain_text(KEYHOLE_NOTE)       # every word of it
        li = page.locator("#track-warnings li").first
        assert li.bounding_box()["height"] > 40             # wrapped over lines, not cut to one
        assert page.evaluate("() => getComputedStyle(document.querySelector('#track-warnings li')).textOverflow") != "ellipsis"
        assert page.locator("#banners").bounding_box()["height"] <= 844 / 3 + 1
        page.screenshot(path=str(artifacts / "tracking-banner-phone.png"))
        page.click("#track-banner .banner-toggle")
        expect(page.locator("#track-warnings")).to_be_hidden()
        expect(page.locator("#track-banner-title")).to_be_visible()
        page.mouse.wheel(0, 3000)
        swiped_to(page, "window.scrollY > 0", "the folded banner")
        assert in_viewport(page, "#stop-btn") and in_viewport(page, "#track-banner-title")
        trk.active = {**trk.active, "plan": {**trk.active["plan"],
                                             "notes": [KEYHOLE_NOTE, "the pass crosses the keep-out zone 'mast'"]}}
        expect(page.locator("#track-warnings")).to_be_visible(timeout=5000)   # news opens it
        expect(page.locator("#track-count")).to_have_text("2 notes")
        page.problems.check()


# --------------------------------------------------------------- the first screen on a phone
def test_the_first_phone_screen_says_where_what_and_why(plain_urc, shared_page, artifacts):
    u = plain_urc
    # (the first test of the module to ask for this page: a new one, at the top)
    page = shared_page(u.url + "/", 390, 844, has_touch=True, is_mobile=True)
    reset(u)
    # (from park a move of ~3.9 s at 40 deg/s: the page says what it does within a frame
    # or two, ~0.3 s even on a loaded machine)
    assert u.post("/api/goto", {"az_deg": 100.0, "el_deg": 35.0}).status_code == 200
    expect(page.locator("#why-line")).to_contain_text("Going to az 100.0°, el 35.0°", timeout=5000)
    expect(page.locator("#state-line")).to_contain_text("moving")
    s = u.wait(lambda s: standing(s) and abs(s["az_deg"] - 100) < 0.5, 30)
    expect(page.locator("#why-line")).to_have_text("Holding at az 100.0°, el 35.0°.", timeout=5000)
    expect(page.locator("#state-line")).to_contain_text("standing")
    az_shown = float(re.search(r"az (\d+\.\d+)", page.locator("#now-az").text_content()).group(1))
    assert az_shown == pytest.approx(s["az_deg"], abs=0.3)
    assert page.evaluate("() => window.scrollY") == 0
    for sel in ("#now-az", "#now-el", "#state-line", "#why-line", "#ro-modeaz", "#ro-modeel", "#stop-btn"):
        assert in_viewport(page, sel), f"{sel} is not on the first screen"
    assert page.locator("#now-badge").is_hidden()
    page.screenshot(path=str(artifacts / "phone-first-screen.png"))
    page.problems.check()


# --------------------------------------------------------------- unconfirmed position
def test_the_position_is_unconfirmed_while_the_sensor_is_unreadable(plain_urc, shared_page, artifacts):
    """A dead elevation sensor: its numbers are marked unconfirmed (the azimuth's are
    not), the banner says the sensor is still unreadable (clearing cannot help); repaired,
    it says clearing will work; cleared, all is confirmed again."""
    u = plain_urc
    # (the phone page the test before used: this one does not test how the page loads)
    page = shared_page(u.url + "/", 390, 844, has_touch=True, is_mobile=True)
    reset(u)
    assert page.locator("#now-el").get_attribute("data-confirmed") == "true"
    assert u.post("/api/sim/fault", {"axis": "el", "kind": "sensor_dead"}).status_code == 200
    expect(page.locator("#now-el")).to_have_attribute("data-confirmed", "false", timeout=5000)
    s = u.status()
    assert s["el"]["sensor_ok"] is False and s["az"]["sensor_ok"] is True
    for sel in ("#ro-el", "#ro-mel"):
        assert page.locator(sel).get_attribute("data-confirmed") == "false"
    for sel in ("#now-az", "#ro-az", "#ro-maz"):
        assert page.locator(sel).get_attribute("data-confirmed") == "true"
    expect(page.locator("#now-badge")).to_be_visible()
    expect(page.locator("#confirm-line")).to_contain_text("el unreadable now")
    expect(page.locator("#fault-now")).to_contain_text("el still unreadable")
    expect(page.locator("#fault-now")).to_contain_text("clearing cannot help")
    # read out to a screen reader once: the live region holds no changing age
    announced = page.locator("#fault-announce").text_content()
    assert "el: position sensor unreadable" in announced and "ago" not in announced
    expect(page.locator("#fault-text")).to_contain_text(" s ago)")
    assert page.locator("#fault-banner").get_attribute("role") is None
    assert in_viewport(page, "#now-badge")
    page.screenshot(path=str(artifacts / "position-unconfirmed-phone.png"))
    u.post("/api/sim/clear", {"axis": "el"})            # the wire is mended
    expect(page.locator("#fault-now")).to_contain_text("el reads again: Clear fault re-arms it", timeout=5000)
    expect(page.locator("#now-el")).to_have_attribute("data-confirmed", "true")
    expect(page.locator("#fault-banner")).to_be_visible()   # still latched until cleared
    page.click("#clear-fault-btn")
    expect(page.locator("#fault-banner")).to_be_hidden(timeout=5000)
    expect(page.locator("#now-badge")).to_be_hidden()
    page.problems.check()


# --------------------------------------------------------------- axis names on a phone
#: every visible "az" or "el" (a whole word: a label, a column head, a readout, the
#: calibration page's axis cell) laid over more than one line box, i.e. broken inside
#: the word; and the position readouts that take more than one line
AXIS_NAMES_BROKEN = """() => {
  const out = [];
  const shown = (el) => el.getClientRects().length > 0 && !el.closest(".sr-only, svg");
  const walker = document.createTreeWalker(document.body, NodeFilter.SHOW_TEXT);
  for (let n = walker.nextNode(); n; n = walker.nextNode()) {
    if (!n.parentElement || !shown(n.parentElement)) continue;
    for (const m of n.nodeValue.matchAll(/\\b(az|el)\\b/g)) {
      const word = document.createRange();
      word.setStart(n, m.index);
      word.setEnd(n, m.index + 2);
      const lines = new Set([...word.getClientRects()].map((r) => Math.round(r.top))).size;
      if (lines > 1) out.push(`"${m[0]}" on ${lines} lines in ${n.parentElement.tagName} "${n.nodeValue.trim().slice(0, 40)}"`);
    }
  }
  for (const id of ["now-az", "ro-az", "ro-taz", "ro-maz", "ro-raz", "ro-modeaz"]) {
    const el = document.getElementById(id);
    if (!el || !shown(el)) continue;
    const text = document.createRange();
    text.selectNodeContents(el);
    const lines = new Set([...text.getClientRects()].map((r) => Math.round(r.top))).size;
    if (lines > 1) out.push(`#${id} "${el.textContent}" on ${lines} lines`);
  }
  return out;
}"""
PHONE_WIDTHS = (360, 375, 390, 414)


def test_axis_names_and_azimuth_readouts_never_break_on_a_phone(plain_urc, shared_page, artifacts):
    """Issue 36.9: "az" wrapped at 390 px. It was the calibration page's sensor table: its
    cells may break anywhere (a long device path must not widen the page), and the long
    constants beside it squeezed the axis column until "az" stood as "a" over "z" from 360
    to 414 px ("el", narrower, fitted). Every view at phone widths, standing and with the
    azimuth sensor dead (its readouts marked unconfirmed, the fault banner open)."""
    u = plain_urc
    page = shared_page(u.url + "/", 390, 844, has_touch=True, is_mobile=True)
    reset(u)
    try:
        for state in ("standing", "az sensor dead"):
            if state == "az sensor dead":
                assert u.post("/api/sim/fault", {"axis": "az", "kind": "sensor_dead"}).status_code == 200
                page.evaluate("() => { location.hash = 'dashboard'; }")
                expect(page.locator("#now-az")).to_have_attribute("data-confirmed", "false", timeout=5000)
            for width in PHONE_WIDTHS:
                page.set_viewport_size({"width": width, "height": 844})
                for view in VIEWS:
                    page.click(f'nav a[data-view="{view}"]')
                    expect(page.locator(f"#view-{view}")).to_be_visible()
                    if view == "calibration":
                        expect(page.locator("#cal-sensors tr").first).to_be_attached()
                    elif view == "settings":
                        expect(page.locator("#settings-form fieldset").first).to_be_attached()
                    page.evaluate(TWO_FRAMES)
                    assert page.evaluate(AXIS_NAMES_BROKEN) == [], f"{view} at {width} px, {state}"
        page.locator("#cal-sensors").screenshot(path=str(artifacts / "calibration-sensors-phone.png"))
    finally:
        u.post("/api/sim/clear", {"axis": "az"})
        reset(u)
    page.problems.check()


def test_a_position_not_referenced_is_unconfirmed_on_every_axis(tmp_path, open_page):
    u = UrcProcess(tmp_path, profile="tartu-urc")
    u.state_dir.mkdir(parents=True)
    (u.state_dir / "state.json").write_text("{ this is not a state file")
    u.start(timeout_s=120)
    try:
        page = open_page(u.url + "/")
        expect(page.locator("#now-badge")).to_be_visible(timeout=5000)
        for sel in ("#now-az", "#now-el", "#ro-az", "#ro-el"):
            assert page.locator(sel).get_attribute("data-confirmed") == "false", sel
        expect(page.locator("#now-az")).to_contain_text("±")
        page.problems.check()
    finally:
        u.kill()


# --------------------------------------------------------------- keys
def test_enter_presses_a_focused_button_and_space_stops_even_there(tmp_path, open_page):
    """After "Go to" the focus stays on that button: a Space meant as a stop stops (and
    does not send the move again); Enter presses the button. The page says so."""
    # (the Tartu rotator turns 6 deg/s: a 170 deg move lasts long enough to be stopped)
    u = UrcProcess(tmp_path, profile="tartu-urc").start(timeout_s=120)
    try:
        page = open_page(u.url + "/")
        reset(u)
        expect(page.locator("#keys-note")).to_contain_text("also while a button has the focus")
        az0 = u.status()["az_deg"]
        goal = (az0 + 170) % 360
        page.fill("#goto-az", f"{goal:.1f}")
        page.fill("#goto-el", "50")
        button = page.locator("#goto-form button[type=submit]")
        button.focus()
        page.keyboard.press("Enter")
        u.wait(lambda s: s["target_az_deg"] is not None, 20)
        assert page.evaluate("() => document.activeElement.textContent") == "Go to"
        page.keyboard.press("Space")
        s = u.wait(standing, 30)
        assert s["target_az_deg"] is None and abs((s["az_deg"] - goal + 180) % 360 - 180) > 20
        time.sleep(0.5)
        assert u.status()["target_az_deg"] is None and not u.status()["moving"]   # no goto sent again
        # Escape stops from anywhere, a text field included
        page.keyboard.press("Enter")                        # (the focus is still on Go to)
        u.wait(lambda s: s["target_az_deg"] is not None, 20)
        page.focus("#goto-az")
        page.keyboard.press("Escape")
        assert u.wait(standing, 30)["target_az_deg"] is None
        page.problems.check()
    finally:
        u.kill()


# --------------------------------------------------------------- times
def test_pass_and_plan_times_are_24_hour_utc(tmp_path, open_page):
    """In a browser set to Tallinn and American English (12-hour clock), the pass list
    and the plan show 24-hour UTC times."""
    trk = FakeTracker()
    with InProcessUrc(tmp_path / "state", trk) as srv:
        page = open_page(srv.url + "/", timezone_id="Europe/Tallinn", locale="en-US")
        page.wait_for_selector("#passes-body tr", timeout=5000)
        assert "times in UTC" in page.locator("#passes-note").text_content()
        for p in trk.pass_list:
            aos, los = datetime.fromisoformat(p["aos"]), datetime.fromisoformat(p["los"])
            cells = page.locator(f'#passes-body tr[data-norad="{p["norad"]}"] td')
            assert cells.nth(1).text_content() == f"{aos.day} {aos:%b} {aos:%H:%M}"
            assert cells.nth(2).text_content() == f"{los:%H:%M}"
        assert not re.search(r"\b[AP]M\b", page.locator("#passes-body").text_content())
        page.locator('#passes-body tr[data-norad="25544"] button.track-pass').click()
        aos = datetime.fromisoformat(trk.pass_list[0]["aos"])
        expect(page.locator("#tracking-line")).to_contain_text(f"AOS {aos:%H:%M:%S} UTC")
        page.problems.check()
