"""A bridge link on the virtual clock: the client engine talks to a device-side protocol
session (urc's own GS-232, Easycomm, SPID or rotctld emulation) in the same process,
with the wire's timing simulated: every byte takes 10 bits at the link's baud rate, the
device answers at once when the request has arrived, and the controller's post-write
delay is kept. A harness (urc.testing): tests and the bridge benchmark fly whole passes
through a bridge in seconds with it, judged by the upstream simulator's truth.

Call :meth:`SimLink.step` once per control tick with the virtual time.
"""

from __future__ import annotations

from typing import Any

from ..hardware.bridge.client import BridgeClient
from ..hardware.bridge.dialects import Exchange
from .sessions import fed

BITS_PER_BYTE = 10  # 8N1: start + 8 data + stop


class SimLink:
    def __init__(self, client: BridgeClient, session: Any, baud: int | None = None,
                 latency_s: float = 0.0005):
        """``session``: a device session (``receive(bytes) -> [replies]``); ``baud``:
        None = a network link (no serial delay); ``latency_s``: one way, per message
        (a host's scheduling, a network hop)."""
        self.client, self.session, self.baud = client, session, baud
        self.latency_s = latency_s
        self._busy: tuple[Exchange, float, float, bytes | None] | None = None  # ex, sent, done, reply
        self._t_s = 0.0  # the line's own time: when it is free for the next request
        self.connected = False
        self.garbage: bytes | None = None   # tests: the device answers this instead
        self.cut_reason: str | None = None
        #: every request sent, with its virtual time (tests)
        self.sent: list[tuple[float, bytes]] = []

    def cut(self, reason: str = "cable pulled", now_s: float = 0.0) -> None:
        """The link goes away (tests): nothing more is exchanged until :meth:`mend`."""
        self.cut_reason = reason
        self._busy = None
        self.client.link_down(reason, now_s)

    def mend(self, now_s: float) -> None:
        self.cut_reason = None
        self.client.link_up(now_s)
        self._t_s = now_s

    def wire_s(self, data: bytes) -> float:
        return self.latency_s + (0.0 if self.baud is None else len(data) * BITS_PER_BYTE / self.baud)

    def step(self, now_s: float) -> None:
        """Run every exchange that completes by ``now_s``."""
        if not self.connected:
            self.client.link_up(now_s)
            self.connected = True
            self._t_s = now_s
        if self.cut_reason is not None:
            return
        if self.client.link_broken():
            # as the I/O thread does: drop the link, reconnect at the next step
            self.client.link_down(f"{self.client.options.max_failures} bad or missing answers in a row", now_s,
                                  failures=True)
            self.client.link_up(now_s)
            self._busy = None
        if self._busy is None and self._t_s < now_s:
            self._t_s = now_s  # the line was idle: the next request starts now
        for _ in range(100):  # bounded: a burst of instant exchanges on a fast link
            if self._busy is not None:
                ex, sent_s, done_s, reply = self._busy
                if now_s < done_s:
                    return
                self._busy = None
                if reply is None:
                    self.client.sent(ex, done_s)
                else:
                    assert ex.reply is not None  # (an answer is kept only for an exchange that has one)
                    complete = ex.reply.complete(reply)
                    if complete is None:
                        self.client.timed_out(ex, reply, done_s)
                    else:
                        self.client.answered(ex, reply[:complete], sent_s, done_s)
                self._t_s = done_s + ex.settle_s
            if self._t_s > now_s:
                return
            upcoming, _wait_s = self.client.next_exchange(self._t_s)
            if upcoming is None:
                return
            ex = upcoming
            start_s = self._t_s
            self.sent.append((start_s, ex.request))
            arrived_s = start_s + self.wire_s(ex.request)
            answers = b"".join(fed(self.session, ex.request))
            if ex.reply is None:
                self._busy = (ex, start_s, arrived_s, None)
                continue
            if self.garbage is not None:
                answers = self.garbage
            complete = ex.reply.complete(answers)
            if complete is None:
                # no (whole) answer: the client waits out its timeout
                self._busy = (ex, start_s, arrived_s + self.client.timeout_s, answers)
            else:
                self._busy = (ex, start_s, arrived_s + self.wire_s(answers[:complete]), answers)


class BridgedRig:
    """Two rotators on one virtual clock: ``upstream`` (the simulator, serving
    ``protocol`` like the controller a station owns) and ``downstream`` (the bridge
    backend driving it through a :class:`SimLink`). ``tick()`` advances one period."""

    def __init__(self, protocol: str, profile: str, state_dir, *, baud: int | None = None,
                 upstream_config: dict | None = None, downstream_config: dict | None = None,
                 client_options=None, start_s: float = 0.0):
        from ..assembly import build_rotator, settings_from_config
        from ..clock import VirtualClock
        from ..config import Config
        from ..hardware.bridge.client import ClientOptions
        from ..hardware.bridge.dialects import make_dialect

        self.clock = VirtualClock(start_s)
        up = {"rotator": {"profile": profile}, "hardware": {"sim": {"wind": False}}, **(upstream_config or {})}
        self.upstream = build_rotator(Config.from_dict(up), self.clock, state_dir / "up", fast_virtual=True)
        down = {"rotator": {"profile": profile},
                "hardware": {"backend": "bridge", "bridge": {"protocol": protocol, "serial": "/dev/null"}},
                **(downstream_config or {})}
        self.settings = settings_from_config(Config.from_dict(down))
        self.dialect = make_dialect(protocol)
        self._client_options = client_options or ClientOptions(over_top=self.settings.caps.el_past_zenith)
        self._baud = None if protocol == "rotctld" else (baud or self.dialect.default_baud)
        self._protocol, self._state_dir = protocol, state_dir / "down"
        self._state_dir.mkdir(parents=True, exist_ok=True)
        self._start_downstream()

    def _start_downstream(self) -> None:
        from ..persistence import StateStore
        from ..protocols.registry import make_session
        from ..rotator.rotator import Rotator
        from ..hardware.interfaces import Hardware
        from ..hardware.bridge import bridge_axes

        self.client = BridgeClient(self.dialect, self._client_options)
        self.session = make_session(self._protocol, self.upstream)
        self.link = SimLink(self.client, self.session, self._baud)
        az, el = bridge_axes(self.client, self.clock)
        # a first report before the downstream rotator restores (as build_bridge_hardware waits)
        for _ in range(200):
            self.upstream.tick()
            self.link.step(self.clock.now_s())
            if self.client._pos is not None:
                break
            self.clock.advance(1.0 / self.upstream.caps.loop_hz)
        self.downstream = Rotator(self.settings, Hardware("bridge", az, el), self.clock,
                                  StateStore(self._state_dir / "state.json", durable=False))

    def restart_downstream(self, crash: bool = False) -> None:
        """The bridged urc stops (its state saved) and starts again on the same
        controller: a new client, link and rotator, restored from that state.
        ``crash``: it dies instead (kill -9: only the records already written count)."""
        if not crash:
            self.downstream.shutdown()
        self._start_downstream()

    @property
    def period_s(self) -> float:
        return 1.0 / self.downstream.caps.loop_hz

    def tick(self, downstream: bool = True):
        """One period; ``downstream=False``: the link is driven by hand (posting to
        ``client``), the bridged rotator stays out of it."""
        self.clock.advance(self.period_s)
        self.upstream.tick()
        self.link.step(self.clock.now_s())
        return self.downstream.tick() if downstream else self.downstream.status()

    def run(self, duration_s: float, until=None):
        status = self.downstream.status()
        for _ in range(max(1, round(duration_s / self.period_s))):
            status = self.tick()
            if until is not None and until(status):
                break
        return status

    def truth(self) -> tuple[float, float]:
        """Where the upstream simulator's antenna really points (mechanical)."""
        t = self.upstream.status().sim_truth
        assert t is not None  # (the upstream is a simulator)
        return t["az"]["deg"], t["el"]["deg"]
