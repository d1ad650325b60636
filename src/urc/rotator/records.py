"""Position records: what the rotator writes down so that a restart knows where the
antenna is (or knows that it does not), and what it concludes from them at start-up.

:meth:`Records.restore` brings back position, wrap and calibration from the state file.
Each tick :meth:`Records.persist` keeps the record one step ahead of the axes (see
:mod:`urc.rotator.position_record`): it hands the writer a new record when one is due
and gives no drive to an axis that could leave the window of the newest record on disk.
A reference search (homing) works in a temporary frame; the records keep the true one.

A moving command's reply waits for the first record after the command took effect
(:meth:`Records.motion_ticket`, :meth:`Records.await_motion_record`): while the antenna
stands nothing is written, so a disk that has just failed is found only by that record,
and the command is then refused rather than answered ok and held (issue 36.19).
"""

from __future__ import annotations

import collections
import threading
import time
from dataclasses import replace
from typing import Any, Callable

from ..clock import VirtualClock
from ..control.faults import Fault
from ..errors import StateFileError
from ..persistence import StateStore
from . import position_record as precord
from .axis import Axis
from .core import Core
from .state_writer import StateWriter


class Records:
    def __init__(self, core: Core, store: StateStore | None, latch: Callable[[Fault], None]):
        self.core = core
        self.store = store
        self.latch = latch
        clock = core.clock
        # the last record handed to the writer, the newest known to be on disk with its
        # windows, and why saving fails, if it does
        self.writer = None if store is None else StateWriter(
            store, background=not isinstance(clock, VirtualClock), now_s=clock.now_s)
        self.record: dict[str, Any] | None = None
        self.recent: collections.deque[tuple[dict[str, Any], dict[str, tuple[float, float]]]] = \
            collections.deque(maxlen=8)
        self.durable: dict[str, Any] | None = None
        self.durable_windows: dict[str, tuple[float, float]] = {}
        #: set when the axes changed in a way the record must show (a re-reference)
        self.record_dirty = False
        self.save_error = ""
        #: reference searches in progress (homing): axis -> (uncertainty before, frame shift)
        self.searches: dict[str, tuple[float, float]] = {}
        #: moving commands accepted that need a record ahead of their motion (counted
        #: under the rotator's lock), the last one's number per thread, and what the
        #: last tick made of them: (how many it applied, the number of the writer's
        #: record they wait for, None: none to wait for)
        self.motions = 0
        self._ticket = threading.local()
        self._applied: tuple[int, int | None] = (0, None)
        self._applied_cv = threading.Condition()

    def mark_dirty(self) -> None:
        """The next tick writes a new record (the axes changed in a way it must show)."""
        self.record_dirty = True

    def restore(self) -> None:
        """Bring back position, wrap and calibration from the state file, and write the
        record of what was concluded before anything can move (a crash right after
        start-up must find it, not an older or missing file)."""
        core = self.core
        payload: dict[str, Any] | None = None
        # with no store (tests, tools) the antenna is where the simulator starts it
        fresh = self.store is None or self.store.fresh()
        if self.store is not None:
            try:
                payload = self.store.load()
            except StateFileError as exc:
                core.event(f"state file damaged, not trusted: {exc}")
                self.store.quarantine()
            if payload is not None and payload.get("profile") == core.caps.name:
                saved_axes = payload.get("axes", {})
                bad = next((why for name, ax in core.axes.items()
                            if (why := precord.record_out_of_range(ax, saved_axes.get(name)))), None)
                if bad is not None:
                    core.event(f"state file damaged, not trusted: {self.store.path}: {bad}")
                    self.store.quarantine()
                    payload = None
            if payload is not None and payload.get("profile") != core.caps.name:
                core.event(f"state file belongs to profile {payload.get('profile')!r}, ignored")
                payload = None
            elif payload is None and not fresh:
                core.event("no usable state file in a state directory used before")
        # a used state directory without a usable record: where the antenna is, is unknown
        lost = payload is None and not fresh
        now = core.clock.now_s()
        core.hw.poll(now)
        saved_axes = (payload or {}).get("axes", {})
        # with nothing saved, assume the mechanical home where the profile's rotator
        # rests (sky park may differ by the mount offsets)
        home = {"az": core.caps.az.park_deg, "el": core.caps.el.park_deg}
        for name, ax in core.axes.items():
            saved = saved_axes.get(name)
            saved = saved if isinstance(saved, dict) else None
            # a record without this axis (written while the rotator ran single-axis):
            # where the axis is now is unknown
            lost_axis = lost or (payload is not None and saved is None)
            if saved and saved.get("calibration"):
                try:
                    ax.hw.sensor.load_calibration(saved["calibration"])
                except Exception as exc:  # a bad calibration must not prevent start-up
                    core.event(f"{name}: saved calibration rejected ({exc})")
            if saved and saved.get("coast_deg"):
                coast = tuple(float(c) for c in saved["coast_deg"])
                if len(coast) == len(ax.law.coast_deg):
                    ax.law = replace(ax.law, coast_deg=coast)
            win = precord.saved_window(saved) if saved else None
            anchor = float(saved["mech_deg"]) if saved else home[name]
            if win is not None and not precord.known_window(ax, win):
                anchor = (win[0] + win[1]) / 2.0
            if not ax.caps.sensor.absolute:
                self._restore_incremental(ax, saved, win, lost_axis, anchor)
            ax.meas_deg = anchor
            if ax.read(0.0) is None:
                core.event(f"{name}: sensor unreadable at start-up ({ax.sensor_error})")
            else:
                self._check_ambiguity(ax, saved, win, lost_axis)
            if saved and saved.get("uncertainty_deg"):
                ax.uncertainty_deg += float(saved["uncertainty_deg"])
            ax.law = replace(ax.law, ref_deg=ax.meas_deg, last_meas_deg=ax.meas_deg)
        if core.position_uncertain():
            core.event("position uncertain: automatic motion refused until re-referenced "
                       "(set position)")
        if self.writer is not None and self.store is not None:
            if self.submit_record(now, wait=True):
                self.store.mark_initialised()

    def _restore_incremental(self, ax: Axis, saved: dict | None, win: tuple[float, float] | None,
                             lost: bool, anchor: float) -> None:
        core = self.core
        if saved is None:
            ax.set_reference(anchor, at_edge=True)  # resting at its mechanical home
            if lost:
                ax.uncertainty_deg = ax.caps.span_deg
            else:
                core.event(f"{ax.name}: first start in this state directory; assuming park "
                           f"{anchor:.1f} deg (set position if the antenna is elsewhere)")
            return
        if win is None:
            # a record without a window (an older urc): only a standing one is trusted
            if saved.get("moving"):
                ax.uncertainty_deg = ax.caps.span_deg
        elif not precord.known_window(ax, win):
            # it died on the move: the axis is somewhere in the window the record promised
            ax.uncertainty_deg = (win[1] - win[0]) / 2.0 + precord.estimate_slack_deg(ax)
        ax.set_reference(anchor)

    def _check_ambiguity(self, ax: Axis, saved: dict | None, win: tuple[float, float] | None,
                         lost: bool) -> None:
        """A reading that could also mean another position within the limits (another
        turn of a sensor modulo 360; the other side of the zenith of a folded report):
        the record must tell which, else the axis is uncertain by the distance."""
        core = self.core
        lo, hi = ax.limits
        fold = ax.caps.sensor.fold_deg
        alternatives = [ax.meas_deg + k * ax.modulo for k in (-1, 1)] if ax.modulo is not None else []
        if fold is not None and abs(ax.meas_deg - fold) > precord.hold_band_deg(ax):
            alternatives.append(2.0 * fold - ax.meas_deg)
        alternatives = [a for a in alternatives if lo <= a <= hi]
        if not alternatives:
            return
        apart_deg = max(abs(a - ax.meas_deg) for a in alternatives)
        slack = precord.estimate_slack_deg(ax)
        if saved is None:
            if lost:
                ax.uncertainty_deg = apart_deg
            else:
                core.event(f"{ax.name}: first start in this state directory; assuming "
                           f"{ax.meas_deg:.1f} deg, nearest park (also possible: "
                           f"{', '.join(f'{a:.1f}' for a in alternatives)})")
        elif win is not None and any(win[0] - slack <= a <= win[1] + slack for a in alternatives):
            ax.uncertainty_deg = apart_deg  # the record cannot tell which
        elif win is None and saved.get("moving"):
            ax.uncertainty_deg = apart_deg

    def persist(self, now_s: float) -> None:
        """Keep the state record one step ahead of the axes (see position_record): hand
        the writer a new record when one is due, and give no drive to an axis that could
        leave the window of the newest record on disk within this tick."""
        core = self.core
        if self.writer is None:
            return
        self.take_report(now_s)
        if self.record_due(now_s):
            self.submit_record(now_s)
            self.take_report(now_s)
        held = []
        dt_s = 1.0 / core.caps.loop_hz
        for name, ax in core.axes.items():
            if ax.out.duty == 0.0 or not precord.needs_record(ax):
                continue
            p, v = ax.meas_deg, ax.rate_deg_per_s
            c = precord.coast_deg(ax, abs(v) + ax.tuning.accel_deg_per_s2 * dt_s)
            step = (min(p, p + v * dt_s) - c, max(p, p + v * dt_s) + c)
            if not precord.covers(self.durable_windows.get(name), step):
                ax.out = replace(ax.out, duty=0.0)
                held.append(name)
        if held and self.save_error:
            self.latch(self._state_fault(now_s))
        self._note_applied()

    def motion_accepted(self) -> None:
        """A moving command passed its checks (under the rotator's lock): if an axis
        needs a record ahead of motion, its reply may wait for it (:meth:`motion_ticket`).
        Not while such an axis drives with the newest record on disk and no write
        failed: the disk has just proved itself on this motion, which is what the wait
        finds out from standing (a write failing now stops the motion with the state
        fault, said as such). So a Gpredict-style P every second while tracking answers
        at once."""
        recorded = [ax for ax in self.core.axes.values() if precord.needs_record(ax)]
        if self.writer is None or not recorded:
            return
        if not self.save_error and self.durable is self.record and any(ax.out.duty != 0.0 for ax in recorded):
            return
        self.motions += 1
        self._ticket.n = self.motions

    def motion_ticket(self) -> int | None:
        """The number of the moving command this thread's last call had accepted (None:
        none, or its rotator needs no record), for :meth:`await_motion_record`; taken once."""
        n = getattr(self._ticket, "n", None)
        self._ticket.n = None
        return n

    def _note_applied(self) -> None:
        """(The tick, after its record.) The moving commands accepted before this tick have
        been applied: they wait for the newest record if it is not yet known on disk."""
        if self._applied[0] == self.motions:
            return
        seq = None if self.writer is None or self.durable is self.record else self.writer.last_seq
        with self._applied_cv:
            self._applied = (self.motions, seq)
            self._applied_cv.notify_all()

    def await_motion_record(self, ticket: int, timeout_s: float) -> tuple[bool | None, str]:
        """Wait (never on the tick, never under the rotator's lock) until the tick has
        applied moving command ``ticket`` and the record it then needed is on disk: (True,
        "") so, or no record was needed; (False, why) its write failed; (None, "") not
        known within ``timeout_s`` (a slow disk, a loop held up)."""
        deadline_s = time.monotonic() + timeout_s
        with self._applied_cv:
            while self._applied[0] < ticket:
                left_s = deadline_s - time.monotonic()
                if left_s <= 0:
                    return None, ""
                self._applied_cv.wait(left_s)
            seq = self._applied[1]
        if seq is None or self.writer is None:
            return True, ""
        return self.writer.outcome(seq, max(0.0, deadline_s - time.monotonic()))

    def refuse_motion(self, now_s: float) -> bool:
        """(Under the rotator's lock.) A moving command's first record failed: latch the
        state fault (every output off, the motion abandoned, so the refused command never
        flies once the disk works again). False if a retry has landed meanwhile (the
        command stands)."""
        self.take_report(now_s)
        if not self.save_error:
            return False
        self.latch(self._state_fault(now_s))
        return True

    def _state_fault(self, now_s: float) -> Fault:
        return Fault("state", None, f"state not saved ({self.save_error}): motion stopped so the saved "
                     "position stays true; retrying", now_s)

    def take_report(self, now_s: float) -> None:
        core = self.core
        assert self.writer is not None
        rep = self.writer.report()
        if rep.durable is not self.durable:
            self.durable = rep.durable
            for payload, windows in self.recent:
                if payload is rep.durable:
                    self.durable_windows = windows
        if rep.error and not self.save_error:
            core.event(f"state not saved: {rep.error} (retrying)")
        elif self.save_error and not rep.error:
            core.event("state saved again")
            if any(f.kind == "state" for f in core.faults):
                # the cause is gone and the record on disk is true again
                core.faults = [f for f in core.faults if f.kind != "state"]
                core.event("state fault cleared: the position record is written again")
        self.save_error = rep.error

    def record_due(self, now_s: float) -> bool:
        core = self.core
        rec = self.record
        if rec is None or self.record_dirty:
            return True
        horizon_s = core.settings.save_interval_s
        windows = self.recent[-1][1]
        for name, ax in core.axes.items():
            saved = rec["axes"][name]
            if saved["uncertainty_deg"] != ax.uncertainty_deg:
                return True
            if precord.standing(ax, core.tracking):
                # at rest: the record should say so (a restart then knows the position)
                shift = self.searches.get(name, (0.0, 0.0))[1]
                if abs(saved["mech_deg"] + shift - ax.meas_deg) > precord.hold_band_deg(ax) or (
                        precord.needs_record(ax) and not precord.known_window(ax, windows[name])):
                    return True
            elif precord.needs_record(ax) and not precord.covers(
                    windows[name], precord.reach(ax, now_s, horizon_s / 2.0, with_target=True)):
                return True
        return False

    def submit_record(self, now_s: float, wait: bool = False) -> bool:
        """Hand the writer a record of the present state (``wait``: write it now)."""
        core = self.core
        assert self.writer is not None
        axes: dict[str, Any] = {}
        windows: dict[str, tuple[float, float]] = {}
        for name, ax in core.axes.items():
            try:
                cal = ax.hw.sensor.calibration()
            except Exception:
                cal = {}
            is_standing = precord.standing(ax, core.tracking)
            windows[name] = precord.window(ax, now_s, core.settings.save_interval_s, is_standing)
            # a reference search works in a temporary frame; the record keeps the true one
            shift = self.searches.get(name, (0.0, 0.0))[1]
            axes[name] = {"mech_deg": ax.meas_deg - shift, "rate_deg_per_s": ax.rate_deg_per_s,
                          "moving": not is_standing,
                          "window_deg": [windows[name][0] - shift, windows[name][1] - shift],
                          "calibration": cal, "coast_deg": list(ax.law.coast_deg),
                          "uncertainty_deg": ax.uncertainty_deg}
            if name in self.searches:
                axes[name]["procedure"] = "reference search"
        payload = {"profile": core.caps.name, "axes": axes}
        self.record, self.record_dirty = payload, False
        self.recent.append((payload, windows))
        if wait:
            ok = self.writer.write_now(payload)
        else:
            self.writer.submit(payload)
            ok = True
        self.take_report(now_s)
        return ok
