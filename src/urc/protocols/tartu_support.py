"""Small pieces the console-style sessions share (Tartu, SARCNET, G4JNT, SPID, PstRotator).

* :class:`LineSplitter`: bytes -> lines ended by CR, LF or CRLF, bounded, with backspace.
* :func:`extended_pose_deg`: a status in the *extended* frame (azimuth with its cable-wrap
  turns, e.g. 400 on a 450 deg rotator; elevation past 90 when flipped), which is what a
  controller's own display and encoders show and what ``Rotator.goto`` accepts back.
* :class:`TargetMemory`: the other axis' target for single-axis gotos (GOAZ, AZIMUTH ...).

Pure, no I/O. They live here (not in base.py) only because this helper owns these files;
nothing in them is specific to the Tartu command set.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..service.snapshot import Status
from .base import MAX_PENDING_BYTES, RotatorPort

_BACKSPACES = (0x08, 0x7F)


@dataclass(frozen=True)
class Line:
    """One complete input line (terminator removed), or an overflow notice."""

    text: bytes
    overflowed: bool = False


class LineSplitter:
    """Split a byte stream into lines ended by CR, LF or CRLF (CRLF counts once).

    A line longer than ``max_len`` is dropped: one ``Line(b"", overflowed=True)`` is
    produced at once (so the session can answer while the flood goes on) and everything
    up to the next terminator is discarded. Backspace/DEL delete the previous character,
    as on a terminal.
    """

    def __init__(self, max_len: int = MAX_PENDING_BYTES, backspace: bool = True):
        self.max_len = max_len
        self.backspace = backspace
        self._buf = bytearray()
        self._after_cr = False
        self._discarding = False

    @property
    def pending(self) -> bytes:
        """The unfinished line so far (what a terminal would show after the prompt)."""
        return bytes(self._buf)

    def feed(self, data: bytes) -> list[Line]:
        lines: list[Line] = []
        for byte in data:
            if byte == 0x0A and self._after_cr:       # the LF of a CRLF
                self._after_cr = False
                continue
            self._after_cr = byte == 0x0D
            if byte in (0x0D, 0x0A):
                if not self._discarding:
                    lines.append(Line(bytes(self._buf)))
                self._buf.clear()
                self._discarding = False
                continue
            if self._discarding:
                continue
            if self.backspace and byte in _BACKSPACES:
                if self._buf:
                    del self._buf[-1]
                continue
            self._buf.append(byte)
            if len(self._buf) > self.max_len:
                self._buf.clear()
                self._discarding = True
                lines.append(Line(b"", overflowed=True))
        return lines


class TerminalEcho:
    """Character echo for a console session (Tartu ``ECHO ON``): what a terminal needs
    to show the line being typed, with backspaces rubbed out and CRLF at each end."""

    def __init__(self) -> None:
        self._shown = b""

    def update(self, pending: bytes) -> bytes:
        """Echo that brings the screen from what was shown to ``pending``."""
        common = 0
        for a, b in zip(self._shown, pending):
            if a != b:
                break
            common += 1
        out = b"\b \b" * (len(self._shown) - common) + pending[common:]
        self._shown = pending
        return out

    def end_line(self, text: bytes) -> bytes:
        out = self.update(text) + b"\r\n"
        self._shown = b""
        return out


# ------------------------------------------------------------------ extended frame
def frame_offsets_deg(st: Status) -> tuple[float, float]:
    """(az, el) to add to a mechanical angle (``st.az.pos_deg``, ``target_deg``) to get
    the extended frame: the mount offsets, from the snapshot (``Status.offsets``) or,
    where a snapshot lacks them, recovered from its sky and mechanical angles."""
    offsets = getattr(st, "offsets", None)
    if offsets and "az" in offsets and "el" in offsets:
        return float(offsets["az"]), float(offsets["el"])
    az_m, el_m = st.az.pos_deg, st.el.pos_deg
    el_off = ((180.0 - st.el_deg) if st.flipped else st.el_deg) - el_m
    az_sky_base = st.az_deg - 180.0 if st.flipped else st.az_deg
    az_off = (az_sky_base - az_m + 180.0) % 360.0 - 180.0
    # a mount offset beyond +-180 deg: put the azimuth on the wrap turn the service says
    ext = az_m + az_off
    turns = math.floor(ext / 360.0)
    near_boundary = abs(ext - 360.0 * round(ext / 360.0)) < 1e-3
    if turns != st.wrap_turns and not near_boundary:
        az_off += 360.0 * (st.wrap_turns - turns)
    return az_off, el_off


def extended_pose_deg(st: Status) -> tuple[float, float]:
    """Where the axes are, in the frame a controller shows: azimuth including the wrap
    (e.g. 400.0, or -10.0 on a -180..540 rotator), elevation past 90 when flipped.
    Equals (st.az_deg, st.el_deg) for a rotator sitting in its first turn, unflipped."""
    az_off, el_off = frame_offsets_deg(st)
    return st.az.pos_deg + az_off, st.el.pos_deg + el_off


def extended_targets_deg(st: Status) -> tuple[float | None, float | None]:
    """The axes' present setpoints (where each axis is heading now) in the extended
    frame; None for an axis that holds no setpoint (idle, stopped)."""
    az_off, el_off = frame_offsets_deg(st)
    az_t, el_t = st.az.target_deg, st.el.target_deg
    return (None if az_t is None else az_t + az_off, None if el_t is None else el_t + el_off)


# ------------------------------------------------------------------- target memory
def _sky(az_deg: float, el_deg: float) -> tuple[float, float]:
    """The sky direction a goto argument names (explicit flipped poses included)."""
    if el_deg > 90.0:
        az_deg, el_deg = az_deg + 180.0, 180.0 - el_deg
    return az_deg % 360.0, el_deg


def _same_sky(a: tuple[float, float], b: tuple[float | None, float | None]) -> bool:
    if b[0] is None or b[1] is None:
        return False
    d_az = (a[0] - b[0] + 180.0) % 360.0 - 180.0
    return abs(d_az) < 1e-6 and abs(a[1] - b[1]) < 1e-6


def _same_target(a: tuple[float | None, float | None], b: tuple[float | None, float | None]) -> bool:
    if a[0] is None or a[1] is None:
        return b[0] is None or b[1] is None
    return _same_sky((a[0], a[1]), b)


class TargetMemory:
    """Complete a single-axis goto with the other axis' target.

    ``Rotator.goto_az`` takes the elevation from the service's target, which only
    changes on its next control tick (so "GOAZ 100" then "GOEL 20" in one chunk would
    have GOEL undo GOAZ), and which a stop leaves in place (so "HALT" then "GOAZ 100"
    would drive elevation back to the old target). This remembers what the session
    asked for, in the session's own frame, for as long as the service's target is
    still that request, and which axes this session stopped, for as long as nobody
    commanded a new target since.
    """

    def __init__(self) -> None:
        self._asked: tuple[float, float, float] | None = None   # (status t_s, az, el)
        self._stopped: dict[str, tuple[float | None, float | None]] = {}

    def base(self, st: Status, extended: bool = False) -> tuple[float, float]:
        """(az, el) to keep for the axis not being commanded; ``extended``: in the
        extended frame (wrap turns, flipped elevation) rather than sky."""
        service = (st.target_az_deg, st.target_el_deg)
        here = extended_pose_deg(st) if extended else (st.az_deg, st.el_deg)
        asked = self._asked
        if asked is not None and not (asked[0] == st.t_s or _same_sky(_sky(asked[1], asked[2]), service)):
            asked = self._asked = None          # superseded by another command
        if asked is not None:
            out = [asked[1], asked[2]]
        else:
            out = [here[0] if service[0] is None else service[0],
                   here[1] if service[1] is None else service[1]]
        for i, axis in enumerate(("az", "el")):
            seen = self._stopped.get(axis)
            if seen is None:
                continue
            if _same_target(seen, service):
                out[i] = here[i]
            else:
                del self._stopped[axis]
        return out[0], out[1]

    def goto(self, rotator: RotatorPort, st: Status, az_deg: float, el_deg: float) -> None:
        """``rotator.goto`` and remember it (raises CommandRejected like goto)."""
        rotator.goto(az_deg, el_deg)
        self._asked = (st.t_s, az_deg, el_deg)
        self._stopped.clear()

    def stopped(self, st: Status, axis: str | None = None) -> None:
        """This session stopped ``axis`` (or both): keep it where it comes to rest."""
        # the target the service will hold once it has applied everything sent so far
        if self._asked is not None and self._asked[0] == st.t_s:
            expected: tuple[float | None, float | None] = _sky(self._asked[1], self._asked[2])
        else:
            expected = (st.target_az_deg, st.target_el_deg)
        for name in ([axis] if axis else ["az", "el"]):
            self._stopped[name] = expected
        if axis is None:
            self._asked = None

    def forget(self) -> None:
        self._asked = None
        self._stopped.clear()
