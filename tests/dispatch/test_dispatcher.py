"""urc.dispatch.Dispatcher, the commands the web API and MQTT share: bad input is refused
with reason "invalid" naming the field and sends nothing over the link; good input sends
one request; a stop reaches the rotator before anything else can fail."""

from __future__ import annotations

import asyncio
import math

import pytest

from urc.dispatch import Dispatcher, Invalid, NotSimulated, Stopped, TrackerFailed, TrackingOff
from urc.errors import CommandRejected
from urc.model import messages as msg
from urc.link.client import ControlUnavailable, StopQueued


class Link:
    """The rotator as the I/O process sees it: ``call`` is one round trip over the link
    (urc.model.effects.call awaits it); every request it is given is recorded."""

    def __init__(self, fail: dict | None = None, answers: dict | None = None, simulator: bool = True):
        self.sent: list = []
        self.fail = fail or {}
        self.answers = answers or {}
        self.simulator = simulator

    def ask(self, query):  # (a query answered without a round trip: HardwareInfo is sent at start)
        assert isinstance(query, msg.HardwareInfo), query
        return msg.HardwareSummary("sim" if self.simulator else "gpio", self.simulator, "")

    async def call(self, request):
        self.sent.append(request)
        if type(request) in self.fail:
            raise self.fail[type(request)]
        return self.answers.get(type(request))


class HubLog:
    def __init__(self, log: list):
        self.log = log

    async def release(self, axis):
        self.log.append(("release", axis))

    async def cancel_procedure(self):
        self.log.append(("cancel_procedure",))

    async def refresh_tracking(self):
        self.log.append(("refresh_tracking",))

    async def procedure_step(self, fn, *args):
        self.log.append(("procedure_step", fn, args))
        return fn(*args)

    def start_procedure(self, proc):
        self.log.append(("start_procedure", proc))


class Tracker:
    def __init__(self, log: list, fail: Exception | None = None):
        self.log = log
        self.fail = fail

    async def track(self, request):
        self.log.append(("track", request))

    def track_pass(self, norad, aos):
        self.log.append(("track_pass", norad, aos))

    async def stop(self):
        self.log.append(("tracker.stop",))
        if self.fail is not None:
            raise self.fail


def station(fail: dict | None = None, tracker_fail: Exception | None = None, answers: dict | None = None):
    log: list = []
    link = Link(fail, answers)
    return Dispatcher(link, Tracker(log, tracker_fail), HubLog(log)), link, log


AOS = "2026-01-01T00:00:00Z"

BAD = [
    ("goto", {"az_deg": float("nan")}, "az_deg"),
    ("goto", {"az_deg": float("inf"), "el_deg": 10.0}, "az_deg"),
    ("goto", {"az_deg": "45"}, "az_deg"),              # strict: a string is no angle
    ("goto", {"az_deg": True}, "az_deg"),
    ("goto", {"az_deg": 721.0}, "az_deg"),
    ("goto", {"az_deg": 10.0, "el_deg": 181.0}, "el_deg"),
    ("goto", {"az_deg": 10.0, "el_dge": 5.0}, "el_dge: unknown field"),
    ("goto", {}, "az_deg"),
    ("stop", {"axis": "x"}, "axis"),
    ("move", {"axis": "az", "direction": 2}, "direction"),
    ("move", {"axis": "az", "direction": 1, "speed": 1.5}, "speed"),
    ("move", {"axis": "az", "direction": 1, "speed": 0.0}, "speed"),
    ("set_position", {"az_deg": float("nan")}, "az_deg"),
    ("track", {"kind": "point", "lat_deg": 1.0}, "needs lon_deg"),
    ("track", {"kind": "satellite"}, "name or norad"),
    ("track", {"kind": "comet"}, "kind"),
    ("track", {"kind": "nmea", "source": "x; rm -rf /"}, "source"),
    ("track_pass", {"norad": "25544", "aos": AOS}, "norad"),
    ("track_pass", {"norad": 0, "aos": AOS}, "norad"),
    ("track_pass", {"norad": 25544, "aos": "tomorrow"}, "aos"),
    ("zero", {"az_deg": -361.0}, "az_deg"),
    ("pot_read", {"axis": "z"}, "axis"),
    ("pot_apply", {"axis": "az", "points": [{"bearing_deg": 0.0, "p": 0.1}]}, "points"),
    ("pot_apply", {"axis": "az", "points": [{"bearing_deg": 0.0, "p": float("nan")},
                                            {"bearing_deg": 90.0, "p": 0.5}]}, "points.0.p"),
    ("homing", {"axis": "az", "speed_frac": 0.0}, "speed_frac"),
    ("homing", {"axis": "az", "switch_deg": 1e6}, "switch_deg"),
    ("sim_fault", {"axis": "az", "kind": "meteor"}, "kind"),
    ("sim_fault", {"axis": "az", "kind": "runaway", "duty": 2.0}, "duty"),
    ("sim_clear", {"axis": "both"}, "axis"),
]


@pytest.mark.parametrize("method, body, says", BAD, ids=[f"{m}-{s}" for m, _, s in BAD])
def test_bad_input_is_refused_naming_the_field_and_sends_nothing(method, body, says):
    d, link, log = station()
    with pytest.raises(Invalid) as err:
        asyncio.run(getattr(d, method)(body))
    assert err.value.reason == "invalid" and says in str(err.value), str(err.value)
    assert isinstance(err.value, CommandRejected)  # (each front end's refusal form takes it)
    assert err.value.errors and all("loc" in e for e in err.value.errors)
    assert link.sent == [] and log == []


def test_a_body_that_is_not_an_object_is_refused_too():
    d, link, log = station()
    for junk in (None, [], "goto", 45.0):
        with pytest.raises(Invalid):
            asyncio.run(d.goto(junk))
    assert link.sent == [] and log == []


@pytest.mark.parametrize("method, body, sent", [
    ("goto", {"az_deg": 120.0, "el_deg": 30.0}, msg.Goto(120.0, 30.0)),
    ("goto", {"az_deg": 120}, msg.GotoAz(120.0)),          # azimuth alone; an int is a number
    ("move", {"axis": "el", "direction": -1}, msg.Move("el", -1, 1.0)),
    ("set_position", {"el_deg": 10.0}, msg.SetPosition(None, 10.0)),
    ("zero", {"az_deg": 5.0}, msg.SetPosition(5.0, None)),
    ("pot_apply", {"axis": "az", "points": [{"bearing_deg": 0.0, "p": 0.1}, {"bearing_deg": 90.0, "p": 0.5}]},
     msg.PotApply("az", ((0.0, 0.1), (90.0, 0.5)))),
])
def test_a_good_body_sends_its_one_request(method, body, sent):
    d, link, _ = station(answers={msg.PotApply: {"M": 1.0}})
    asyncio.run(getattr(d, method)(body))
    assert link.sent == [sent]


def test_goto_and_park_return_the_route_and_a_refusal_passes_through_with_its_reason():
    route = [(10.0, 5.0), (20.0, 5.0)]
    d, link, _ = station(answers={msg.Goto: route, msg.Park: route})
    assert asyncio.run(d.goto({"az_deg": 20.0, "el_deg": 5.0})) == route
    assert asyncio.run(d.park()) == route
    d, link, _ = station(fail={msg.Goto: CommandRejected("az 20 is in keep-out zone mast", "keepout")})
    with pytest.raises(CommandRejected) as err:
        asyncio.run(d.goto({"az_deg": 20.0, "el_deg": 5.0}))
    assert err.value.reason == "keepout" and "mast" in str(err.value)


def test_pot_apply_gives_a_constant_never_set_as_none():
    d, _, _ = station(answers={msg.PotApply: {"M": 2.0, "C": math.nan}})
    assert asyncio.run(d.pot_apply({"axis": "az", "points": [{"bearing_deg": 0.0, "p": 0.1},
                                                              {"bearing_deg": 90.0, "p": 0.5}]})) == \
        {"M": 2.0, "C": None}


def test_stop_goes_out_first_then_jogs_procedure_and_tracking():
    d, link, log = station()
    assert asyncio.run(d.stop()) == Stopped()
    assert link.sent == [msg.Stop(None)]
    assert log == [("release", None), ("cancel_procedure",), ("tracker.stop",), ("refresh_tracking",)]
    d, link, log = station()
    asyncio.run(d.stop({"axis": "el"}))   # one axis: its jog only; tracking goes on
    assert link.sent == [msg.Stop("el")] and log == [("release", "el")]


def test_a_tracker_that_fails_to_stop_cannot_keep_the_stop_from_the_rotator():
    d, link, log = station(tracker_fail=RuntimeError("catalog locked"))
    with pytest.raises(TrackerFailed) as err:
        asyncio.run(d.stop())
    assert link.sent == [msg.Stop(None)]
    assert err.value.reason == "tracking" and "catalog locked" in str(err.value)
    assert isinstance(err.value.cause, RuntimeError)


def test_a_failed_stop_still_stops_jogs_procedure_and_tracking_and_says_why():
    d, link, log = station(fail={msg.Stop: ControlUnavailable("control loop died: it stopped")})
    with pytest.raises(ControlUnavailable, match="control loop died"):
        asyncio.run(d.stop())
    assert ("tracker.stop",) in log and ("cancel_procedure",) in log and ("release", None) in log


def test_a_queued_stop_is_no_failure_and_the_rest_stops_too():
    d, link, log = station(fail={msg.Stop: StopQueued("control process held up: the stop is sent")})
    out = asyncio.run(d.stop())
    assert out.queued and "held up" in out.note
    assert ("tracker.stop",) in log


def test_tracking_without_a_tracker_is_refused_with_reason_tracking():
    d = Dispatcher(Link())
    for run in (d.track({"kind": "sun"}), d.track_pass({"norad": 25544, "aos": AOS}), d.track_stop()):
        with pytest.raises(TrackingOff) as err:
            asyncio.run(run)
        assert err.value.reason == "tracking" and "no [station]" in str(err.value)
    assert asyncio.run(d.stop()) == Stopped()   # (a stop needs no tracker)


def test_tracker_commands_plain_or_async_refresh_the_hub_and_a_failure_is_a_refusal():
    d, link, log = station()
    asyncio.run(d.track({"kind": "azel", "az_deg": 10, "el_deg": 20}))
    asyncio.run(d.track_pass({"norad": 25544, "aos": AOS}))
    assert log[0] == ("track", {"kind": "azel", "az_deg": 10.0, "el_deg": 20.0})
    assert log[1] == ("refresh_tracking",) and log[2][:2] == ("track_pass", 25544) and log[3] == ("refresh_tracking",)
    assert link.sent == []  # (the tracker moves the rotator itself)

    class NoFit(Tracker):
        def track_pass(self, norad, aos):
            raise ValueError("the pass does not fit inside the limits")
    log = []
    d = Dispatcher(Link(), NoFit(log), HubLog(log))
    with pytest.raises(TrackerFailed) as err:
        asyncio.run(d.track_pass({"norad": 25544, "aos": AOS}))
    assert err.value.reason == "tracking" and "does not fit" in str(err.value) and log == []

    class Busy(Tracker):
        async def track(self, request):
            raise CommandRejected("a pass program is running", "busy")
    with pytest.raises(CommandRejected) as err2:   # a UrcError keeps its own reason
        asyncio.run(Dispatcher(Link(), Busy([]), None).track({"kind": "sun"}))
    assert err2.value.reason == "busy" and not isinstance(err2.value, TrackerFailed)


def test_fault_injection_only_on_a_simulator_and_then_one_request():
    d = Dispatcher(Link(simulator=False))
    for run in (d.sim_fault({"axis": "az", "kind": "jam"}), d.sim_clear({"axis": "az"})):
        with pytest.raises(NotSimulated) as err:
            asyncio.run(run)
        assert err.value.reason == "simulator" and "only on the simulator" in str(err.value)
    assert d.rotator.sent == []
    d = Dispatcher(Link())
    asyncio.run(d.sim_fault({"axis": "el", "kind": "slow_read", "delay_s": 0.5, "reads": 3}))
    asyncio.run(d.sim_clear({"axis": "el"}))
    assert d.rotator.sent == [msg.SimFault("el", "slow_read", {"delay_s": 0.5, "reads": 3}), msg.SimClear("el", None)]


def test_procedures_need_a_hub():
    d = Dispatcher(Link())
    with pytest.raises(CommandRejected):
        asyncio.run(d.homing({"axis": "az"}))
