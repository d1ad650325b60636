"""SPID Rot1Prog / Rot2Prog / MD-01/02 binary frames (protocols.md §4): pure functions.

Command (host -> controller), always 13 bytes::

    'W'  H1 H2 H3 H4  PH  V1 V2 V3 V4  PV  K  0x20

K = 0x0F stop, 0x1F status, 0x2F set, 0x14 move (MD-01/02). In a set command the digits
are ASCII: Rot2Prog/MD H = PH x (360 + az), V = PV x (360 + el), four digits, thousands
first; Rot1Prog H1..H3 = 360 + az in whole degrees and H4 = '0'.

Reply (controller -> host): Rot2Prog/MD 12 bytes ``'W' H1..H4 PH V1..V4 PV 0x20``,
Rot1Prog 5 bytes ``'W' H1 H2 H3 0x20``; the digits are raw values 0..9 (not ASCII) of
360 + angle in tenths (Rot1Prog: whole degrees). So an azimuth of -180..540 (a rotator's
overturn) is representable, as anything from -360 to 639.9.
"""

from __future__ import annotations

from dataclasses import dataclass

from ..errors import ProtocolError

START = 0x57            # 'W'
END = 0x20              # ' '
COMMAND_LEN = 13
ROT2_REPLY_LEN = 12
ROT1_REPLY_LEN = 5

K_STOP = 0x0F
K_STATUS = 0x1F
K_SET = 0x2F
K_MOVE = 0x14
KNOWN_K = (K_STOP, K_STATUS, K_SET, K_MOVE)

# MD-01/02 move direction bits (byte 1 of a K_MOVE frame)
DIR_LEFT, DIR_RIGHT, DIR_UP, DIR_DOWN = 0x01, 0x02, 0x04, 0x08

#: offset the controller adds so negative angles encode as positive numbers
OFFSET_DEG = 360.0


class SpidFrameError(ProtocolError):
    """A 13-byte window that is not a well-formed command."""


@dataclass(frozen=True)
class SpidCommand:
    kind: str                        # "stop" | "status" | "set" | "move"
    az_deg: float | None = None      # set
    el_deg: float | None = None      # set (Rot2Prog/MD)
    direction: int = 0               # move: DIR_* bits


def resolution_to_pulses(resolution_deg: float) -> int:
    """0.5 deg -> 2 (PH/PV: pulses per degree). Must be 1/n for a whole n in 1..10."""
    if not resolution_deg > 0:
        raise ValueError(f"resolution_deg must be > 0, got {resolution_deg!r}")
    n = round(1.0 / resolution_deg)
    if not 1 <= n <= 10 or abs(n * resolution_deg - 1.0) > 1e-6:
        raise ValueError(f"resolution_deg must be 1/n deg for n = 1..10 (1, 0.5, 0.25 ...), "
                         f"got {resolution_deg!r}")
    return n


# ------------------------------------------------------------------ framing
def split_frames(buf: bytes, plausible) -> tuple[list[bytes], bytes, int]:
    """Cut complete command frames out of ``buf``.

    Returns (frames, rest to keep for later, number of bytes discarded). A frame starts
    with 'W', is 13 bytes long, ends with 0x20 and passes ``plausible(frame)``. When the
    13 bytes from a 'W' do not, that 'W' was not a frame start (a half frame followed by
    a new one, or noise): skip it and look for the next. Fewer than 13 bytes after a 'W'
    wait for more input. Bytes before a 'W' are discarded.
    """
    frames: list[bytes] = []
    dropped = 0
    i = 0
    n = len(buf)
    while True:
        j = buf.find(b"W", i)
        if j < 0:
            return frames, b"", dropped + (n - i)
        dropped += j - i
        if n - j < COMMAND_LEN:
            return frames, buf[j:], dropped
        cand = buf[j:j + COMMAND_LEN]
        if cand[-1] == END and plausible(cand):
            frames.append(cand)
            i = j + COMMAND_LEN
        else:
            dropped += 1
            i = j + 1


def _ascii_digits(b: bytes) -> int | None:
    if all(0x30 <= c <= 0x39 for c in b):
        return int(b.decode("ascii"))
    return None


def decode_command(frame: bytes, variant: str, pulses: tuple[int, int]) -> SpidCommand:
    """One 13-byte command -> SpidCommand. ``variant``: rot1 | rot2 | md01; ``pulses``:
    this controller's (PH, PV), used when the frame's own are 0. Raises SpidFrameError."""
    if len(frame) != COMMAND_LEN or frame[0] != START or frame[-1] != END:
        raise SpidFrameError(f"expected 13 bytes 'W'...0x20, got {frame.hex(' ')}")
    k = frame[11]
    if k == K_STOP:
        return SpidCommand("stop")
    if k == K_STATUS:
        return SpidCommand("status")
    if k == K_MOVE:
        if variant != "md01":
            raise SpidFrameError(f"move (K=0x14) is an MD-01/02 command, not {variant}")
        return SpidCommand("move", direction=frame[1])
    if k != K_SET:
        raise SpidFrameError(f"expected K 0x0F, 0x1F, 0x2F or 0x14, got 0x{k:02X}")
    h = _ascii_digits(frame[1:5])
    if h is None:
        raise SpidFrameError(f"set: azimuth digits must be ASCII '0'..'9', got {frame[1:5].hex(' ')}")
    if variant == "rot1":
        # H1..H3 whole degrees, H4 '0' (read as tenths, so a client sending them works)
        return SpidCommand("set", az_deg=h / 10.0 - OFFSET_DEG)
    v = _ascii_digits(frame[6:10])
    if v is None:
        raise SpidFrameError(f"set: elevation digits must be ASCII '0'..'9', got {frame[6:10].hex(' ')}")
    # Hamlib writes the PH/PV it scaled with into bytes 5 and 10; 0 means "yours"
    ph = frame[5] or pulses[0]
    pv = frame[10] or pulses[1]
    if ph > 10 or pv > 10:
        raise SpidFrameError(f"set: PH/PV (pulses per degree) expected 1..10, got {ph}/{pv}")
    return SpidCommand("set", az_deg=h / ph - OFFSET_DEG, el_deg=v / pv - OFFSET_DEG)


def plausible(frame: bytes, variant: str) -> bool:
    try:
        decode_command(frame, variant, (1, 1))
    except SpidFrameError:
        return False
    return True


# ------------------------------------------------------------------ replies
def _tenths_digits(angle_deg: float) -> bytes:
    t = round((angle_deg + OFFSET_DEG) * 10.0)
    t = min(max(t, 0), 9999)
    return bytes((t // 1000, t // 100 % 10, t // 10 % 10, t % 10))


def encode_rot2_position(az_deg: float, el_deg: float, ph: int, pv: int) -> bytes:
    """12-byte Rot2Prog/MD position reply (tenths of a degree, raw digits)."""
    return bytes((START,)) + _tenths_digits(az_deg) + bytes((ph,)) + \
        _tenths_digits(el_deg) + bytes((pv, END))


def encode_rot1_position(az_deg: float) -> bytes:
    """5-byte Rot1Prog position reply (whole degrees, raw digits)."""
    d = min(max(round(az_deg + OFFSET_DEG), 0), 999)
    return bytes((START, d // 100, d // 10 % 10, d % 10, END))


def decode_rot2_position(reply: bytes) -> tuple[float, float, int, int]:
    """As Hamlib decodes it: (az, el, PH, PV)."""
    if len(reply) != ROT2_REPLY_LEN or reply[0] != START or reply[-1] != END:
        raise SpidFrameError(f"expected a 12-byte 'W'...0x20 reply, got {reply.hex(' ')}")
    az = reply[1] * 100 + reply[2] * 10 + reply[3] + reply[4] / 10.0 - OFFSET_DEG
    el = reply[6] * 100 + reply[7] * 10 + reply[8] + reply[9] / 10.0 - OFFSET_DEG
    return az, el, reply[5], reply[10]


def decode_rot1_position(reply: bytes) -> float:
    if len(reply) != ROT1_REPLY_LEN or reply[0] != START or reply[-1] != END:
        raise SpidFrameError(f"expected a 5-byte 'W'...0x20 reply, got {reply.hex(' ')}")
    return reply[1] * 100 + reply[2] * 10 + reply[3] - OFFSET_DEG


# ------------------------------------------------- host side (what Hamlib sends)
def encode_query(k: int) -> bytes:
    """Stop (0x0F) or status (0x1F): all fields zero."""
    return bytes((START,)) + bytes(10) + bytes((k, END))


def encode_rot2_set(az_deg: float, el_deg: float, ph: int, pv: int) -> bytes:
    """As Hamlib's rot2prog_rot_set_position: truncated, four ASCII digits."""
    h = int(ph * (OFFSET_DEG + az_deg))
    v = int(pv * (OFFSET_DEG + el_deg))
    return bytes((START,)) + f"{h:04d}".encode() + bytes((ph,)) + f"{v:04d}".encode() + bytes((pv, K_SET, END))


def encode_rot1_set(az_deg: float) -> bytes:
    h = int(OFFSET_DEG + az_deg)
    return bytes((START,)) + f"{h:03d}0".encode() + bytes(6) + bytes((K_SET, END))


def encode_move(direction: int, junk: tuple[int, int] = (0x7F, 0x00)) -> bytes:
    """MD-01/02 move; bytes 5 and 10 carry whatever Hamlib's stack held."""
    return bytes((START, direction, 0, 0, 0, junk[0], 0, 0, 0, 0, junk[1], K_MOVE, END))
