"""SPID controllers: Rot2Prog, Rot1Prog and MD-01/02 in ROT2 mode (protocols.md §4).

Binary 13-byte commands, no checksum; frames in urc.wire.spid. What each session does:

* status (K 0x1F) and stop (K 0x0F): answer at once with the position, 12 bytes
  (Rot2Prog, MD) or 5 bytes (Rot1Prog); stop first stops both axes.
* set (K 0x2F): Rot2Prog/MD go to (az, el), Rot1Prog to az (elevation untouched).
  Rot1Prog/Rot2Prog send no answer; MD-01/02 answers with the position (Hamlib 903
  reads one).
* move (K 0x14, MD-01/02 only): jog the axes named by the direction bits (left/right
  azimuth, up/down elevation) at full speed until stop; no answer.

Positions are reported in the controller's frame: azimuth with its overturn (e.g. 400.0
on a 450 deg rotator, -10.0 below north on a -180..540 one), in tenths of a degree; PH/PV
report ``resolution_deg``. A set azimuth within the rotator's range names that pose
(overturn included); outside it the service's rule applies (a negative down to -180 is
a compass bearing, anything else is refused: left unanswered, nothing moves).

Framing: a command starts with 'W' and is accepted only when its 13th byte is 0x20 and
its fields are well formed, so after noise or a half frame the next whole frame is found
again and nothing is ever done on a partial frame. SPID has no error reply: rejected or
malformed input is logged and (like the real controller) left unanswered.
"""

from __future__ import annotations

from ..errors import CommandRejected, UrcError
from ..model.effects import Effects
from .base import MAX_PENDING_BYTES, RotatorPort, bad_input_log, internal_error, protocol_logger
from ..wire import spid as codec
from .poses import ExtendedTarget, extended_pose_deg
from ..wire.spid import SpidCommand, SpidFrameError

log = protocol_logger("spid")
bad_input = bad_input_log("spid")

_MOVES = ((codec.DIR_LEFT, "az", -1), (codec.DIR_RIGHT, "az", +1),
          (codec.DIR_UP, "el", +1), (codec.DIR_DOWN, "el", -1))


class _SpidSession:
    variant = "rot2"
    default_resolution_deg = 0.5

    def __init__(self, rotator: RotatorPort, *, resolution_deg: float | None = None):
        self.rotator = rotator
        self.closed = False
        res = self.default_resolution_deg if resolution_deg is None else float(resolution_deg)
        self.pulses = codec.resolution_to_pulses(res)
        self._buf = b""
        self._targets = ExtendedTarget(rotator, named=True)   # Rot1Prog: az-only sets keep elevation

    # ------------------------------------------------------------------ Session
    def receive(self, data: bytes) -> Effects[list[bytes]]:
        buf = self._buf + data
        if len(buf) > MAX_PENDING_BYTES:   # cannot happen (rest < 13 bytes); kept as a bound
            log.warning("input buffer over %d bytes dropped", MAX_PENDING_BYTES)
            buf = buf[-codec.COMMAND_LEN:]
        frames, self._buf, dropped = codec.split_frames(buf, lambda f: codec.plausible(f, self.variant))
        if dropped:
            bad_input.warning("discarded %d byte(s) that were not part of a whole 13-byte frame", dropped)
        out: list[bytes] = []
        for frame in frames:
            try:
                cmd = codec.decode_command(frame, self.variant, (self.pulses, self.pulses))
                reply = yield from self._execute(cmd)
            except SpidFrameError as exc:   # plausible() let it through: should not happen
                bad_input.warning("frame %s ignored: %s", frame.hex(" "), exc)
                continue
            except UrcError as exc:         # SPID has no error reply: the client times out
                log.warning("frame %s failed: %s", frame.hex(" "), exc)
                continue
            except Exception:               # a bug: logged and counted, no reply
                internal_error(log, "spid", "frame %s failed", frame.hex(" "))
                continue
            if reply is not None:
                out.append(reply)
        return out

    def tick(self, now_s: float) -> list[bytes]:
        return []

    # ----------------------------------------------------------------- commands
    def _execute(self, cmd: SpidCommand) -> Effects[bytes | None]:
        if cmd.kind == "status":
            return self._position()
        if cmd.kind == "stop":
            yield from self._targets.stop()
            return self._position()
        if cmd.kind == "set":
            yield from self._set(cmd)
            return self._position() if self.variant == "md01" else None
        if cmd.kind == "move":
            yield from self._move(cmd.direction)
        return None

    def _set(self, cmd: SpidCommand) -> Effects[None]:
        assert cmd.az_deg is not None
        try:
            yield from self._goto(cmd.az_deg, cmd.el_deg)
        except CommandRejected as exc:
            bad_input.warning("set az %.1f el %s refused (%s): %s", cmd.az_deg,
                        "-" if cmd.el_deg is None else f"{cmd.el_deg:.1f}", exc.reason, exc)

    def _goto(self, az: float, el: float | None) -> Effects[None]:
        """el None (Rot1Prog): elevation keeps its target. An azimuth outside the range
        is refused by the service (the one rule, README), never folded into 0..360:
        Hamlib's 639 is not 279."""
        yield from self._targets.goto(az, el)

    def _move(self, direction: int) -> Effects[None]:
        wanted = [(axis, sign) for bit, axis, sign in _MOVES if direction & bit]
        axes = [a for a, _ in wanted]
        if direction & ~0x0F or not wanted or len(set(axes)) != len(axes):
            bad_input.warning("move direction 0x%02X ignored: expected left/right and/or up/down bits", direction)
            return
        for axis, sign in wanted:
            try:
                yield from self._targets.move(axis, sign, 1.0)   # no target: it rests where it stops
            except CommandRejected as exc:
                # (up/down on a single-axis rotator: reason no_axis. SPID frames have no
                # error answer, so it is ignored, as a Rot2Prog with no elevation
                # rotator drives nothing; set frames turn the azimuth, el left aside)
                bad_input.warning("move %s %+d refused (%s): %s", axis, sign, exc.reason, exc)

    def _position(self) -> bytes:
        az, el = extended_pose_deg(self.rotator.status())
        return codec.encode_rot2_position(az, el, self.pulses, self.pulses)


class Rot2ProgSession(_SpidSession):
    """SPID Rot2Prog (Hamlib 901). Option ``resolution_deg`` (0.5): reported as PH/PV
    and used to decode set frames whose PH/PV bytes are 0."""

    variant = "rot2"
    default_resolution_deg = 0.5


class Md01Session(_SpidSession):
    """SPID MD-01/02 in ROT2 mode (Hamlib 903): Rot2Prog plus a position answer to set
    and the move command. Option ``resolution_deg`` (0.5)."""

    variant = "md01"
    default_resolution_deg = 0.5


class Rot1ProgSession(_SpidSession):
    """SPID Rot1Prog (Hamlib 902): azimuth only, 5-byte answers in whole degrees.
    Option ``resolution_deg`` (1): kept for symmetry; Rot1Prog frames carry no PH."""

    variant = "rot1"
    default_resolution_deg = 1.0

    def _position(self) -> bytes:
        az, _ = extended_pose_deg(self.rotator.status())
        return codec.encode_rot1_position(az)
