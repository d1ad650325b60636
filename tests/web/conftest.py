"""Browser fixtures: Debian's chromium driven by Playwright (never a downloaded browser)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from fastapi.testclient import TestClient

from urc.api import create_api

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


@pytest.fixture
def open_page(browser):
    pages = []

    def open_(url: str | None, width: int = 1400, height: int = 1100, **context):
        """A new context's page at ``url``, its live feed running; ``url=None``: the page
        only, with its problems watched (the caller navigates it)."""
        ctx = browser.new_context(viewport={"width": width, "height": height}, **context)
        page = ctx.new_page()
        problems = PageProblems()
        page.on("pageerror", lambda e: problems.append(f"exception: {e}"))
        page.on("console", lambda m: problems.append(f"console: {m.text} ({m.location.get('url')})")
                if m.type == "error" and not expected_refusal(m) else None)
        page.problems = problems
        pages.append((ctx, page))
        if url is not None:
            page.goto(url)
            page.wait_for_selector("#conn.live", timeout=15_000)
        return page
    yield open_
    for ctx, _page in pages:
        ctx.close()


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
        app = create_api(b.rot, b.cfg, config_path=config_path, tracker=tracker)
        c = LoopbackClient(app)
        c.__enter__()
        clients.append(c)
        c.bench = b
        return c
    yield make
    for c in clients:
        c.__exit__(None, None, None)
