"""Browser fixtures: Debian's chromium driven by Playwright (never a downloaded browser)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from fastapi.testclient import TestClient

from urc.api import create_api
from urc.assembly import settings_from_config

CHROMIUM = os.environ.get("URC_CHROMIUM", "/usr/bin/chromium")
CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                 "--disable-background-networking", "--disable-component-update", "--disable-sync"]
ARTIFACTS = Path(__file__).resolve().parents[2] / "test-artifacts"


# per module, not per session: Playwright's sync API keeps an event loop running on the
# main thread while it is open, and a later test's asyncio.run() in the same process (a
# pytest-xdist worker runs whole files in any order) would fail
@pytest.fixture(scope="module")
def browser():
    if not Path(CHROMIUM).exists():
        pytest.skip(f"browser tests need Debian's chromium at {CHROMIUM} (apt-get install chromium)")
    sync_api = pytest.importorskip("playwright.sync_api", reason="browser tests need the playwright package")
    with sync_api.sync_playwright() as p:
        b = p.chromium.launch(executable_path=CHROMIUM, headless=True, args=CHROMIUM_ARGS)
        yield b
        b.close()


@pytest.fixture
def artifacts() -> Path:
    ARTIFACTS.mkdir(exist_ok=True)
    return ARTIFACTS


def expected_refusal(msg) -> bool:
    """An API answer >= 400 the page handles (404 probe of /api/passes, 422 validation...);
    a failed load of the page's own files is still a problem."""
    url = (msg.location or {}).get("url", "")
    return msg.text.startswith("Failed to load resource: the server responded") and "/api/" in url


class PageProblems(list):
    """JavaScript exceptions, CSP violations and other console errors of a page."""

    def check(self) -> None:
        assert not self, "page reported problems:\n" + "\n".join(self)


def _new_page(browser, url: str | None, width: int, height: int, **context):
    """A new context's page at ``url``, its live feed running; ``url=None``: the page
    only, with its problems watched (the caller navigates it)."""
    ctx = browser.new_context(viewport={"width": width, "height": height}, **context)
    page = ctx.new_page()
    problems = PageProblems()
    page.on("pageerror", lambda e: problems.append(f"exception: {e}"))
    page.on("console", lambda m: problems.append(f"console: {m.text} ({m.location.get('url')})")
            if m.type == "error" and not expected_refusal(m) else None)
    page.problems = problems
    if url is not None:
        page.goto(url)
        page.wait_for_selector("#conn.live", timeout=15_000)
    return page


@pytest.fixture
def open_page(browser):
    pages = []

    def open_(url: str | None, width: int = 1400, height: int = 1100, **context):
        """A new context's page at ``url``, its live feed running; ``url=None``: the page
        only, with its problems watched (the caller navigates it)."""
        page = _new_page(browser, url, width, height, **context)
        pages.append(page)
        return page
    yield open_
    for page in pages:
        page.context.close()


class PageKeeper:
    """One dashboard page kept from a test to the next of the same module that asks for
    the same one (address without its view, size, context options): opening one took
    1.5-3 s on the loaded test machine. Closed after a failed test, and after a test
    whose next one in the module asks for no kept page (an open dashboard draws every
    live frame)."""

    def __init__(self, browser):
        self.browser = browser
        self.key: tuple | None = None
        self.page = None

    def get(self, url: str, width: int = 1400, height: int = 1100, **context):
        base, _, view = url.partition("#")
        key = (base, width, height, tuple(sorted(context.items())))
        if self.page is not None and key == self.key and not self.page.is_closed():
            self._hand_over(view or "dashboard")
            return self.page
        self.close()
        self.page, self.key = _new_page(self.browser, url, width, height, **context), key
        return self.page

    def _hand_over(self, view: str) -> None:
        """Back to how a newly opened page stands: its size, the view its address names, at
        the top, nothing focused, showing a live frame sent after this test began (the
        test's own reset included). Its problems are kept: one that came after the last
        test's check is reported by this test's."""
        page = self.page
        width, height = self.key[1], self.key[2]
        if page.viewport_size != {"width": width, "height": height}:   # (a test resized it)
            page.set_viewport_size({"width": width, "height": height})
        page.evaluate("""(view) => {
          if (document.activeElement) document.activeElement.blur();
          if (location.hash !== "#" + view) location.hash = view;
          window.scrollTo(0, 0);
        }""", view)
        page.locator(f"#view-{view}").wait_for()
        seen = int(page.locator("#conn").get_attribute("data-frames") or 0)
        # (two more: the first may have been on its way already)
        page.wait_for_function("(seen) => Number(document.getElementById('conn').dataset.frames) >= seen + 2"
                               " && document.getElementById('conn').classList.contains('live')",
                               arg=seen, timeout=15_000)

    def close(self) -> None:
        if self.page is not None:
            self.page.context.close()
        self.page = self.key = None


@pytest.fixture(scope="module")
def page_keeper(browser):
    keeper = PageKeeper(browser)
    yield keeper
    keeper.close()


@pytest.fixture
def shared_page(page_keeper):
    """Like ``open_page`` (an address is required) for a test that does not test how
    the page loads: the page the module's test before used when it asked for the same
    one, handed over as a new one stands (:class:`PageKeeper`), or a new one."""
    return page_keeper.get


_FAILED = pytest.StashKey[bool]()


@pytest.hookimpl(wrapper=True)
def pytest_runtest_makereport(item, call):
    report = yield
    if report.failed:
        item.stash[_FAILED] = True
    return report


_RELEASE = pytest.StashKey[dict]()


def release_when_unused(request, close) -> None:
    """Call ``close`` (a module fixture's urc's ``kill``) after the teardown of the last
    test of the module that asks for the fixture, not at the end of the module: an idle
    ``urc run`` costs ~0.1 CPU-s a second, and some are done with long before their
    module. The fixture's own teardown still ends it (``close`` must allow that)."""
    request.node.stash.setdefault(_RELEASE, {})[request.fixturename] = close


@pytest.hookimpl(wrapper=True)
def pytest_runtest_teardown(item, nextitem):
    """Close the kept page after a failed test (the next starts from a new one), and
    unless the next test of this module asks for one (an open dashboard draws every
    live frame: ~0.06-0.25 CPU-s a second kept open through another test); after the
    teardown, end the module's urcs no later test asks for (:func:`release_when_unused`)."""
    keeper = getattr(item, "funcargs", {}).get("page_keeper")
    if keeper is not None and keeper.page is not None and (
            item.stash.get(_FAILED, False) or nextitem is None or nextitem.module is not item.module
            or "shared_page" not in getattr(nextitem, "fixturenames", ())):
        keeper.close()
    try:
        return (yield)
    finally:
        module = item.getparent(pytest.Module)
        release = module.stash.get(_RELEASE, {}) if module is not None else {}
        for name in [n for n in release if n in item.fixturenames and not _later_in_module_use(item, n)]:
            release.pop(name)()


def _later_in_module_use(item, fixture: str) -> bool:
    items = item.session.items
    try:
        i = items.index(item)
    except ValueError:
        return False
    return any(later.module is item.module and fixture in getattr(later, "fixturenames", ())
               for later in items[i + 1:])


class LoopbackClient(TestClient):
    """A TestClient that asks under a loopback name, as a browser on the station does
    (a loopback API refuses others: DNS rebinding); TestClient's own is "testserver",
    and its WebSockets always use that unless told."""

    def __init__(self, app):
        super().__init__(app, base_url="http://127.0.0.1:8080")

    def websocket_connect(self, url, subprotocols=None, **kwargs):
        kwargs["headers"] = {"host": "127.0.0.1:8080", **(kwargs.get("headers") or {})}
        return super().websocket_connect(url, subprotocols, **kwargs)


@pytest.fixture
def make_client(bench, tmp_path):
    """The control API app (in process, virtual clock) behind a TestClient."""
    clients = []

    def make(profile="berkeley", tracker=None, config_path=None, **config):
        b = bench(profile, **config)
        app = create_api(b.rot, b.cfg, settings_of=settings_from_config, config_path=config_path, tracker=tracker)
        c = LoopbackClient(app)
        c.__enter__()
        clients.append(c)
        c.bench = b
        return c
    yield make
    for c in clients:
        c.__exit__(None, None, None)
