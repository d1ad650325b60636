"""The G4JNT PIC rotator controller's serial stream and constants, on urc.

Every ``interval_s`` (0.5 s) ``tick(now_s)`` emits ``b059.3,p1415`` CR LF: ``b`` the
bearing (the rotator's azimuth, in its own frame, 0.1 deg) and ``p`` the linearised pot
reading P the controller would compute at that bearing, P = 4096 N / (2048 - N) from the
10-bit count N of the loaded pot (see g4jnt_codec; the simulator's pot is the same model).

Constants, settable over serial and answered with the value stored (``Z12.5`` ->
``Z12.5``; bare ``Z`` reports, ``?`` reports all four):

* ``M`` slope (deg per P unit) and ``C`` intercept (deg) of the two-point calibration,
  ``Z`` zero offset (deg): bearing = M x P + C + Z. They start from the rotator's own
  pot calibration when its sensor reports one (the simulated G4JNT pot does), else
  M = 360/4096, C = 0, Z = 0.
* ``K`` (deg): the slow/fast threshold: the original drives fast while the error is
  larger than K and pulses the motor slowly within it. Default 5.

On urc the position comes from the rotator service, which owns the sensor calibration
and picks slow or fast drive itself, so these constants are this connection's: they
change how P is derived from the bearing (M, C, Z), and are stored and echoed (K); they
do not re-reference or re-tune the rotator.

Commands: ``G123.4`` go to bearing 123.4 (elevation keeps its target), ``G123.4,45.0``
go to both -> echoed ``G123.4`` / ``G123.4,45.0``; ``S`` stop -> ``S``. Errors: one line
``? <what was expected>, got '<what came>'``; nothing moves on an error.
"""

from __future__ import annotations

from ..errors import CommandRejected
from .base import MAX_PENDING_BYTES, RotatorPort, protocol_logger
from . import g4jnt_codec as codec
from .g4jnt_codec import G4jntCommand, G4jntSyntaxError
from .lines import LineSplitter, next_due_s
from .poses import ExtendedTarget, extended_pose_deg

log = protocol_logger("g4jnt")

DEFAULT_K_DEG = 5.0


def _rotator_pot_calibration(rotator: RotatorPort) -> dict[str, float]:
    """M, C, Z of the rotator's azimuth pot when its sensor reports them (read only)."""
    try:
        cal = rotator.hw.axis("az").sensor.calibration()  # type: ignore[attr-defined]
        got = {k: float(cal[k]) for k in ("M", "C", "Z")}
    except Exception:
        return {}
    return got if got["M"] > 0 else {}


class G4jntSession:
    wants_tick = True  # streams position lines (see base.Session)

    def __init__(self, rotator: RotatorPort, *, interval_s: float = 0.5):
        if not interval_s > 0:
            raise ValueError(f"interval_s must be > 0, got {interval_s!r}")
        self.rotator = rotator
        self.closed = False
        self.interval_s = float(interval_s)
        self.constants = {"Z": 0.0, "C": 0.0, "K": DEFAULT_K_DEG, "M": 360.0 / 4096.0}
        self.constants.update(_rotator_pot_calibration(rotator))
        self._lines = LineSplitter(MAX_PENDING_BYTES, backspace=True, log=log)
        self._targets = ExtendedTarget(rotator)
        self._next_s: float | None = None

    # ------------------------------------------------------------------ Session
    def receive(self, data: bytes) -> list[bytes]:
        out: list[bytes] = []
        for item in self._lines.feed(data):
            if item.overflowed:
                out.append(codec.line(f"? line too long: expected at most {MAX_PENDING_BYTES} characters"))
                continue
            try:
                cmd = codec.parse_line(item.text)
                if cmd is not None:
                    out.append(self._execute(cmd))
            except G4jntSyntaxError as exc:
                log.info("rejected %r: %s", item.text[:80], exc)
                out.append(codec.line(f"? {exc}"))
            except CommandRejected as exc:
                log.info("rotator refused %r: %s", item.text[:80], exc)
                out.append(codec.line(f"? refused ({exc.reason}): {exc}"))
            except Exception as exc:
                log.exception("line %r failed", item.text[:80])
                out.append(codec.line(f"? internal error: {exc}"))
        return out

    def tick(self, now_s: float) -> list[bytes]:
        nxt = next_due_s(self._next_s, now_s, self.interval_s)
        if nxt is None:
            return []
        self._next_s = nxt
        return [self.stream_line()]

    def stream_line(self) -> bytes:
        bearing = extended_pose_deg(self.rotator.status())[0]
        k = self.constants
        return codec.stream_line(bearing, codec.p_for_bearing(bearing, k["M"], k["C"], k["Z"]))

    # ----------------------------------------------------------------- commands
    def _execute(self, cmd: G4jntCommand) -> bytes:
        if cmd.kind == "const":
            if cmd.value is not None:
                self.constants[cmd.name] = cmd.value
            return codec.line(codec.format_constant(cmd.name, self.constants[cmd.name]))
        if cmd.kind == "all":
            return codec.line(" ".join(codec.format_constant(n, self.constants[n]) for n in codec.CONSTANTS))
        if cmd.kind == "stop":
            self._targets.stop()
            return codec.line("S")
        assert cmd.kind == "goto" and cmd.az_deg is not None
        self._targets.goto(cmd.az_deg, cmd.el_deg)
        echo = f"G{cmd.az_deg:g}" + ("" if cmd.el_deg is None else f",{cmd.el_deg:g}")
        return codec.line(echo)
