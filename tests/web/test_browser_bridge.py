"""The dashboard of a urc bridged to a controller (issue 22): the controller is a
GS-232B on a pseudo-terminal (tests/fake_gs232b.py), and ``urc run`` drives it with the
bridge backend and serves the page. The controller goes away (its pty hangs up, as when
its process dies) and comes back: while it is gone the position is shown unconfirmed and
the banner says clearing cannot help; once it answers again the link's fault clears
itself and the position is confirmed."""

from __future__ import annotations

import os
import re

from fake_gs232b import FakeGs232b
from playwright.sync_api import expect
from urc_process import UrcProcess

PROFILE = "berkeley"
#: a generous bound for a urc to start listening (the machine may be loaded)
START_S = 120.0


def test_link_lost_then_back_the_page_says_clearing_cannot_help_then_confirms_by_itself(tmp_path, open_page, artifacts):
    down_dir = tmp_path / "down"
    down_dir.mkdir()
    link = str(tmp_path / "ctl")
    ctl = FakeGs232b(link)
    down = UrcProcess(down_dir, profile=PROFILE, serve=[],
                      extra=f'[hardware]\nbackend = "bridge"\n[hardware.bridge]\nprotocol = "gs232b"\n'
                            f'serial = "{link}"\n').start(START_S)
    try:
        page = open_page(down.url + "/", 390, 844, has_touch=True)
        expect(page.locator("#now-az")).to_have_attribute("data-confirmed", "true", timeout=10_000)
        expect(page.locator("#now-badge")).to_be_hidden()

        ctl.vanish()                                        # the controller is gone (its pty closes)
        expect(page.locator("#fault-banner")).to_be_visible(timeout=15_000)
        expect(page.locator("#fault-text")).to_contain_text("link lost")
        expect(page.locator("#fault-text")).to_contain_text(re.compile(r"\(\d+ s ago\)"))
        for sel in ("#now-az", "#now-el", "#ro-az", "#ro-el"):
            expect(page.locator(sel)).to_have_attribute("data-confirmed", "false")
        expect(page.locator("#now-badge")).to_be_visible()
        expect(page.locator("#fault-now")).to_contain_text("az and el still unreadable (bridge gs232b: link lost")
        expect(page.locator("#fault-now")).to_contain_text("clearing cannot help")
        s = down.status()
        assert s["az"]["sensor_ok"] is False and "link lost" in s["az"]["sensor_error"]
        page.screenshot(path=str(artifacts / "bridge-link-lost-phone.png"))

        os.unlink(link)             # (gone, it could not remove its link: urc keeps others' files)
        ctl = FakeGs232b(link)                              # back: the bridge reopens the pty
        # the link's fault clears itself once the controller answers again (issue 21),
        # and the position is confirmed again without anyone clearing anything
        expect(page.locator("#now-az")).to_have_attribute("data-confirmed", "true", timeout=40_000)
        expect(page.locator("#fault-banner")).to_be_hidden(timeout=40_000)
        expect(page.locator("#now-badge")).to_be_hidden()
        page.screenshot(path=str(artifacts / "bridge-link-back-phone.png"))
        assert down.post("/api/goto", {"az_deg": 20.0, "el_deg": 10.0}).status_code == 200
        down.wait(lambda s: abs(s["az_deg"] - 20.0) < 1.5 and not s["moving"], 30)
        page.problems.check()
    finally:
        down.kill()     # (done with it: nothing is asserted on an orderly stop)
        ctl.close()
