"""The tracker and calibration procedures without greenlets (issue 34.3): synchronous
code that calls the rotator port runs on a thread of its own, where a round trip to a
real control process blocks that thread only, and the event loop awaits it. Every
request they send is recorded with the thread that sent it: none from the loop's
(URC_STRICT_EVENT_LOOP, set for every test, would also turn one into an error)."""

from __future__ import annotations

import asyncio
import threading

from urc.config import Config
from urc.tracking.service import TrackingService
from urc.web.live import Hub

from .conftest import TARTU


def recorded_senders(rot) -> list[tuple[str, str]]:
    """(request, the thread that sent it) for every request on ``rot``'s link."""
    sent: list[tuple[str, str]] = []
    link = rot._link
    real_send = link.send

    def send(msg: tuple) -> None:
        if msg[0] == "request":
            sent.append((type(msg[1].request).__name__, threading.current_thread().name))
        real_send(msg)
    link.send = send
    return sent


def test_tracker_steps_and_commands_reach_the_control_process_from_the_tracker_thread(start_control):
    _proc, rot = start_control("tartu-urc")
    sent = recorded_senders(rot)
    cfg = Config.from_dict({"station": {"lat_deg": TARTU.lat_deg, "lon_deg": TARTU.lon_deg, "alt_m": TARTU.alt_m}})
    svc = TrackingService(rot, cfg, background=True)

    async def main() -> str:
        await svc.track({"kind": "azel", "az_deg": 123.0, "el_deg": 30.0})
        for _ in range(300):  # steps, as urc run makes them, until the setpoint is there
            await svc.step(rot.clock.now_s())
            if rot.status().target_az_deg is not None:
                break
            await asyncio.sleep(0.01)
        await svc.stop()
        return threading.current_thread().name

    loop_thread = asyncio.run(main())
    svc.close()
    assert rot.status().target_az_deg is not None and abs(rot.status().target_az_deg - 123.0) < 1.0
    assert sent, "the tracker sent nothing to the control process"
    assert {thread for _name, thread in sent} == {"urc-tracker_0"}, sent
    assert loop_thread not in {thread for _name, thread in sent}


class _StopsWhenPolled:
    """A procedure of the hub's shape whose poll and cancel call the port."""

    kind, axis, state = "test", "az", "running"

    def __init__(self, rot):
        self.rot, self.polls, self.threads = rot, 0, []

    @property
    def finished(self) -> bool:
        return self.state != "running"

    def poll(self, status) -> None:
        self.threads.append(threading.current_thread().name)
        self.rot.stop()
        self.polls += 1

    def cancel(self) -> None:
        self.threads.append(threading.current_thread().name)
        self.rot.stop()
        self.state = "cancelled"

    def as_dict(self) -> dict:
        return {"kind": self.kind, "state": self.state}


def test_a_procedure_polls_and_cancels_off_the_loop(start_control):
    _proc, rot = start_control("tartu-urc")
    sent = recorded_senders(rot)
    proc = _StopsWhenPolled(rot)

    async def main() -> str:
        hub = Hub(rot)
        hub.start_procedure(proc)
        for _ in range(500):
            if proc.polls >= 3:
                break
            await asyncio.sleep(0.01)
        await hub.cancel_procedure()
        return threading.current_thread().name

    loop_thread = asyncio.run(main())
    assert proc.polls >= 3 and proc.state == "cancelled"
    assert [name for name, _thread in sent].count("Stop") >= 4
    assert loop_thread not in proc.threads and loop_thread not in {thread for _name, thread in sent}, sent
