"""The schema's sections but ``[hardware]`` and ``[panel]`` (:mod:`.hardware_sections`,
:mod:`.panel_sections`): the rotator and its profile, limits, park, keep-out zones,
control overrides, faults, the API, state, station, tracking and what is served."""

from __future__ import annotations

import ipaddress
import os
from dataclasses import replace
from pathlib import Path
from typing import Literal

from pydantic import Field

from ..caps import AxisCaps, RotatorCaps
from ..control.geometry import KeepOut
from ..profiles import DEFAULT_PROFILE
from .base import Section, num


class RotatorSection(Section):
    #: one of :data:`urc.profiles.PROFILES`
    profile: str = DEFAULT_PROFILE
    loop_hz: float = num(50.0, ge=1.0, le=1000.0, description="control loop rate")
    #: flying "over the top" (elevation past 90, azimuth + 180) on rotators whose
    #: elevation reaches 180: "auto" = the pass planner decides per pass wherever the
    #: profile can flip (a goto to a sky direction stays unflipped, so protocol clients
    #: read back what they set); true = that, and gotos take the flipped pose when it
    #: is faster (an error on a profile that cannot flip); false = never (the user
    #: forbids it: a feed or cable that must not go over the top). An explicit pose
    #: (elevation past 90) is flown whatever the setting. See :meth:`flip_enabled`.
    flip: bool | Literal["auto"] = "auto"
    #: false = a single-axis rotator, azimuth only (the Tartu TRC turntable, BIG-RAS
    #: with "Elevation: OFF", an HF beam): no elevation parts, limits, park or offset;
    #: protocols answer elevation queries as the original az-only units do.
    elevation: bool = True
    #: BIG-RAS "Max. elevation": 90, or 180 (elevation 0..180: past 90 is over the top,
    #: azimuth + 180, and passes may be flown so); None = the profile's range
    max_el_deg: float | None = num(None)
    #: BIG-RAS "Pulse/degree": pulses the rotator's pulse sensor gives per degree (both
    #: axes; profiles with pulse feedback only); None = the profile's
    pulses_per_deg: int | None = Field(default=None, ge=1, le=100)
    #: BIG-RAS "Zero point": where the rotator's mechanical zero points, "north" or
    #: "south". South: the mechanical frame (limits, park, the pulse count) starts at
    #: south, compass azimuth = mechanical + 180 (+ offsets.az_deg). Protocols, status
    #: and the page always speak compass azimuth (north = 0), as the BIG-RAS does.
    zero: Literal["north", "south"] = "north"

    def flip_enabled(self, caps: RotatorCaps) -> bool:
        """May the pass planner fly passes over the top on this profile?"""
        return caps.can_flip if self.flip == "auto" else bool(self.flip)

    def variant(self, caps: RotatorCaps) -> RotatorCaps:
        """The profile's caps as this section changes them (a new caps value): max
        elevation, pulses per degree, single-axis."""
        if self.max_el_deg is not None:
            caps = replace(caps, el=replace(caps.el, max_deg=float(self.max_el_deg),
                                            park_deg=min(caps.el.park_deg, float(self.max_el_deg))))
        if self.pulses_per_deg is not None:
            step_deg = 1.0 / self.pulses_per_deg

            def stepped(axis: AxisCaps) -> AxisCaps:
                if axis.sensor.kind != "pulse":
                    return axis
                return replace(axis, sensor=replace(axis.sensor, resolution_deg=step_deg))

            caps = replace(caps, az=stepped(caps.az), el=stepped(caps.el))
        return caps if self.elevation else caps.single_axis()

    @property
    def zero_offset_deg(self) -> float:
        """What the zero point adds to the mechanical azimuth to make it a compass one."""
        return 180.0 if self.zero == "south" else 0.0


class AxisLimits(Section):
    """User soft limits narrowing the profile's range; None = the profile's."""

    min_deg: float | None = num(None)
    max_deg: float | None = num(None)


class LimitsSection(Section):
    az: AxisLimits = AxisLimits()
    el: AxisLimits = AxisLimits()


class OffsetsSection(Section):
    #: added to what the sensor says (mount misalignment).
    az_deg: float = num(0.0, ge=-180.0, le=180.0)
    el_deg: float = num(0.0, ge=-90.0, le=90.0)


class ParkSection(Section):
    #: None = the profile's park position.
    az_deg: float | None = num(None)
    el_deg: float | None = num(None)
    #: auto-park after this many seconds idle; 0 = never.
    idle_park_s: float = num(0.0, ge=0.0)

    def __call__(self, caps: RotatorCaps) -> tuple[float, float]:
        """``(az_deg, el_deg)`` to park at: these values, else the profile's park."""
        az = caps.az.park_deg if self.az_deg is None else self.az_deg
        el = caps.el.park_deg if self.el_deg is None else self.el_deg
        return float(az), float(el)


class KeepoutZone(Section):
    """A region the antenna must never pass through.

    The azimuth sector is in compass degrees and may wrap: ``az_min_deg = 350``,
    ``az_max_deg = 10`` is the 20 degree sector across north. Values in the profile's
    wrap range (e.g. 370) mean the same compass direction (10).
    """

    name: str = ""
    az_min_deg: float = num(...)
    az_max_deg: float = num(...)
    el_min_deg: float = num(...)
    el_max_deg: float = num(...)

    def keep_out(self, index: int) -> KeepOut:
        """The zone as the controller's geometry uses it (one containment rule)."""
        return KeepOut(self.label(index), self.az_min_deg, self.az_max_deg, self.el_min_deg, self.el_max_deg)

    def label(self, index: int) -> str:
        return self.name or f"keepout[{index}]"


class AxisControl(Section):
    """Per-axis control overrides; None = the profile's value."""

    tolerance_deg: float | None = num(None, gt=0.0)
    restart_deg: float | None = num(None, gt=0.0)
    max_rate_deg_per_s: float | None = num(None, gt=0.0)
    #: the slowest speed at which the motor still turns reliably (BIG-RAS "Minimal
    #: turn"): motion starts from it and slows to it before stopping, and slow targets
    #: are followed at it in bursts
    min_rate_deg_per_s: float | None = num(None, gt=0.0)
    accel_deg_per_s2: float | None = num(None, gt=0.0)
    kp_per_s: float = num(6.0, ge=0.0)
    ki_per_s2: float = num(1.0, ge=0.0)
    overshoot_deg: float | None = num(None, ge=0.0)
    creep_lead_deg: float | None = num(None, ge=0.0)
    backlash_deg: float | None = num(None, ge=0.0, le=20.0)


class ControlSection(Section):
    az: AxisControl = AxisControl()
    el: AxisControl = AxisControl()


class FaultsSection(Section):
    stall_timeout_s: float = num(1.5, gt=0.0)
    #: moved this far without a command, or the wrong way -> fault.
    runaway_deg: float = num(3.0, gt=0.0)
    sensor_jump_deg: float = num(5.0, gt=0.0)
    #: 0 = the backend's default.
    overcurrent_a: float = num(0.0, ge=0.0)
    #: control-loop deadline: a tick this late stops the motors, held off until the loop
    #: has been on time for watchdog_recover_s
    watchdog_s: float = num(0.5, gt=0.0)
    watchdog_recover_s: float = num(2.0, ge=0.0, le=60.0)
    #: this many stalls within watchdog_latch_window_s latch a watchdog fault (cleared
    #: only by an operator); fewer are ridden out
    watchdog_latch_stalls: int = Field(default=3, ge=1, le=1000)
    watchdog_latch_window_s: float = num(60.0, gt=0.0, le=86400.0)
    #: urc run's I/O process takes the outputs over from a control process that is dead
    #: or has published no status for this long (frozen): it kills it, drives every
    #: output safe itself and stops the service (0: never; the control process's own
    #: watch and an external safety chain remain)
    control_takeover_s: float = num(1.0, ge=0.0, le=60.0)


class ApiSection(Section):
    host: str = Field(default="127.0.0.1", min_length=1)
    port: int = Field(default=8080, ge=0, le=65535)
    token: str = ""
    #: a read-only token (a wall display): reads of an exposed instance, never control
    read_token: str = ""

    @property
    def reads_require_token(self) -> bool:
        """Listening beyond loopback, reading (status, settings: the station's position and
        the whole configuration, the live feed) needs ``token`` or ``read_token``; with
        neither set, nothing is read from other machines (the page's files still load)."""
        return not self.is_loopback

    @property
    def is_loopback(self) -> bool:
        host = self.host.strip().strip("[]").lower()
        if host == "localhost" or host.endswith(".localhost"):
            return True
        try:
            return ipaddress.ip_address(host).is_loopback
        except ValueError:
            return False

    @property
    def control_requires_token(self) -> bool:
        """Control over the API needs ``token`` because the API is reachable from outside.

        With an empty token that means remote control is refused (reading still works).
        """
        return not self.is_loopback


class StateSection(Section):
    #: "" = the per-user data directory; the --state-dir option overrides.
    dir: str = ""
    #: the longest an axis moves on one state record: a new one is written before the
    #: axis can leave what the last one promised (motion, plus the same again at top
    #: speed). A crash mid-move restarts uncertain by about that much; shorter = more
    #: writes (SD card wear). Bounded: a record promising minutes ahead is no record.
    save_interval_s: float = num(1.0, gt=0.0, le=10.0)

    def resolve_dir(self, override: str | os.PathLike[str] | None = None) -> Path:
        """The state directory: ``override`` (--state-dir), else ``dir``, else per-user."""
        if override is not None and str(override) != "":
            return Path(override).expanduser()
        if self.dir:
            return Path(self.dir).expanduser()
        import platformdirs

        return Path(platformdirs.user_data_dir("urc"))


class StationSection(Section):
    """Where the antenna stands. Needed for tracking; None = not configured."""

    lat_deg: float | None = num(None, ge=-90.0, le=90.0)
    lon_deg: float | None = num(None, ge=-180.0, le=360.0)
    alt_m: float = num(0.0, ge=-500.0, le=100_000.0)
    name: str = ""
    #: a GPS receiver's NMEA stream: a device path or "tcp:HOST:PORT"; its fix sets the
    #: station when lat/lon are not given, and tells whether the system clock is right
    gps: str = ""
    gps_baud: int = Field(default=9600, ge=50, le=4_000_000)

    @property
    def configured(self) -> bool:
        return self.lat_deg is not None and self.lon_deg is not None


class ScheduleEntry(Section):
    #: satellite name (unique prefix, any case) or NORAD id as text
    sat: str = Field(min_length=1)
    #: larger wins when two passes compete for the antenna
    priority: int = 0


class TrackingSection(Section):
    #: where element sets are kept; "" = <per-user data dir>/catalog
    catalog_dir: str = ""
    #: passes below this maximum elevation are ignored; tracking starts at this elevation
    min_el_deg: float = num(0.0, ge=-5.0, le=90.0)
    #: park when a pass ends
    park_after_pass: bool = True
    #: CelesTrak groups `urc tle update` downloads
    groups: tuple[str, ...] = Field(default=("stations", "amateur", "cubesat", "weather"), strict=False)
    #: satellites to track automatically, pass by pass, by priority
    schedule: tuple[ScheduleEntry, ...] = Field(default=(), strict=False)

    def resolve_catalog_dir(self) -> Path:
        if self.catalog_dir:
            return Path(self.catalog_dir).expanduser()
        import platformdirs

        return Path(platformdirs.user_data_dir("urc")) / "catalog"


class ServeEntry(Section):
    """One protocol served on one transport: exactly one of tcp, pty, serial, udp."""

    #: one of :data:`urc.protocols.PROTOCOLS`
    protocol: str
    #: "host:port" to listen on
    tcp: str | None = None
    #: path of a stable symlink to a pseudo-terminal urc creates (``rotctl -r PATH``)
    pty: str | None = None
    #: a real serial device, e.g. "/dev/ttyUSB0"
    serial: str | None = None
    #: serial rate; None = the protocol's own default (Tartu 115200, GS-232 9600 ...)
    baud: int | None = Field(default=None, ge=50, le=4_000_000)
    #: "host:port" to listen on for datagrams (PstRotator)
    udp: str | None = None
    #: UDP replies go to the sender's host on this port (PstRotator listens on 12001)
    reply_port: int = Field(default=12001, ge=1, le=65535)
    #: protocol-specific options, e.g. { hamlib_version = "4.6" }
    options: dict[str, str | int | float | bool] = Field(default_factory=dict, strict=False)

    @property
    def transport(self) -> tuple[str, str]:
        for kind in ("tcp", "pty", "serial", "udp"):
            value = getattr(self, kind)
            if value is not None:
                return kind, value
        raise ValueError("no transport")

    def describe(self) -> str:
        kind, where = self.transport
        return f"{self.protocol} on {kind} {where}"


#: what urc serves when the configuration has no [[serve]] entries at all
DEFAULT_SERVE = (ServeEntry(protocol="rotctld", tcp="127.0.0.1:4533"),)


class PointingSection(Section):
    """``[pointing]``: where a calibration scan (``urc calibrate sun``) reads the received
    power (urc.pointing.sources) and how wide the beam is."""

    #: "sim": the simulator's source seen through [hardware.sim] pointing_error (the sim
    #: backend only); "rigctld": a rig's S-meter (``l STRENGTH``) at ``address``;
    #: "rtl_power": the newest line of rtl_power's CSV ``file``; "tcp": one power per
    #: line from ``address``
    source: Literal["sim", "rigctld", "rtl_power", "tcp"] = "sim"
    #: "host:port" of rigctld or the line feed
    address: str | None = Field(default=None, min_length=3)
    #: rtl_power's output file (``rtl_power -f ... file.csv``)
    file: str | None = Field(default=None, min_length=1)
    #: the antenna's half-power beamwidth: the scan's size and step follow it
    beamwidth_deg: float = num(10.0, gt=0.0, le=90.0)
    #: the simulated source's peak over the noise floor's noise, dB (source = "sim")
    snr_db: float = num(20.0, ge=-10.0, le=60.0)
    #: a reading at or above this is saturated (refused); None = no ceiling known
    ceiling_db: float | None = num(None)
    #: the antenna stands on each scan point this long, reading the power
    dwell_s: float = num(2.0, gt=0.0, le=60.0)
    samples_per_point: int = Field(default=3, ge=1, le=50)
    #: step-track (issue 38.5): during a pass, small scans around the prediction on this
    #: source estimate the satellite's time offset (elements that are off) and correct the
    #: rest of the pass; a lost signal falls back to the prediction (urc.peaking.steptrack)
    step_track: bool = False
