"""The ``urc`` command line and a real ``urc run`` process, including kill -9."""

from __future__ import annotations

import json
import signal
import subprocess
import time
import tomllib

import pytest
from urc_process import HTTP, URC, UrcProcess, free_port, wait_until


def urc(*args, check=True, **kw):
    res = subprocess.run(URC + list(args), capture_output=True, text=True, timeout=60, **kw)
    if check and res.returncode != 0:
        raise AssertionError(f"urc {' '.join(args)} failed ({res.returncode}): {res.stdout}{res.stderr}")
    return res


class Controller(UrcProcess):
    """A real ``urc run`` process on the simulator, driven through the ``urc`` CLI."""

    def __init__(self, tmp_path, profile="tartu-urc", extra=""):
        super().__init__(tmp_path, profile=profile, extra=extra)

    def cli(self, *args, check=True):
        return urc(*args, "--url", self.url, check=check)

    def status(self) -> dict:
        # (its waits poll the API instead, UrcProcess.wait: `urc status --json` prints that
        # same snapshot, and a poll is then a request, not a Python process started)
        return json.loads(self.cli("status", "--json").stdout)

    def stop(self, sig=signal.SIGTERM) -> str:
        self.proc.send_signal(sig)
        out, _ = self.proc.communicate(timeout=20)
        return out


@pytest.fixture
def controller(tmp_path):
    made = []

    def make(**kw):
        c = Controller(tmp_path, **kw)
        made.append(c)
        return c
    yield make
    # killed, not stopped in order: no test here judges the stop of a urc it leaves
    # running (test_run_status_goto_stop_park stops its own, and looks at it)
    for c in made:
        if c.proc is not None and c.proc.poll() is None:
            UrcProcess.kill(c)
        UrcProcess.stop(c)


def test_config_example_is_valid_toml_with_defaults(tmp_path):
    out = urc("config", "example").stdout
    assert "#" in out and "[rotator]" in out
    tomllib.loads(out)
    path = tmp_path / "example.toml"
    path.write_text(out)
    assert "ok" in urc("config", "check", str(path)).stdout


@pytest.mark.parametrize("body, key, expected, found", [
    ('[limits.az]\nmax_deg = "abc"\n', "limits.az.max_deg", "number", "abc"),
    ('[rotator]\nprofile = "nope"\n', "rotator.profile", "tartu-urc", "nope"),
    ('[rotator]\nloop_hz = 0\n', "rotator.loop_hz", "1", "0"),
    ('[rotatr]\nprofile = "g5500"\n', "rotatr", "rotator", "rotatr"),
])
def test_config_errors_name_file_key_expected_found(tmp_path, body, key, expected, found):
    path = tmp_path / "bad.toml"
    path.write_text(body)
    res = urc("run", "--config", str(path), "--state-dir", str(tmp_path / "s"), check=False)
    assert res.returncode != 0
    msg = res.stderr
    for part in (str(path), key, expected, found):
        assert part in msg, f"{part!r} missing from {msg!r}"


def test_client_commands_without_a_controller_fail_clearly():
    res = urc("status", "--url", f"http://127.0.0.1:{free_port()}", check=False)
    assert res.returncode != 0 and "cannot reach urc" in res.stderr


def test_client_commands_take_port_like_run(tmp_path):
    port = free_port()
    res = urc("status", "--port", str(port), check=False)
    assert res.returncode != 0 and f"127.0.0.1:{port}" in res.stderr and "cannot reach urc" in res.stderr
    both = urc("status", "--port", str(port), "--url", "http://127.0.0.1:1", check=False)
    assert both.returncode != 0 and "not both" in both.stderr


def test_profiles_show_ranges_and_speeds():
    out = urc("profiles").stdout
    assert "az 0..400 deg, 0.6..6 deg/s   el 0..180 deg, 0.6..6 deg/s" in out   # tartu-urc
    assert "az -90..450 deg" in out                                            # sarcnet-mini


def test_run_status_goto_stop_park(controller):
    c = controller(profile="berkeley").start()
    s = c.status()
    assert s["profile"] == "berkeley" and s["simulator_truth"]["az"]["deg"] == pytest.approx(0, abs=0.5)
    assert "pointing" in c.cli("status").stdout
    # issue 13.8: the client commands take --port like `urc run` does
    by_port = json.loads(urc("status", "--json", "--port", str(c.port)).stdout)
    assert by_port["profile"] == "berkeley"
    # (25 deg of azimuth, 15 of elevation from the park at 0, 0: 1.8 s at berkeley's 40 deg/s
    # and 30 deg/s2; 45 20 was 2.5 s)
    c.cli("goto", "25", "15")
    s = c.wait(lambda s: abs(s["az_deg"] - 25) < 0.3 and abs(s["el_deg"] - 15) < 0.3 and not s["moving"])
    assert s["simulator_truth"]["az"]["deg"] == pytest.approx(25, abs=0.5)
    refused = c.cli("goto", "400", "30", check=False)  # berkeley: az 0..360
    assert refused.returncode != 0 and "outside" in refused.stderr
    # beyond what the API takes at all (el -90..180): said as the rotator's limits are,
    # not as pydantic's list (issue 36.11)
    refused = c.cli("goto", "123", "200", check=False)
    assert refused.returncode != 0 and refused.stderr.strip() == \
        f"Error: refused (422): el 200 outside the limits el {s['limits']['el'][0]:g}..{s['limits']['el'][1]:g}"
    # through the API, not the CLI: a loaded machine can take the whole 6 s move to start
    # a CLI process, and the stop below must land while the antenna moves
    # (a machine busy enough can finish the 4 s move before the stop lands: up to three
    # moves back and forth, one of which must stop on the way)
    for goal_az in (300, 90, 300):
        assert c.post("/api/goto", {"az_deg": goal_az, "el_deg": 80}).status_code == 200
        c.wait(lambda s: s["moving"])
        assert c.post("/api/stop", {}).status_code == 200
        s = c.wait(lambda s: not s["moving"])
        assert s["target_az_deg"] is None
        if abs(s["az_deg"] - goal_az) > 1:
            break  # it stopped on the way
    else:
        raise AssertionError(f"no stop landed during a move: last status {s}")
    assert "stop" in c.cli("stop").stdout.lower()  # the CLI's own stop is accepted
    c.cli("park")
    c.wait(lambda s: s["parked"] and not s["moving"])
    out = c.stop()
    assert "stopped, state saved" in out


def test_kill_9_during_a_move_then_restart(controller):
    c = controller(profile="tartu-urc").start()
    c.cli("goto", "200", "30")
    # (killed at speed: tartu-urc turns 6 deg/s at most; it used to wait for 20 deg of the
    # move, 3-4 s more of it, which changed nothing in what the restart is judged on)
    c.wait(lambda s: s["moving"] and abs(s["az"]["rate_deg_per_s"]) > 5)
    time.sleep(0.5)
    c.proc.send_signal(signal.SIGKILL)
    c.proc.wait()
    c.start()
    s = c.status()
    count_deg = 0.1  # tartu-urc encoders: 10 pulses per degree
    for axis in ("az", "el"):
        ax, truth = s[axis], s["simulator_truth"][axis]["deg"]
        if ax["uncertainty_deg"] == 0:
            assert abs(ax["pos_deg"] - truth) <= 2 * count_deg
        else:
            assert abs(ax["pos_deg"] - truth) <= ax["uncertainty_deg"]
    if not s["position_known"]:
        refused = c.cli("goto", "10", "10", check=False)
        assert refused.returncode != 0 and "uncertain" in refused.stderr
        assert "UNCERTAIN" in c.cli("status").stdout
        truth = s["simulator_truth"]
        c.cli("set-position", "--az", str(truth["az"]["deg"]), "--el", str(truth["el"]["deg"]))
        s = c.wait(lambda s: s["position_known"])
    # it moves again: a few degrees on from where it stands (elevation kept: the azimuth
    # move is the one judged; goto 10 10 was a 50-60 deg elevation move, 10 s of waiting)
    goal_az = round(s["az_deg"]) + 5
    c.cli("goto", str(goal_az), str(round(s["el_deg"])))
    c.wait(lambda s: abs(s["az_deg"] - goal_az) < 0.3 and not s["moving"])


def saved_at_rest(c: Controller) -> bool:
    """The state record on disk has each axis standing where the API's status says."""
    saved = json.loads((c.state_dir / "state.json").read_text())["payload"]["axes"]
    s = c.api_status()
    return all(not saved[axis]["moving"] and saved[axis]["mech_deg"] == s[axis]["pos_deg"] for axis in ("az", "el"))


def test_kill_9_when_standing_still_restarts_exactly(controller):
    c = controller(profile="bigras").start()
    c.cli("goto", "8", "3")   # (BIG-RAS: 4 deg/s az, 2 deg/s el; both axes off their park)
    c.wait(lambda s: not s["moving"] and abs(s["az_deg"] - 8) < 1.5, timeout_s=90)
    # standing on disk too: the record a restart reads has each axis at rest where the
    # status says it is (waited for: it was a fixed 0.3 s)
    wait_until(lambda: saved_at_rest(c), 30.0, "the position at rest saved")
    before = c.status()
    c.proc.send_signal(signal.SIGKILL)
    c.proc.wait()
    c.start()
    s = c.status()
    assert s["position_known"]
    for axis in ("az", "el"):
        assert s[axis]["pos_deg"] == pytest.approx(before[axis]["pos_deg"], abs=1e-6)
        assert s[axis]["pos_deg"] == pytest.approx(s["simulator_truth"][axis]["deg"], abs=2 * 0.5 + 0.3)


def test_track_prints_the_target_and_its_warnings(controller, tmp_path):
    """Issue 12.7: `urc track` always printed `tracking  None` (the plan and its warnings
    never reached the user)."""
    c = controller(extra="[station]\nlat_deg = 58.378\nlon_deg = 26.729\n").start()
    out = c.cli("track", "sun").stdout
    assert "tracking  Sun" in out and "None" not in out, out
    assert "target    az" in out
    out = c.cli("track", "--azel", "120", "-5").stdout  # below the horizon: said so
    assert "warning" in out and "below" in out, out
    c.cli("track", "--stop")


def test_track_without_a_station_says_what_is_missing(controller):
    """Issue 36.10: `urc track ISS` on a urc without [station] printed `refused (404): Not
    Found`. It says what is missing and how to add it; `urc run --lat --lon` gives the
    position for one run, never saved."""
    c = controller()
    c.start()
    res = c.cli("track", "ISS", check=False)
    assert res.returncode == 1 and "404" not in res.stderr, res.stderr
    for said in ("tracking is off", "no station position", "[station]", "lat_deg =", "lon_deg =",
                 "urc run --lat"):
        assert said in res.stderr, (said, res.stderr)
    c.stop()
    config_before = c.config.read_text()
    c.start(args=["--lat", "58.378", "--lon", "26.729"])
    assert "tracking  Sun" in c.cli("track", "sun").stdout
    c.cli("track", "--stop")
    c.stop()
    assert c.config.read_text() == config_before
    half = urc("run", "--config", str(c.config), "--lat", "58.4", check=False)
    assert half.returncode == 2 and "--lat and --lon together" in half.stderr


def test_status_shows_a_position_in_a_reference_search_as_unknown(bench):
    """BIG-RAS homing jogs in a search frame of its own: status printed 'az 434.00 ...
    UNCERTAIN' for an antenna at about 62 deg. During the search the number says nothing:
    it is shown as unknown; after it, the found position again."""
    from urc.procedures import calibration as cal
    from urc.status_text import format_status as _format_status

    b = bench("bigras", hardware={"sim": {"wind": False, "start_az_deg": 62.0}})
    cal.zero(b.rot, az_deg=b.truth("az"))
    b.run(0.2)
    proc = cal.LimitSwitchHoming(b.rot, "az")
    b.run(3.0, on_tick=proc.poll)
    s = b.rot.status()
    assert proc.state == "running" and not s.position_known
    assert abs(s.az.pos_deg - b.truth("az")) > 100          # the search frame's number
    text = _format_status(s.as_dict())
    assert "pointing  az unknown  el " in text and "axes      az unknown (" in text
    assert f"{s.az.pos_deg:.2f}" not in text and f"{s.az_deg:.2f}" not in text
    assert "az unknown: a reference search (homing) runs" in text
    b.run(300.0, on_tick=proc.poll, until=lambda _s: proc.finished)
    assert proc.state == "done"
    b.run(0.1)                                               # the end of the search is applied
    text = _format_status(b.rot.status().as_dict())
    assert "unknown" not in text and f"pointing  az {b.rot.status().az_deg:7.2f}" in text


def test_serve_specs_become_serve_entries():
    from urc.cli import serve_entry, with_serve
    from urc.config import Config
    from urc.errors import ConfigError

    assert serve_entry("rotctld=tcp:127.0.0.1:4535") == {"protocol": "rotctld", "tcp": "127.0.0.1:4535"}
    assert serve_entry("rot2prog=serial:/dev/ttyUSB0,baud=600") == \
        {"protocol": "rot2prog", "serial": "/dev/ttyUSB0", "baud": 600}
    assert serve_entry("urc=pty:/tmp/x,variant=trc,echo=true") == \
        {"protocol": "urc", "pty": "/tmp/x", "options": {"variant": "trc", "echo": True}}
    cfg = with_serve(Config(), ("gs232b=pty:/tmp/urc-gs", "pstrotator=udp:0.0.0.0:12000,reply_port=12002"))
    assert [e.describe() for e in cfg.serve] == ["gs232b on pty /tmp/urc-gs", "pstrotator on udp 0.0.0.0:12000"]
    assert cfg.serve[1].reply_port == 12002
    for bad in ("rotctld", "rotctld=4535", "rotctld=ftp:x", "rotctld=tcp:", "=tcp:1:2", "rotctld=tcp:h:1,baud"):
        with pytest.raises(ConfigError, match="--serve"):
            with_serve(Config(), (bad,))
    with pytest.raises(ConfigError, match="nosuch"):          # the configuration's own checks
        with_serve(Config(), ("nosuch=tcp:127.0.0.1:4535",))


def test_a_second_instance_needs_no_config_file(tmp_path):
    """`urc run --serve rotctld=tcp:...` serves there instead of the default 4533 (which a
    first urc holds), with no configuration file; the flag is not saved by the settings."""
    import socket

    port, rot_port = free_port(), free_port()
    proc = subprocess.Popen(URC + ["run", "--port", str(port), "--state-dir", str(tmp_path / "state"),
                                   "--serve", f"rotctld=tcp:127.0.0.1:{rot_port}"],
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        url = f"http://127.0.0.1:{port}"

        def answers():
            try:
                with socket.create_connection(("127.0.0.1", rot_port), timeout=2) as s:
                    s.sendall(b"p\n")
                    return s.recv(100)
            except OSError:
                assert proc.poll() is None, proc.stdout.read()
                return None
        reply = wait_until(answers, timeout_s=60, what="rotctld on the --serve port")
        assert reply.decode().count("\n") == 2                      # az and el lines
        doc = HTTP.get(url + "/api/settings", timeout=5).json()
        assert doc["config"]["serve"] == [{"protocol": "rotctld", "tcp": f"127.0.0.1:{rot_port}",
                                           "reply_port": 12001, "options": {}}]
    finally:
        proc.terminate()
        proc.wait(timeout=30)


def test_help_texts_for_set_position_and_run():
    out = urc("set-position", "--help").stdout
    assert "--az DEG" in out and "azimuth the antenna points at now" in out
    assert "--el DEG" in out and "elevation the antenna points at now" in out
    assert "--serve PROTOCOL=KIND:WHERE" in urc("run", "--help").stdout


def test_settings_show_prints_only_the_keys_that_apply(monkeypatch):
    """Issue 36.14: `urc settings show` printed reply_port on TCP ports and the compass
    keys on a BIG-RAS (pulse sensors), the simulator's table on a Pi."""
    import tomllib

    from click.testing import CliRunner

    from urc import cli
    from urc.config import Config, load_config

    from pathlib import Path

    data = load_config(Path(__file__).resolve().parents[1] / "examples" / "bigras.toml").to_dict()
    data["serve"] = [{"protocol": "rotctld", "tcp": "127.0.0.1:4533"},
                     {"protocol": "pstrotator", "udp": "127.0.0.1:12000", "reply_port": 12002},
                     {"protocol": "gs232b", "serial": "/dev/ttyUSB0", "baud": 9600}]
    doc = Config.from_dict(data).to_dict()
    assert "compass" in doc["hardware"]["gpio"]["az"] and "reply_port" in doc["serve"][0]  # (in the document)
    monkeypatch.setattr(cli, "api_request", lambda *a, **k: {"config": doc})
    res = CliRunner().invoke(cli.main, ["settings", "show", "--url", "http://127.0.0.1:1"])
    assert res.exit_code == 0, res.output
    shown = tomllib.loads(res.output)
    az = shown["hardware"]["gpio"]["az"]
    assert "compass" not in az and "declination_deg" not in az and "stepper_driver" not in az
    assert "relay_pulse_hz" not in az and "encoder_drift_counts" not in az and "adc" not in az
    assert az["pulse_debounce_s"] == 0.005 and az["motor"] == "bts7960" and "limit_debounce_s" in az
    assert "sim" not in shown["hardware"]
    tcp, udp, serial = shown["serve"]
    assert "reply_port" not in tcp and "baud" not in tcp and udp["reply_port"] == 12002 and "baud" not in udp
    assert serial["baud"] == 9600 and "reply_port" not in serial
