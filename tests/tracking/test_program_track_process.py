"""Program track in a real `urc run` (issue 33): a pass survives a paused I/O process,
and the death of `urc run` (the next one takes the control process over).

The tracker used to send the pre-position move once; a 1.5 s SIGSTOP of `urc run` during
it stopped the axes, and the antenna stood for 49-59 s into the pass ("prepositioning",
no target, no fault). Now the whole pass is uploaded to the control process, which flies
the pre-position, the pass and the end by its own clock.
"""

from __future__ import annotations

import os
import signal
import subprocess
import time

import httpx
from urc_process import URC, UrcProcess, process_gone, wait_until

from urc.angles import great_circle_deg
from urc.testing.synthetic import STATION_TOML, satellite_passing_soon
from urc.tracking.propagate import look_angles
from urc.tracking.station import Station

TARTU = Station(58.378, 26.729, 70.0, "Tartu")
NORAD = 99007


def _pass_soon(tmp_path):
    """A pass whose AOS azimuth is far from the start (az 0: a long pre-position slew), and
    a g5500 urc with it in its catalog (not started)."""
    text, es, p = satellite_passing_soon(tmp_path, TARTU, (40.0, 70.0), 20.0, norad=NORAD,
                                         accept=lambda p: 120.0 <= p.aos_az_deg <= 240.0)
    tle = tmp_path / "sat.tle"
    tle.write_text(text)
    u = UrcProcess(tmp_path, profile="g5500", extra=STATION_TOML + f"[tracking]\ncatalog_dir = '{tmp_path / 'cat'}'\n")
    subprocess.run(URC + ["tle", "import", str(tle), "--config", str(u.config)], check=True, capture_output=True)
    return es, p, u


def _error_deg(u, es, t_unix_s: float | None = None) -> tuple[float, dict]:
    t0 = time.time()
    s = u.status()
    t1 = time.time()
    look = look_angles(es, TARTU, [0.5 * (t0 + t1)])
    return float(great_circle_deg(s["az_deg"], s["el_deg"], look.az_deg[0], look.el_deg[0])), s


def test_a_pass_survives_a_paused_io_process_during_the_pre_position_move(tmp_path):
    es, p, u = _pass_soon(tmp_path)
    u.start()
    try:
        r = httpx.post(u.url + "/api/track/pass", json={"norad": NORAD, "aos": p.aos.isoformat()}, timeout=60)
        assert r.status_code == 200, r.text
        s = u.wait(lambda s: (s.get("tracking") or {}).get("state") == "prepositioning" and s["moving"], 60)
        assert s["program"] is not None and s["program"]["state"] == "prepositioning", s["program"]
        u.proc.send_signal(signal.SIGSTOP)
        try:
            time.sleep(1.5)
        finally:
            u.proc.send_signal(signal.SIGCONT)
        # on the satellite 15 s after AOS (it stood ~50 s into the pass before)
        wait_until(lambda: time.time() > p.aos_unix_s + 15.0, 120.0, "15 s after AOS")
        err_deg, s = _error_deg(u, es)
        assert err_deg < 2.0, (err_deg, s["az_deg"], s["el_deg"], s["events"])
        assert s["program"]["state"] == "tracking" and s["tracking"]["state"] == "tracking"
        assert not s["faults"] and s["last_stop"] is None, (s["faults"], s["last_stop"])
    finally:
        u.kill()


def test_a_pass_survives_the_death_of_urc_run_and_the_next_one_takes_it_over(tmp_path):
    """kill -9 of `urc run` during the pre-position: the control process flies on (it used
    to stop in order, the pass lost), and the `urc run` started 3 s later (systemd's
    RestartSec=2) takes the same control process over: on the satellite 15 s after AOS,
    position known, no fault, the take-over said in the events."""
    es, p, u = _pass_soon(tmp_path)
    u.start()
    u2 = None
    try:
        r = httpx.post(u.url + "/api/track/pass", json={"norad": NORAD, "aos": p.aos.isoformat()}, timeout=60)
        assert r.status_code == 200, r.text
        u.wait(lambda s: (s.get("program") or {}).get("state") == "prepositioning" and s["moving"], 60)
        control = u.control_pid()
        os.kill(u.proc.pid, signal.SIGKILL)
        u.proc.wait(10)
        time.sleep(3.0)
        assert not process_gone(control), "the control process stopped with urc run"
        u2 = UrcProcess(tmp_path, profile="g5500", port=u.port,
                        extra=STATION_TOML + f"[tracking]\ncatalog_dir = '{tmp_path / 'cat'}'\n")
        u2.adopted_control_pid = control
        u2.start()
        s = u2.status()
        assert s["program"] is not None and s["program"]["state"] in ("prepositioning", "tracking"), (s["program"], s["program_end"], s["events"])
        assert any("taken over" in e for e in s["events"]), s["events"]
        wait_until(lambda: time.time() > p.aos_unix_s + 15.0, 150.0, "15 s after AOS")
        err_deg, s = _error_deg(u2, es)
        assert err_deg < 2.0, (err_deg, s["az_deg"], s["el_deg"], s["events"])
        assert s["position_known"] and not s["faults"], (s["position_known"], s["faults"])
        assert u2.control_pid() == control
    finally:
        if u2 is not None:
            u2.kill()
        u.kill()
