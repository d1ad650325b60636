"""The bridge's client engine: what to send to the controller next, and what its
answers mean. Sans-I/O (h11 style): no sockets, no threads, no clock of its own.

The control tick posts per-axis targets (:meth:`BridgeClient.post`) and reads the latest
report (:meth:`BridgeClient.reading`); the link runner (:mod:`.link`, or a simulated
link on the virtual clock in benchmarks) asks :meth:`next_exchange`, writes it, and
feeds the answer back. Both sides only touch state under one lock.

Rules for slow and quirky controllers:

* one exchange at a time; after a set or stop the next exchange is a poll (a GS-232
  answers C2 only between commands), and polls run as fast as the link allows
  (``poll_interval_s`` at least, and no faster than a control tick), so the report is
  never older than one round trip;
* a target is sent only when it changes what the controller would do: quantised to
  its set resolution (a G-5500's relays must not chatter on sub-degree changes);
* ``stop_before_set``: for controllers that ignore a new target while moving, a stop
  goes out first;
* an answer urc did not fully understand moves nothing: no set goes out until a good
  position report has come back, and ``max_failures`` bad or missing answers in a row
  drop the link (reconnect, with the position unknown until the first good report).

Controllers that report their own status (``Dialect.status_interval_s``, the SatNOGS
firmware's GS/GE) are read every so often: no target goes out unless a fresh status
says the controller is well, and an error it reports is :meth:`BridgeClient.controller_fault`
(the rotator's guard latches it, with the controller's own words). A controller told to
home (:meth:`BridgeClient.request_home`) may say nothing for ``Dialect.homing_s``: its
position is unknown meanwhile (the reason says it homes), and silence is no failure.

(Over 600 lines on purpose: one engine under one lock, since what goes out next, a stop,
a home, a status read, a move, a target or a poll, is decided on all of its state at once.)
"""

from __future__ import annotations

import collections
import logging
import math
import threading
from dataclasses import dataclass

from ...errors import SensorError
from .dialects import ControllerError, ControllerStatus, Dialect, Exchange, ReplyError

log = logging.getLogger("urc.bridge")

AXES = ("az", "el")
#: a fast link (a pty, a LAN) is polled no faster than a control tick can use it
MIN_POLL_INTERVAL_S = 0.02
#: targets go out at most this often (a tracker refreshes its setpoint every 0.2 s; a
#: controller re-plans at every new target)
MIN_SET_INTERVAL_S = 0.2
#: smoothing of the measured round trip (exponential moving average weight)
LATENCY_GAIN = 0.2
#: between reports, the position moves on at the last reported speed for at most this
#: many poll periods (then it waits for the next report)
EXTRAPOLATE_PERIODS = 1.0
#: a controller spoken to in compass azimuth (Easycomm, rotctld) takes a target in
#: 0..360 on the turn nearest in travel (README: Angles): a goal further than this from
#: where it is might be taken on the other turn, so it is approached through waypoints
#: WAYPOINT_STEP_DEG apart, each unambiguous (unwinding 370 -> 0 is 250, 130, 10, 0)
NEAREST_TURN_SAFE_DEG = 150.0
WAYPOINT_STEP_DEG = 120.0
#: the speed to extrapolate with is measured over the reports of this long
SPEED_WINDOW_S = 1.0
#: a controller's own move is handed over to a goto this long (at its speed) before
#: the jog's end, on top of the link's delays: it brakes and settles on its own loop
NATIVE_MOVE_HANDOVER_S = 1.0
#: while a controller homes its status is asked this often: it reads no input then and
#: an Arduino keeps only 64 bytes of it (HardwareSerial's receive buffer), so a few
#: short questions, not a poll per timeout that would overflow it into broken lines
HOMING_POLL_S = 3.0


@dataclass(frozen=True)
class ClientOptions:
    #: no reply within this long is a failure; None = the protocol's default
    timeout_s: float | None = None
    #: poll no faster than this (0 = as fast as the link allows)
    poll_interval_s: float = 0.0
    #: consecutive bad or missing answers that count as a lost link
    max_failures: int = 3
    #: send a stop before a new target while the controller is moving
    stop_before_set: bool = False
    #: the rotator's elevation reaches past 90 (it can fly over the top): a sky-frame
    #: report (Easycomm, rotctld) is then unfolded by continuity (see _unfold)
    over_top: bool = False



def folds_at_zenith(dialect: Dialect, over_top: bool) -> bool:
    """Reports are sky directions (compass azimuth, el 0..90) of a rotator that flies
    over the top: a report cannot tell the side of the zenith (the client follows it
    from report to report; the state records keep it across a restart)."""
    return bool(over_top and dialect.az_modulo_deg)

class BridgeClient:
    def __init__(self, dialect: Dialect, options: ClientOptions | None = None):
        self.dialect = dialect
        self.options = options or ClientOptions()
        self.timeout_s = self.options.timeout_s or dialect.timeout_s
        self._lock = threading.Lock()
        # what the control tick wants: a target per axis, None = stopped
        self._wanted: dict[str, float | None] = {"az": None, "el": None}
        self._stop_wanted = False
        self._hold: list[float | None] = [None, None]
        # jogs (see post_move) per axis: (end, speed fraction, speed, handed over to a
        # goto near its end), None = no jog
        self._jog: list[tuple[float, float, float, bool] | None] = [None, None]
        #: the controller's own move running now: (axis index, direction, speed fraction)
        self._native: tuple[int, int, float] | None = None
        # what the controller was last told
        self._sent_pose: tuple[float, float] | None = None
        self._waypoint: float | None = None   # compass azimuth on the way to a far goal
        #: the azimuth on its turn as the rotator has it (its estimate, unwound by
        #: continuity from the saved state): (value, the compass report it went with)
        self._az_turn: tuple[float, float] | None = None
        self._stopped = True
        #: a stop is the last command the controller got (not merely nothing sent yet)
        self._told_stop = False
        self._after_command = False
        # what it last reported
        self._pos: tuple[float, float] | None = None
        self._prev_pos: tuple[float, float] | None = None
        self._pos_t_s = -math.inf
        self._prev_t_s = -math.inf
        self._trusted = False
        #: the last unfolded report (kept across a lost link): which side of the zenith
        #: the antenna is on; (None, el) = only the side is known (a saved state)
        self._fold_ref: tuple[float | None, float] | None = None
        self._failures = 0
        self._next_poll_s = -math.inf
        self._link_up = False
        self._error = "not connected yet"
        #: what went wrong since the last good report (the reason a fault shows): "link
        #: lost: ..." (the port closed or failed), "no reply from the controller (...)"
        #: (silence), "answer not understood (...)" (garbage); "" = nothing
        self._cause = ""
        self._rtt_s: float | None = None
        self._interval_s: float | None = None
        self._last_gap_s = 0.0
        self._last_set_s = -math.inf
        self._recent: collections.deque[tuple[float, tuple[float, float]]] = collections.deque()
        self.identity: str | None = None
        #: the controller's own status (Dialect.status): the last read, and when
        self._ctl_status: ControllerStatus | None = None
        self._ctl_status_t_s = -math.inf
        self._ctl_error: ControllerError | None = None
        self._need_error = False
        self._next_status_s = -math.inf
        self._home_wanted = False
        #: when urc told it to home (None: not homing as far as urc knows)
        self._homing_since_s: float | None = None
        self._withheld_reason = ""
        self.counts = {"exchanges": 0, "timeouts": 0, "garbage": 0, "sets": 0, "stops": 0, "moves": 0,
                       "reconnects": 0, "statuses": 0, "homes": 0, "withheld": 0}

    # ============================================================ control-tick side
    def post(self, axis: str, target_deg: float | None) -> None:
        """The target for one axis (its mechanical frame), or None to stop it."""
        with self._lock:
            self._post(axis, target_deg)

    def _post(self, axis: str, target_deg: float | None) -> None:
        i = AXES.index(axis)
        if target_deg is None and self._wanted[axis] is not None and self._pos is not None:
            # one axis stopped while the other goes on: it holds where it is now (on
            # the turn it was sent to: a compass report names no turn)
            self._hold[i] = self._near(i, self._pos[i], self._wanted[axis])
        if target_deg is not None:
            self._hold[i] = None
        self._wanted[axis] = target_deg
        self._jog[i] = None
        if all(self._wanted[a] is None for a in AXES):
            self._stop_wanted = not self._stopped

    def note_position(self, axis: str, mech_deg: float) -> None:
        """The rotator's estimate of ``axis`` on its turn (a compass report names none)."""
        if axis != "az":
            return
        with self._lock:
            if self._pos is not None:
                self._az_turn = (mech_deg, self._pos[0])

    def _az_on_its_turn(self) -> float | None:
        """The latest azimuth report on the turn the rotator has the axis on."""
        if self._pos is None:
            return None
        if self._az_turn is None:
            return self._pos[0]
        mech, raw = self._az_turn
        return self._near(0, self._pos[0], mech + (self._pos[0] - raw))

    def post_move(self, axis: str, end_deg: float, speed_frac: float, rate_deg_per_s: float) -> None:
        """A jog of one axis towards ``end_deg`` (the soft limit or a keep-out zone's
        edge), at ``speed_frac`` of its top speed (``rate_deg_per_s``). Where the
        protocol has a move of its own (GS-232 R/L/U/D with X1..X4, Easycomm ML..MD or
        VL..VD, rotctld ``M``, MD-01 K 0x14) the controller moves on its own at that
        speed (Easycomm II, MD-01: at its own); urc takes over with a goto to
        ``end_deg`` while the axis is still far enough from it to stop in time (the
        controller's own limits may lie further out). Elsewhere it is a goto to
        ``end_deg`` from the start."""
        with self._lock:
            i = AXES.index(axis)
            jog = self._jog[i]
            self._post(axis, end_deg)
            # the same jog posted again (every tick) keeps its hand-over: once a goto
            # finishes it, no new move starts (the controller overshooting its end
            # would otherwise be sent moving back)
            handed = jog is not None and jog[0] == end_deg and jog[3]
            self._jog[i] = (end_deg, speed_frac, rate_deg_per_s, handed)

    def reading(self, axis: str, now_s: float | None = None) -> float:
        """The axis' latest reported position; SensorError when there is none to trust
        (link down, nothing reported yet, or the last report older than the link's
        whole retry budget)."""
        with self._lock:
            # (a controller that reports an error and no position: its own words first)
            ctl = self._ctl_fault_text()
            ctl = f"{ctl}; " if ctl else ""
            if not self._link_up or self._pos is None:
                raise SensorError(f"bridge {self.dialect.name}: {ctl}{self._error}")
            i = AXES.index(axis)
            if now_s is None:
                return self._pos[i]
            age_s = now_s - self._pos_t_s
            if age_s > self.stale_after_s:
                raise SensorError(f"bridge {self.dialect.name}: {ctl}"
                                  + (f"{self._cause} (no position report for {age_s:.1f} s)" if self._cause
                                     else f"no position report for {age_s:.1f} s"))
            pos = self._pos[i]
            est = pos + self._speed(i) * min(max(age_s, 0.0), EXTRAPOLATE_PERIODS * self._period_s())
            if self._sent_pose is not None and not self._stopped:
                # the controller stops at its target: never estimate past it
                target = self._near(i, self._sent_pose[i], pos)
                if (est - target) * (pos - target) <= 0:   # (reached, or would pass it)
                    est = target
            return est

    def _near(self, i: int, value_deg: float, ref_deg: float) -> float:
        """``value_deg`` on the turn nearest ``ref_deg`` (compass azimuth names no turn)."""
        m = self.dialect.az_modulo_deg if i == 0 else None
        return value_deg if not m else ref_deg + (value_deg - ref_deg + m / 2.0) % m - m / 2.0

    def _unfold(self, az: float, el: float) -> tuple[float, float]:
        """A sky-frame report (Easycomm, rotctld: compass az, el 0..90 from urc's own
        emulation; mechanical az/el from Hamlib behind a GS-232) names one of two poses:
        (az, el), or the antenna over the top at (az + 180, 180 - el). The one nearer the
        last report it is; the two lie 180 deg of azimuth apart near the zenith, so
        continuity decides even there. With no report yet: the saved side, else as
        reported (urc's own emulation never reports past 90; a controller that does
        reports its mechanical frame)."""
        m = self.dialect.az_modulo_deg
        az = az % m
        over = ((az + 180.0) % m, 180.0 - el)
        ref = self._fold_ref
        if ref is None:
            pose = (az, el)
        elif ref[0] is None:
            pose = (az, el) if (el > 90.0) == (ref[1] > 90.0) else over
        else:
            def dist(p: tuple[float, float]) -> float:
                return abs(self._near(0, p[0], ref[0]) - ref[0]) + abs(p[1] - ref[1])
            pose = min(((az, el), over), key=dist)
        self._fold_ref = pose
        return pose

    def assume_over_top(self, over_top: bool) -> None:
        """The side of the zenith a saved state names (start-up, before any motion):
        reports already unfolded to the other side are turned over."""
        if not self.folds_at_zenith():
            return
        with self._lock:
            ref_el = 135.0 if over_top else 45.0
            if self._fold_ref is not None and (self._fold_ref[1] > 90.0) == over_top:
                return
            self._fold_ref = (None, ref_el)
            m = self.dialect.az_modulo_deg

            def turn(p: tuple[float, float]) -> tuple[float, float]:
                return ((p[0] + 180.0) % m, 180.0 - p[1])
            if self._pos is not None:
                self._pos = turn(self._pos)
                self._fold_ref = self._pos
            if self._prev_pos is not None:
                self._prev_pos = turn(self._prev_pos)
            self._recent = collections.deque((t, turn(p)) for t, p in self._recent)

    def folds_at_zenith(self) -> bool:
        return folds_at_zenith(self.dialect, self.options.over_top)

    def over_top(self) -> bool:
        """The antenna is over the top (its last report unfolded past el 90)."""
        with self._lock:
            return self._fold_ref is not None and self._fold_ref[1] > 90.0

    def _period_s(self) -> float:
        return max(self._interval_s or 0.0, self.options.poll_interval_s)

    def _speed(self, i: int) -> float:
        """The axis speed over the recent reports, or 0 unless it moved at least two
        report steps in them: a report flickering by one step (a whole degree on a
        GS-232) is no motion to extrapolate."""
        if len(self._recent) < 2:
            return 0.0
        (t0, p0), (t1, p1) = self._recent[0], self._recent[-1]
        moved = p1[i] - p0[i]
        modulo = self.dialect.az_modulo_deg if i == 0 else None
        if modulo:  # compass azimuth: 359.9 -> 0.1 is 0.2 deg, not -359.8
            moved = (moved + modulo / 2.0) % modulo - modulo / 2.0
        if t1 - t0 <= 0 or abs(moved) < 2.0 * self.dialect.report_resolution_deg:
            return 0.0
        return moved / (t1 - t0)

    @property
    def stale_after_s(self) -> float:
        return (self.options.max_failures + 1) * (self.timeout_s + 0.3) + self.options.poll_interval_s

    def latency_s(self) -> float:
        """The measured round trip (how late a target reaches the controller)."""
        with self._lock:
            return self._rtt_s or 0.0

    def sample_interval_s(self) -> float:
        """How far apart reports come: the usual spacing, or the last gap if longer (a
        busy host or a retry: the report after it may have moved that much further)."""
        with self._lock:
            return max(self._interval_s or self.timeout_s, self._last_gap_s, self.options.poll_interval_s)

    def error(self) -> str:
        with self._lock:
            return "" if self._link_up and self._trusted else self._error

    def controller_fault(self) -> str:
        """The error the controller itself reports (its last status said so), or ""."""
        with self._lock:
            text = self._ctl_fault_text()
            return f"bridge {self.dialect.name}: {text}" if text else ""

    def _ctl_fault_text(self) -> str:
        st, err = self._ctl_status, self._ctl_error
        if st is None or not st.error:
            return ""
        if err is None:
            return f"the controller reports an error (status {st.code}); its error code not read yet"
        return f"the controller reports {err.text} (status {st.code}, error {err.code})"

    def homing(self) -> bool:
        with self._lock:
            return self._homing_since_s is not None

    def request_home(self) -> str:
        """Have the controller home on its endstops: "" when it will be told (its next
        exchange), else why not (the protocol has no such command)."""
        if self.dialect.home(False) is None:
            return f"{self.dialect.name}: the controller has no homing command"
        with self._lock:
            self._home_wanted = True
        return ""

    def _homing_text(self, now_s: float) -> str:
        since = self._homing_since_s if self._homing_since_s is not None else now_s
        return (f"controller homing ({now_s - since:.0f} s so far): it answers nothing until it has found "
                f"its endstops, up to {self.dialect.homing_s:g} s; the position is unknown until then")

    def _ctl_blocks(self, now_s: float) -> str:
        """Why no target may go out now because of the controller's own status ("" = none)."""
        d = self.dialect
        if not d.status_interval_s:
            return ""
        if self._homing_since_s is not None:
            return "the controller is homing"
        st = self._ctl_status
        if st is None:
            return "the controller's status not read yet"
        if st.error:
            return "the controller reports an error"
        if now_s - self._ctl_status_t_s > 2.0 * d.status_interval_s + self.timeout_s:
            return f"the controller's status not read for {now_s - self._ctl_status_t_s:.1f} s"
        return ""

    # ================================================================= link side
    def link_up(self, now_s: float) -> None:
        with self._lock:
            self._link_up, self._trusted, self._failures = True, False, 0
            self._pos, self._prev_pos = None, None
            self._recent.clear()
            # until a good report comes, what broke the link stays the reason
            self._error = self._cause or "no position report yet"
            self._next_poll_s = -math.inf
            # the controller may have been told something urc no longer wants
            self._sent_pose, self._told_stop = None, False
            self._after_command = False
            # its status is read again before any target (what it said is kept till then)
            self._ctl_status_t_s, self._next_status_s = -math.inf, -math.inf

    def link_down(self, reason: str, now_s: float, failures: bool = False) -> None:
        """The link went away (``reason``: the port's error), or is being reopened
        after ``max_failures`` bad or missing answers (``failures``: their cause stays
        the reason: silence is no reply, garbage not understood, not a lost link)."""
        with self._lock:
            if not failures:
                self._cause = f"link lost: {reason}"
            if self._link_up:
                log.error("bridge %s: %s", self.dialect.name, self._cause if not failures else
                          f"{reason}: reopening the link")
                self.counts["reconnects"] += 1
            self._link_up, self._trusted = False, False
            self._pos = None
            self._error = self._cause or f"link lost: {reason}"
            # tell it to stop as soon as it is back, unless a target is wanted then
            self._stopped = False
            self._stop_wanted = True

    def reconnecting(self, attempt: int, attempts: int, reason: str) -> None:
        """An attempt to reopen the link failed; the loss reason stays in front."""
        with self._lock:
            lost = self._cause or "link lost"
            self._error = f"{lost}; reconnect attempt {attempt} of {attempts} failed ({reason})"
            if attempt > attempts:
                self._error = f"{lost}; gave up after {attempts} reconnect attempts (restart urc)"

    def wait_report(self, timeout_s: float) -> bool:
        """Block (not on the tick: at start-up) until a first position report came."""
        import time
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            with self._lock:
                if self._pos is not None:
                    return True
            time.sleep(0.01)
        return False

    def next_exchange(self, now_s: float) -> tuple[Exchange | None, float]:
        """(the exchange to run now, or None and how long to wait before asking again)."""
        with self._lock:
            d = self.dialect
            # homing and not answering yet: it reads no input, so nothing but a status
            # question now and then (a stop waits: it could not reach it before either)
            silent = self._homing_since_s is not None and self._ctl_status is None
            if not silent and (self._stop_wanted or (all(self._wanted[a] is None for a in AXES) and not self._stopped)):
                # a stop always goes out at once, understood or not
                self._stop_wanted, self._sent_pose = False, None
                return self._stop_first(d)
            ctl = self._controller_exchange(d, now_s)
            if ctl is not None:
                return ctl
            if silent:
                self._after_command = False
                return None, max(0.0, self._next_status_s - now_s)
            blocked = self._ctl_blocks(now_s)
            native = self._native_move() if not blocked else None
            if native is not None:
                if native != self._native and self._trusted and not self._after_command:
                    if d.stop_around_move and not self._told_stop:
                        # (also when urc sent nothing yet: it may be moving on its own)
                        return self._stop_first(d)
                    ex = d.move(AXES[native[0]], native[1], native[2])
                    # a move replaces the target the controller had: the pose after it is sent anew
                    self._native, self._sent_pose, self._stopped, self._after_command = native, None, False, True
                    self._told_stop = False
                    self.counts["moves"] += 1
                    return ex, 0.0
                pose = None  # moving on its own: only polls until urc takes over
            else:
                pose = self._pose_to_send()
            if pose is not None and blocked:
                if blocked != self._withheld_reason:
                    log.warning("bridge %s: target %s withheld: %s", d.name, pose, blocked)
                    self.counts["withheld"] += 1
                self._withheld_reason = blocked
                pose = None
            elif pose is not None:
                self._withheld_reason = ""
            if pose is not None and self._trusted and not self._after_command and \
                    now_s >= self._last_set_s + MIN_SET_INTERVAL_S:
                if (self.options.stop_before_set and self._moving()
                        or d.stop_around_move and self._native is not None) and not self._stopped:
                    return self._stop_first(d)
                self._sent_pose, self._stopped, self._after_command = pose, False, True
                self._native, self._told_stop = None, False
                self._last_set_s = now_s
                self.counts["sets"] += 1
                return d.goto(*pose), 0.0
            if now_s >= self._next_poll_s or self._after_command:
                self._after_command = False
                self._next_poll_s = now_s + max(self.options.poll_interval_s, MIN_POLL_INTERVAL_S)
                return d.poll(), 0.0
            return None, max(0.0, self._next_poll_s - now_s)

    def _controller_exchange(self, d: Dialect, now_s: float) -> tuple[Exchange, float] | None:
        """A home, a status or an error read, when one is due (controllers that have them)."""
        if self._home_wanted:
            self._home_wanted = False
            ex = d.home(self._ctl_status is not None and self._ctl_status.error)
            if ex is not None:
                # from here its position is unknown and its silence expected
                self._homing_since_s = now_s
                self._pos, self._prev_pos, self._trusted = None, None, False
                self._recent.clear()
                self._sent_pose, self._stopped, self._native = None, True, None
                self._after_command = False
                self._ctl_status, self._ctl_error, self._need_error = None, None, False
                self._next_status_s = now_s + HOMING_POLL_S
                self._error = self._homing_text(now_s)
                self.counts["homes"] += 1
                log.warning("bridge %s: told the controller to home (%r)", d.name, ex.request)
                return ex, 0.0
        if not d.status_interval_s or self._after_command or now_s < self._next_status_s and not self._need_error:
            return None
        if self._need_error:
            ex = d.error_query()
            self._need_error = False
            if ex is not None:
                return ex, 0.0
        if now_s < self._next_status_s:
            return None
        ex = d.status()
        if ex is None:
            return None
        self._next_status_s = now_s + (HOMING_POLL_S if self._homing_since_s is not None else d.status_interval_s)
        return ex, 0.0

    def _stop_first(self, d: Dialect) -> tuple[Exchange, float]:
        """A stop (before a new target or move: a poll follows it, then the command)."""
        self._stopped, self._after_command, self._native, self._told_stop = True, True, None, True
        self.counts["stops"] += 1
        return d.stop(), 0.0

    def _native_move(self) -> tuple[int, int, float] | None:
        """The controller's own move a jog should run now, or None (no jog, no such
        command, the other axis still on its way, or too near the jog's end: urc stops
        it there with a goto, in time for the speed, the link's round trip and two
        report periods)."""
        if self._pos is None:
            return None
        d = self.dialect
        for i, jog in enumerate(self._jog):
            if jog is None or jog[3]:
                continue
            end, speed_frac, rate, _ = jog
            other = 1 - i
            held = self._wanted[AXES[other]]
            if held is not None and d.has_el and abs(self._near(other, held, self._pos[other]) - self._pos[other]) > \
                    d.resolution_deg[other] + d.report_resolution_deg:
                return None
            pos = self._pos[i]
            to_go = self._near(i, end, pos) - pos
            rate = max(abs(self._speed(i)), rate)
            margin = rate * (2.0 * max(self._period_s(), MIN_POLL_INTERVAL_S) + (self._rtt_s or self.timeout_s)
                             + NATIVE_MOVE_HANDOVER_S) + 2.0 * d.resolution_deg[i] + d.report_resolution_deg
            if d.move(AXES[i], 1, speed_frac) is None:
                return None
            if abs(to_go) <= margin:
                self._jog[i] = (end, speed_frac, rate, True)
                return None
            return (i, 1 if to_go > 0 else -1, speed_frac)
        return None

    def _pose_to_send(self) -> tuple[float, float] | None:
        """The quantised pose to command, or None when the controller already has it."""
        wanted = [self._wanted[a] for a in AXES]
        if all(w is None for w in wanted):
            return None
        pose = []
        for i, w in enumerate(wanted):
            if w is None:
                # a stopped axis holds where it was when told to stop, else where it
                # was sent, else where it is
                held = self._hold[i] if self._hold[i] is not None else \
                    self._sent_pose[i] if self._sent_pose is not None else \
                    (self._pos[i] if self._pos is not None else None)
                if held is None:
                    return None
                w = held
            pose.append(self.dialect.quantise(w, i))
        pose[0] = self._via_waypoint(pose[0])
        if not self.dialect.has_el:
            pose[1] = 0.0
        if self._sent_pose is not None and not self._stopped and \
                all(abs(p - s) < 1e-9 for p, s in zip(pose, self._sent_pose)):
            return None
        return (pose[0], pose[1])

    def _via_waypoint(self, goal_deg: float) -> float:
        """The azimuth to send for ``goal_deg`` (mechanical, on its turn): the goal, or on
        a compass protocol a waypoint towards it while it is too far for the nearest-turn
        rule to name its turn. A waypoint is kept until the axis is near it."""
        p = self._az_on_its_turn() if self.dialect.az_modulo_deg else None
        if p is None:
            self._waypoint = None
            return goal_deg
        if abs(goal_deg - p) <= NEAREST_TURN_SAFE_DEG:
            self._waypoint = None
            return goal_deg
        sign = 1.0 if goal_deg > p else -1.0
        wp = self._waypoint
        if wp is None or not (WAYPOINT_STEP_DEG / 4.0 < (wp - p) * sign <= NEAREST_TURN_SAFE_DEG):
            wp = self.dialect.quantise(p + sign * WAYPOINT_STEP_DEG, 0)
        self._waypoint = wp
        return wp

    def _moving(self) -> bool:
        """The controller may be moving: it has not reported reaching the target it was
        sent, or its reports still change. (Two reports in a row are no guide: whole
        degrees polled every 40 ms repeat while it turns at 10 deg/s, and a target sent
        then was ignored by a controller that takes none while moving.)"""
        if self._pos is None:
            return False
        if self._sent_pose is not None and not self._stopped:
            d = self.dialect
            if any(abs(self._near(i, s, p) - p) > d.resolution_deg[i] + d.report_resolution_deg
                   for i, (s, p) in enumerate(zip(self._sent_pose, self._pos))):
                return True
        return any(self._speed(i) != 0.0 for i in range(len(AXES)))

    def answered(self, ex: Exchange, data: bytes, sent_s: float, now_s: float) -> None:
        """The whole answer to ``ex`` (framed by ``ex.reply``) arrived at ``now_s``."""
        try:
            value = ex.parse(data) if ex.parse is not None else None
        except ReplyError as exc:
            self._bad(f"answer not understood ({ex.kind}: {exc})", "garbage")
            return
        except Exception as exc:  # any parser surprise is garbage too, never motion
            self._bad(f"answer not understood ({ex.kind}: {data!r}: {exc})", "garbage")
            return
        with self._lock:
            self.counts["exchanges"] += 1
            self._failures = 0
            rtt = now_s - sent_s
            self._rtt_s = rtt if self._rtt_s is None else (1 - LATENCY_GAIN) * self._rtt_s + LATENCY_GAIN * rtt
            if ex.kind == "identify":
                self.identity = str(value)
            elif ex.kind == "home":
                pass    # (RESET answers its position before it homes: no report of where it ends)
            elif isinstance(value, ControllerStatus):
                self._status(value, now_s)
            elif isinstance(value, ControllerError):
                self._ctl_error = value
                log.error("bridge %s: %s", self.dialect.name, value.text)
            elif ex.kind == "set" and isinstance(value, int) and value != 0:
                # rotctld refused the target (its own limits): nothing moves; say so
                self._error = f"controller refused the target {ex.pose}: RPRT {value}"
                log.warning("bridge %s: %s", self.dialect.name, self._error)
            elif ex.kind == "move" and isinstance(value, int) and value != 0:
                # rotctld has no move for this rotator: the jog goes on as a goto
                log.warning("bridge %s: move refused (RPRT %d): jogging by goto", self.dialect.name, value)
                self._native = None
                self._jog = [None if j is None else (*j[:3], True) for j in self._jog]
            elif isinstance(value, tuple):
                # sampled somewhere in the round trip: take its middle
                self._position(value, now_s - 0.5 * rtt)

    def _status(self, value: ControllerStatus, now_s: float) -> None:
        self.counts["statuses"] += 1
        was = self._ctl_status
        self._ctl_status, self._ctl_status_t_s = value, now_s
        if value.error:
            # read what it is: at once when newly reported, then again now and then
            self._need_error = self._ctl_error is None or was is None or not was.error or \
                self.counts["statuses"] % 10 == 0
        else:
            self._ctl_error = None
        if self._homing_since_s is not None:
            # it reads input again: its position next
            self._next_poll_s = -math.inf

    def _position(self, value: tuple[float, float | None], now_s: float) -> None:
        if self._homing_since_s is not None:
            log.warning("bridge %s: the controller answers again after %.1f s of homing", self.dialect.name,
                        now_s - self._homing_since_s)
            self._homing_since_s = None
        az, el = value
        if el is None:
            el = 0.0
        if self.options.over_top and self.dialect.az_modulo_deg:
            az, el = self._unfold(az, el)
        if self._pos is not None:
            self._last_gap_s = now_s - self._pos_t_s
            self._prev_pos, self._prev_t_s = self._pos, self._pos_t_s
            self._interval_s = now_s - self._pos_t_s if self._interval_s is None else \
                0.8 * self._interval_s + 0.2 * (now_s - self._pos_t_s)
        self._pos, self._pos_t_s = (az, el), now_s
        self._recent.append((now_s, (az, el)))
        while len(self._recent) > 2 and now_s - self._recent[0][0] > SPEED_WINDOW_S:
            self._recent.popleft()
        self._trusted = True
        self._error = self._cause = ""

    def sent(self, ex: Exchange, now_s: float) -> None:
        """An exchange that has no answer went out."""
        with self._lock:
            self.counts["exchanges"] += 1

    def timed_out(self, ex: Exchange, partial: bytes, now_s: float) -> None:
        with self._lock:
            since = self._homing_since_s
            if since is not None and now_s - since <= self.dialect.homing_s:
                # told to home: its silence is expected, no failure
                self.counts["timeouts"] += 1
                self._error = self._homing_text(now_s)
                return
        hint = ""
        if self._ctl_fault_text():
            hint = "; " + self._ctl_fault_text()
        elif self.dialect.homing_s:
            hint = (f"; it says nothing while it homes, after power-up or a reset, up to "
                    f"{self.dialect.homing_s:g} s" if since is None else
                    f"; homing for {now_s - since:.0f} s, longer than it takes")
        self._bad(f"no reply from the controller ({ex.kind}: no {'complete ' if partial else ''}answer "
                  f"within {self.timeout_s:g} s" + (f", got {partial!r}" if partial else "") + hint + ")", "timeouts")

    def _bad(self, reason: str, count: str) -> None:
        with self._lock:
            self.counts[count] += 1
            self._failures += 1
            # never move on an answer not understood: wait for a good report first
            self._trusted = False
            self._after_command = False
            self._error = self._cause = reason
            if self._native is not None:
                # a controller moving on its own must not run on unwatched
                self._stop_wanted, self._native = True, None
            log.warning("bridge %s: %s", self.dialect.name, reason)

    def link_broken(self) -> bool:
        """Too many bad answers in a row: the runner drops the link and reconnects."""
        with self._lock:
            return self._failures >= self.options.max_failures
