"""Yaesu GS-232A / GS-232B / generic GS-232 / FoxDelta ST2 device emulation.

What Hamlib models 601 (GS-232A), 603 (GS-232B), 602/607 (generic) and 608 (FoxDelta
ST2) talk to. The command set is the same; the replies differ (protocols.md 3.2-3.5):

====================  ======================  ==================  ===========
                      C2 (position)           after a set         bad command
====================  ======================  ==================  ===========
GS-232A               ``+0aaa+0eee\\r\\n``      ``\\r`` (manual)     ``?>\\r``
GS-232B               ``AZ=aaa  EL=eee\\r\\n``  nothing             ``?>\\r\\n``
generic / FoxDelta    ``+0aaa+0eee\\r``         nothing             ``?>\\r``
====================  ======================  ==================  ===========

Positions are in the controller's own frame, as a G-5500's potentiometers read them:
azimuth 0..450 including the cable wrap (Hamlib does not map 350 back to -10), elevation
0..180 including the flip. Values sent in that frame name that pose and are passed to
the rotator unchanged.
"""

from __future__ import annotations

from .. import geodesy
from ..errors import CommandRejected, UrcError
from ..model.messages import Goto, Move, Stop
from ..model.effects import Effects
from ..model.snapshot import Status
from .base import RotatorPort, bad_input_log, internal_error, protocol_logger
from ..wire.gs232 import (SPEED_LEVELS, STYLE_A, STYLE_B, STYLE_GENERIC, Command, Gs232ParseError,
                          format_error, format_help, format_position, parse_command)
from .lines import LineSplitter
from .poses import extended_pose_deg, frame_offsets_deg, goto_extended
from .single_axis import has_elevation, wire_el_axis

#: the speed a session starts with (X4, fastest), until the client sends X1..X4.
DEFAULT_SPEED_LEVEL = 4


def controller_pose(s: Status) -> tuple[float, float]:
    """(az, el) in the controller frame (the extended frame), except that GS-232 has no
    sign for azimuth: on a rotator whose range starts below 0 (e.g. -90..450) a negative
    azimuth is reported as the same direction + 360 (what Hamlib sends for it)."""
    az, el = extended_pose_deg(s)
    if az < -0.5 and s.limits.get("az", (0.0, 0.0))[0] + frame_offsets_deg(s)[0] < -0.5:
        az += 360.0
    return az, el


def _station(lat_deg: object, lon_deg: object, alt_m: object) -> tuple[float, float, float] | None:
    """The options' station (lat_deg, lon_deg, alt_m), None without coordinates;
    TypeError (the server's "bad options", found at start) for half a pair or a value
    that is not a position."""
    if lat_deg is None and lon_deg is None:
        return None
    if lat_deg is None or lon_deg is None:
        raise TypeError("station_lat_deg and station_lon_deg go together (the station's position, "
                        "for NMEA GGA points)")
    problem = geodesy.position_problem(lat_deg, lon_deg, alt_m)
    if problem is not None:
        raise TypeError(f"station {problem}")
    return float(lat_deg), float(lon_deg), float(alt_m)  # type: ignore[arg-type]  # (checked)


class _Gs232Session:
    protocol = "gs232"
    style = STYLE_A

    def __init__(self, rotator: RotatorPort, *, station_lat_deg: float | None = None,
                 station_lon_deg: float | None = None, station_alt_m: float = 0.0) -> None:
        self.rotator = rotator
        self.closed = False
        #: the station's own coordinates, for NMEA GGA points (BIG-RAS: "if we have
        #: previously set our own coordinates")
        self._station = _station(station_lat_deg, station_lon_deg, station_alt_m)
        self._log = protocol_logger(self.protocol)
        self._bad = bad_input_log(self.protocol)
        self._lines = LineSplitter(log=self._bad)
        self._speed_frac = SPEED_LEVELS[DEFAULT_SPEED_LEVEL]

    # ------------------------------------------------------------------ Session API
    def receive(self, data: bytes) -> Effects[list[bytes]]:
        out: list[bytes] = []
        for item in self._lines.feed(data):
            if item.overflowed:
                out.append(format_error(self.style))
                continue
            try:
                out += yield from self._line(item.text)
            except UrcError as exc:  # a hardware failure: the protocol's error
                self._log.warning("%r failed: %s", item.text[:80], exc)
                out.append(format_error(self.style))
            except Exception:  # a bug: the connection survives, the bug is counted
                internal_error(self._log, self.protocol, "on %r", item.text[:80])
                out.append(format_error(self.style))
        return out

    def tick(self, now_s: float) -> list[bytes]:
        return []

    # ------------------------------------------------------------------ one command
    def _line(self, line: bytes) -> Effects[list[bytes]]:
        if not line.strip(b" \t"):
            # Hamlib 603 sends a bare CR after every write (an empty line): silence
            # (a late "?>" could land in the next reply Hamlib reads)
            return []
        try:
            cmd = parse_command(line)
        except Gs232ParseError as exc:
            self._bad.warning("%s", exc)
            return [format_error(self.style)]
        try:
            reply = yield from self._do(cmd)
        except Gs232ParseError as exc:          # an NMEA sentence it cannot use
            self._bad.warning("%s", exc)
            return [format_error(self.style)]
        except CommandRejected as exc:
            self._bad.warning("%r refused (%s): %s", line[:80], exc.reason, exc)
            return self._refused()
        return [reply] if reply is not None else self._ack()

    def _ack(self) -> list[bytes]:
        """After a command without data. GS-232A: a CR (its manual). Hamlib 601 waits
        50 ms after every write and flushes before the next command, so it never reads it."""
        return [b"\r"]

    def _refused(self) -> list[bytes]:
        return [format_error(self.style)]

    def _do(self, cmd: Command) -> Effects[bytes | None]:
        rot = self.rotator
        if cmd.op == "read":
            az, el = controller_pose(rot.status())  # never cached
            return format_position(self.style, az if cmd.what in ("az", "azel") else None,
                                   el if cmd.what in ("el", "azel") else None)
        if not has_elevation(rot) and (cmd.op == "goto_el" or (cmd.op == "move" and cmd.what == "el")):
            # a single-axis rotator (BIG-RAS "Elevation: OFF", a GS-232A on an azimuth
            # rotator): the controller cannot tell that no elevation rotator hangs on its
            # elevation output, so it acknowledges Keee / EL=eee / U / D / MU / MD as
            # usual; urc does too, and moves nothing (the azimuth keeps its goal). C2/B
            # read elevation 0 (single_axis.wire_status), W and AZ= EL= turn the azimuth.
            return None
        # GS-232 speaks the controller's own azimuth (0..450 on an overlap rotator): a set
        # names its pose, the wrap turn included (README: Angles)
        # (the parser gives each op its fields: asserted for the type checker)
        if cmd.op == "goto":
            assert cmd.az_deg is not None and cmd.el_deg is not None
            yield from goto_extended(rot, cmd.az_deg, cmd.el_deg)
        elif cmd.op == "goto_az":
            assert cmd.az_deg is not None
            yield from goto_extended(rot, cmd.az_deg, self._el_to_keep(rot.status()))
        elif cmd.op == "goto_el":
            assert cmd.el_deg is not None
            yield from goto_extended(rot, self._az_to_keep(rot.status()), cmd.el_deg)
        elif cmd.op == "help":
            return format_help()
        elif cmd.op == "nmea":
            az, el = self._nmea_point(cmd.text)
            yield Goto(az, el)
        elif cmd.op == "stop":
            yield Stop(cmd.what)
        elif cmd.op == "move":
            assert cmd.what is not None
            yield Move(cmd.what, cmd.direction, self._speed_frac)
        elif cmd.op == "speed":
            # applies to the next L/R/U/D (Hamlib sends X just before the direction)
            self._speed_frac = SPEED_LEVELS[cmd.level]
        return None

    def _nmea_point(self, sentence: bytes) -> tuple[float, float]:
        """A GGA sentence -> (az, el) of the point it reports, seen from the station.
        The BIG-RAS turns the antenna to each report as it comes (balloon tracking from
        SondeMonitor); urc's own ``track --nmea`` target predicts between reports."""
        import pynmea2

        if self._station is None:
            raise Gs232ParseError("station coordinates (options station_lat_deg, station_lon_deg) "
                                  "before an NMEA point", sentence[:20])
        try:
            msg = pynmea2.parse(sentence.decode("ascii", "replace"), check=True)
        except (pynmea2.ParseError, ValueError) as exc:
            raise Gs232ParseError(f"a valid NMEA sentence ({exc})"[:80], sentence[:20]) from None
        if getattr(msg, "sentence_type", "") != "GGA":
            raise Gs232ParseError("a GGA sentence", sentence[:20])
        if not int(msg.gps_qual or 0) or not msg.lat:
            raise Gs232ParseError("a GGA sentence with a fix", sentence[:20])
        try:
            point = (msg.latitude, msg.longitude, float(msg.altitude or 0.0))
        except ValueError as exc:
            raise Gs232ParseError(f"a point on Earth ({exc})"[:80], sentence[:20]) from None
        problem = geodesy.position_problem(*point)
        if problem is not None:
            raise Gs232ParseError(f"a point on Earth ({problem})"[:80], sentence[:20])
        lat_deg, lon_deg, _alt_m = self._station
        az_deg, el_deg, _range_km = geodesy.look_at(geodesy.itrs_km(*self._station),
                                                    geodesy.enu_rows(lat_deg, lon_deg), geodesy.itrs_km(*point))
        return az_deg, el_deg

    @staticmethod
    def _az_to_keep(s: Status) -> float:
        """``Beee``/``EL=eee`` turn the elevation only: azimuth keeps its turn and goal."""
        az_m = s.az.target_deg if s.moving and s.az.target_deg is not None else s.az.pos_deg
        lo, hi = s.limits.get("az", (az_m, az_m))
        return min(max(az_m, lo), hi) + frame_offsets_deg(s)[0]

    @staticmethod
    def _el_to_keep(s: Status) -> float:
        """``Maaa`` turns the azimuth only: elevation keeps its mechanical pose (a flipped
        120 stays 120) or, while moving, its current target; clamped to the limits so
        sensor noise at the bottom stop cannot make the command illegal."""
        el = wire_el_axis(s)
        el_m = el.target_deg if s.moving and el.target_deg is not None else el.pos_deg
        lo, hi = s.limits.get("el", (el_m, el_m))
        return min(max(el_m, lo), hi) + frame_offsets_deg(s)[1]


class Gs232aSession(_Gs232Session):
    """Yaesu GS-232A (Hamlib 601): C2 -> ``+0aaa+0eee\\r\\n``, a CR after every command."""

    protocol = "gs232a"
    style = STYLE_A


class Gs232bSession(_Gs232Session):
    """Yaesu GS-232B (Hamlib 603): C2 -> ``AZ=aaa  EL=eee\\r\\n``.

    What a real GS-232B sends after a successful set is not known (protocols.md 7). We
    send nothing: Hamlib 603 stops reading at the first CR, so a stray CR that its flush
    missed would be read as a one-byte reply to the next C2 and fail it (-8, no retry);
    silence is always safe. Its extra bare CR after each write is ignored likewise.
    """

    protocol = "gs232b"
    style = STYLE_B

    def _ack(self) -> list[bytes]:
        return []


class Gs232GenericSession(_Gs232Session):
    """Generic GS-232 (Hamlib 602/607): C2 -> ``+0aaa+0eee\\r`` (read to CR, 11 bytes max).

    Hamlib writes these commands back to back with no delay and never reads a reply to
    W or S, so a set is answered with nothing, not even when refused: a ``?>`` arriving
    after Hamlib's flush would be read as the answer to its next C2.
    """

    protocol = "gs232"
    style = STYLE_GENERIC

    def _ack(self) -> list[bytes]:
        return []

    def _refused(self) -> list[bytes]:
        return []


class FoxDeltaSession(Gs232GenericSession):
    """FoxDelta ST2 (Hamlib 608): Hamlib drives it with the generic GS-232 code."""

    protocol = "foxdelta"
