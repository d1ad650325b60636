"""The dashboard of a urc bridged to a controller (issue 22): one ``urc run`` on the
simulator is the controller (GS-232B on a pseudo-terminal), a second drives it with the
bridge backend and serves the page. The controller's process dies and comes back: while
it is gone the position is shown unconfirmed and the banner says clearing cannot help;
once it answers again the link's fault clears itself and the position is confirmed."""

from __future__ import annotations

import os
import re

from playwright.sync_api import expect
from urc_process import UrcProcess

PROFILE = "berkeley"
#: a generous bound for a urc to start listening (the machine may be loaded)
START_S = 120.0


def test_link_lost_then_back_the_page_says_clearing_cannot_help_then_confirms_by_itself(tmp_path, open_page, artifacts):
    up_dir, down_dir = tmp_path / "up", tmp_path / "down"
    up_dir.mkdir()
    down_dir.mkdir()
    pty_path = str(up_dir / "ctl")
    up = UrcProcess(up_dir, profile=PROFILE, serve=[{"protocol": "gs232b", "pty": pty_path}]).start(START_S)
    down = UrcProcess(down_dir, profile=PROFILE, serve=[],
                      extra=f'[hardware]\nbackend = "bridge"\n[hardware.bridge]\nprotocol = "gs232b"\n'
                            f'serial = "{pty_path}"\n').start(START_S)
    try:
        page = open_page(down.url + "/", 390, 844, has_touch=True)
        expect(page.locator("#now-az")).to_have_attribute("data-confirmed", "true", timeout=10_000)
        expect(page.locator("#now-badge")).to_be_hidden()

        up.proc.kill()                                      # the controller is gone (its pty closes)
        up.proc.wait()
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

        os.unlink(pty_path)         # (killed, it could not remove its link: urc keeps others' files)
        up.start(START_S)                                   # back: the bridge reopens the pty
        # the link's fault clears itself once the controller answers again (issue 21),
        # and the position is confirmed again without anyone clearing anything
        expect(page.locator("#now-az")).to_have_attribute("data-confirmed", "true", timeout=40_000)
        expect(page.locator("#fault-banner")).to_be_hidden(timeout=40_000)
        expect(page.locator("#now-badge")).to_be_hidden()
        page.screenshot(path=str(artifacts / "bridge-link-back-phone.png"))
        assert down.post("/api/goto", {"az_deg": 40.0, "el_deg": 20.0}).status_code == 200
        down.wait(lambda s: abs(s["az_deg"] - 40.0) < 1.5 and not s["moving"], 30)
        page.problems.check()
    finally:
        down.stop()
        up.stop()
