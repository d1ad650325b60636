"""Position-sensor drivers: parts -> :class:`urc.hardware.interfaces.PositionSensor`.

Each keeps its calibration constants (``calibration()`` / ``load_calibration``) and
re-references from a fresh reading (``set_reference_deg``: "what you read now is
``angle_deg``").
A part error (:class:`urc.hardware.parts.PartError`) passes through as the
``SensorError`` the rotator turns into a fault.
"""

from __future__ import annotations

import math
from typing import Any, Literal, Sequence

from ...caps import SensorCaps
from ..parts import AdcChannel, As5600Part, PartError, PulseCounter, QuadratureCounter, Vector3
from .motors import DirectionTracker
from ...angles import wrap180_deg


def wrap(v: float, modulo: float | None) -> float:
    if modulo:
        v %= modulo
        if v >= modulo:        # -1e-17 % 360 == 360.0
            v = 0.0
    return v


def quantise(v: float, q: float) -> float:
    return round(v / q) * q if q > 0 else v


class _Driver:
    def __init__(self, caps: SensorCaps, name: str):
        self.caps = caps
        self.name = name

    def _wrap(self, v: float) -> float:
        return wrap(v, self.caps.modulo_deg)


# ----------------------------------------------------------------- incremental
class _Incremental(_Driver):
    """Counts x resolution + reference; the counter starts at 0 at power-on."""

    reference_deg = 0.0

    def counts(self) -> int:
        raise NotImplementedError

    def read_deg(self) -> float:
        return self._wrap(self.counts() * self.caps.resolution_deg + self.reference_deg)

    def set_reference_deg(self, angle_deg: float) -> None:
        self.reference_deg = float(angle_deg) - self.counts() * self.caps.resolution_deg

    def calibration(self) -> dict[str, Any]:
        return {"reference_deg": self.reference_deg}

    def load_calibration(self, values: dict[str, Any]) -> None:
        if "reference_deg" in values:
            self.reference_deg = float(values["reference_deg"])


class QuadratureEncoder(_Incremental):
    """Incremental encoder on an x4 quadrature counter (Tartu: 10 counts per degree).

    ``index_deg``: the axis angle of an index (Z) pulse, which comes again every
    ``index_period_deg`` (360 with the encoder on the axis; 360 / N on a shaft turning N
    times per axis turn): each new index pulse re-references the count to the nearest
    such angle (drift from missed edges, up to half a period, is wiped at every pass).
    ``motor``/``drift_counts``: with the motor off for ``still_after_s`` the count must
    not move by more than ``drift_counts`` (noise on A/B counts a motor that stands);
    past that the driver reports an error until re-referenced.

    Lost edges (``counter.errors()``: a report of a level its channel already had) each
    cost up to 4 counts in an unknown direction (the channel's two edges, and the other
    channel's edges decoded the wrong way until this one's next report): :meth:`uncertainty_deg` is that bound
    since the last reference (a reference or an index pulse wipes it); past
    ``max_lost_deg`` the reading is a sensor error until re-referenced, so the position
    is never called known when it may be off by more.
    """

    #: counts one lost report may cost: its channel's double step, and the other
    #: channel's two reports decoded against the stale level (+1 -1 instead of +1 +1)
    LOST_EDGE_COUNTS = 4

    def __init__(self, caps: SensorCaps, name: str, counter: QuadratureCounter, *,
                 index_deg: float | None = None, index_period_deg: float = 360.0, motor: Any = None,
                 drift_counts: int | None = None, still_after_s: float = 2.0, clock: Any = None,
                 max_lost_deg: float = 1.0):
        super().__init__(caps, name)
        self.counter = counter
        self.max_lost_deg = float(max_lost_deg)
        self._errors_at_ref = self._errors()
        self.counts_per_deg = round(1.0 / caps.resolution_deg)
        self.index_deg, self.index_period_deg = index_deg, float(index_period_deg)
        self._index_count = counter.index_count()
        #: index re-references so far and the last correction (deg): what the index wiped
        self.index_rereferences = 0
        self.last_index_correction_deg = 0.0
        self.motor, self.drift_counts, self.still_after_s, self.clock = motor, drift_counts, still_after_s, clock
        self._off_since: tuple[float, int] | None = None
        self._drives_seen = 0
        self._drift_error = ""

    def counts(self) -> int:
        return self.counter.count()

    def _errors(self) -> int:
        errors = getattr(self.counter, "errors", None)
        return int(errors()) if errors is not None else 0

    def lost_edges(self) -> int:
        """Edges the counter knows it lost since the last reference."""
        return self._errors() - self._errors_at_ref

    def uncertainty_deg(self) -> float:
        """How far the count may be off from lost edges since the last reference."""
        return self.lost_edges() * self.LOST_EDGE_COUNTS * self.caps.resolution_deg

    def read_deg(self) -> float:
        c = self.counts()
        errors = self._errors()
        if self.index_deg is not None:
            idx = self.counter.index_count()
            if idx is not None and idx != self._index_count:
                self._index_count = idx
                read_at_idx = idx * self.caps.resolution_deg + self.reference_deg
                k = round((read_at_idx - self.index_deg) / self.index_period_deg)
                mark = self.index_deg + k * self.index_period_deg
                self.last_index_correction_deg = mark - read_at_idx
                self.index_rereferences += 1
                self.reference_deg += self.last_index_correction_deg
                self._errors_at_ref = errors      # the mark wiped what the lost edges cost
        lost_deg = (errors - self._errors_at_ref) * self.LOST_EDGE_COUNTS * self.caps.resolution_deg
        if lost_deg > self.max_lost_deg + 1e-9:
            raise PartError(f"{self.name} encoder lost {errors - self._errors_at_ref} edge(s) since it was "
                            f"referenced: the position may be off by up to {lost_deg:.2f} deg (more than "
                            f"{self.max_lost_deg:g}); re-reference it (noise on A/B, or edges faster than "
                            "the pins report them)")
        self._check_drift(c)
        return self._wrap(c * self.caps.resolution_deg + self.reference_deg)

    def _check_drift(self, c: int) -> None:
        if self.drift_counts is None or self.motor is None or self.clock is None:
            return
        if self._drift_error:
            raise PartError(self._drift_error)
        now = self.clock.now_s()
        drives = getattr(self.motor, "drives", 0)
        if getattr(self.motor, "duty", 0.0) != 0.0 or drives != self._drives_seen:
            self._drives_seen = drives
            self._off_since = None
            return
        if self._off_since is None:
            self._off_since = (now, c)
            return
        t0, c0 = self._off_since
        if now - t0 < self.still_after_s:
            self._off_since = (t0, c)      # still coasting: follow it
            return
        if abs(c - c0) > self.drift_counts:
            self._drift_error = (f"{self.name} encoder counted {c - c0:+d} with the motor off "
                                 "(noise on A/B or a loose coupling)")
            raise PartError(self._drift_error)

    def set_reference_deg(self, angle_deg: float) -> None:
        super().set_reference_deg(angle_deg)
        self._errors_at_ref = self._errors()
        self._drift_error = ""
        self._off_since = None

    def index_seen(self) -> bool:
        return self.counter.index_count() is not None


class SpidPulseSensor(_Incremental):
    """SPID/BIG-RAS: one pulse per resolution step and no direction channel.

    Pulses add or subtract by the direction of the drive's last non-zero command
    (as the BIG-RAS firmware does), folded in whenever that direction flips. Coasting
    past a reversal, gear wobble or a reversed motor therefore miscount, as on iron.
    """

    def __init__(self, caps: SensorCaps, name: str, counter: PulseCounter,
                 drive: DirectionTracker):
        super().__init__(caps, name)
        self.counter = counter
        self.drive = drive
        self._seen = counter.count()
        self._signed = 0
        drive.add_direction_listener(self._fold)

    def _fold(self, direction: int) -> None:
        c = self.counter.count()
        self._signed += (c - self._seen) * direction
        self._seen = c

    def counts(self) -> int:
        self._fold(self.drive.direction)
        return self._signed


# ----------------------------------------------------------------- pot
class PotSensor(_Driver):
    """Potentiometer on an ADC channel, in 10-bit units N = 1024 x counts / reference.

    ``ratiometric`` (G4JNT): the pot loaded by a resistor equal to its track gives
    N = 2048 x/(1+x); linearised P = 4096 N/(2048-N) (= 4096 x), the axis angle
    theta = M*P + C from the end-stop reference. ``linear`` (G-5500 through an ADC):
    theta = M*N + C. The reading is theta: the travel limits are theta's. ``Z``, the
    bearing of the end-stop reference, turns bearings only (bearing = theta + Z, modulo
    360): the rotator adds :attr:`pointing_offset_deg` to its mount offset, so a new Z
    moves no limit (the G4JNT document's arithmetic). Dividing by what the ADC
    reads on the pot's supply makes it ratiometric on any ADC (ADS1115 with the supply
    on a second channel); a reference outside ``reference_range`` of full scale
    (a broken wire, a dead supply) is an error, never a bearing.
    """

    def __init__(self, caps: SensorCaps, name: str, adc: AdcChannel, *,
                 law: Literal["ratiometric", "linear"], m: float, c: float, z: float = 0.0,
                 reference_range: tuple[float, float] = (0.8, 1.05)):
        super().__init__(caps, name)
        self.adc = adc
        self.law = law
        self.m_deg_per_unit, self.c_deg, self.z_deg = float(m), float(c), float(z)
        self.reference_range = reference_range
        #: ratiometric: 1024 x the divider's drive gain as the driver assumes it (the
        #: G4JNT constant K, 2048 for its gain of 2); P = 4096 N / (K - N)
        self.k_counts = 2048.0
        #: the N behind the last position read, whole counts (the G4JNT stream prints it)
        self.last_counts = 0
        self._last_n = 0.0

    def read_n(self) -> float:
        """The pot in 10-bit units (N), checked against the reference."""
        ref = self.adc.read_reference_counts()
        full = self.adc.full_scale_counts
        lo, hi = self.reference_range
        if not lo * full <= ref <= hi * full:
            raise PartError(f"{self.name} pot: ADC reference reads {ref} counts, expected "
                            f"{lo * full:.0f}..{hi * full:.0f} (pot supply or wiring)")
        return 1024 * self.adc.read_counts() / ref

    def linearised(self, n: float) -> float:
        """P (ratiometric, 4096 N/(K-N)) or N (linear), before M, C, Z."""
        if self.law == "ratiometric":
            k = self.k_counts
            return 4096.0 * n / (k - n) if n < k else 4096.0 * 1023
        return float(n)

    def raw_units(self) -> float:
        """One fresh P (ratiometric) or N (linear): what two-point calibration fits."""
        return self.linearised(self.read_n())

    def last_units(self) -> float:
        """The linearised reading (P) behind the last position read."""
        return self.linearised(self._last_n)

    def _theta(self, units: float) -> float:
        return self.m_deg_per_unit * units + self.c_deg

    #: calibration keys that turn bearings, not the reading
    pointing_keys = ("Z",)

    @property
    def pointing_offset_deg(self) -> float:
        """Z: what the rotator adds to the axis angle to make a bearing."""
        return self.z_deg

    def read_deg(self) -> float:
        n = self.read_n()
        self._last_n, self.last_counts = n, round(n)
        return self._wrap(self._theta(self.linearised(n)))

    def set_reference_deg(self, angle_deg: float) -> None:
        # the axis angle is re-referenced through the intercept: Z stays the bearing
        # of the reference
        units = self.raw_units()
        self.c_deg += float(angle_deg) - self._theta(units)

    def calibration(self) -> dict[str, Any]:
        cal = {"M": self.m_deg_per_unit, "C": self.c_deg, "Z": self.z_deg}
        if self.law == "ratiometric":
            cal["K"] = self.k_counts
        return cal

    def load_calibration(self, values: dict[str, Any]) -> None:
        self.m_deg_per_unit = float(values.get("M", self.m_deg_per_unit))
        self.c_deg = float(values.get("C", self.c_deg))
        self.z_deg = float(values.get("Z", self.z_deg))
        if self.law == "ratiometric":
            self.k_counts = float(values.get("K", self.k_counts))


# ----------------------------------------------------------------- AS5600
class As5600Sensor(_Driver):
    """AS5600 on the axis (Berkeley): 12-bit angle minus a zero, modulo 360.

    The magnet status is checked on every read: no magnet, too weak or too strong is an
    error, never an angle. ``turns`` counts crossings of 0/360 (the unwrapped angle is
    ``unwrapped_deg()``), for a sensor geared to more than one turn per axis travel.
    ``reversed``: the chip counts up as the axis angle falls (AS5600 datasheet, "Direction":
    DIR to GND counts up turning clockwise seen from above the chip, DIR to VDD
    counterclockwise); its count is taken as 4096 - raw.
    """

    COUNTS = 4096

    def __init__(self, caps: SensorCaps, name: str, part: As5600Part, *, zero_deg: float = 0.0,
                 reversed: bool = False):
        super().__init__(caps, name)
        self.part = part
        self.zero_deg = float(zero_deg)
        self.reversed = bool(reversed)
        self.last_raw: int | None = None
        self.turns = 0

    def read_raw(self) -> int:
        st = self.part.magnet_status()
        if not st.detected or st.too_weak or st.too_strong:
            what = "too weak" if st.too_weak else "too strong" if st.too_strong else "not detected"
            raise PartError(f"{self.name} AS5600: magnet {what} (check the magnet gap)")
        raw = int(self.part.read_raw_angle()) & 0x0FFF
        if self.reversed:
            raw = -raw & 0x0FFF
        if self.last_raw is not None:
            jump = raw - self.last_raw
            if jump < -self.COUNTS // 2:
                self.turns += 1
            elif jump > self.COUNTS // 2:
                self.turns -= 1
        self.last_raw = raw
        return raw

    def read_deg(self) -> float:
        return self._wrap(self.read_raw() * (360.0 / self.COUNTS) - self.zero_deg)

    def unwrapped_deg(self) -> float:
        return self.turns * 360.0 + self.read_raw() * (360.0 / self.COUNTS) - self.zero_deg

    def set_reference_deg(self, angle_deg: float) -> None:
        raw = self.read_raw()
        self.zero_deg = raw * (360.0 / self.COUNTS) - float(angle_deg)

    def calibration(self) -> dict[str, Any]:
        return {"zero_deg": self.zero_deg}

    def load_calibration(self, values: dict[str, Any]) -> None:
        self.zero_deg = float(values.get("zero_deg", self.zero_deg))


# ----------------------------------------------------------------- compass
IDENTITY3 = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)


def _numbers(values: Any, n: int, what: str) -> tuple[float, ...]:
    t = tuple(float(v) for v in values)
    if len(t) != n or not all(math.isfinite(v) for v in t):
        raise ValueError(f"{what} must be {n} finite numbers, got {values!r}")
    return t


class AccelCalibration:
    """Accelerometer offsets and scales (SARCNET 12-direction calibration): gravity read
    as ``(raw - offset) / scale`` per axis; shared by the compass and the tilt driver."""

    def __init__(self) -> None:
        self.accel_offset: tuple[float, ...] = (0.0, 0.0, 0.0)
        self.accel_scale: tuple[float, ...] = (1.0, 1.0, 1.0)

    def corrected_accel(self, a: Sequence[float]) -> tuple[float, float, float]:
        o, k = self.accel_offset, self.accel_scale
        return ((a[0] - o[0]) / k[0], (a[1] - o[1]) / k[1], (a[2] - o[2]) / k[2])

    def accel_calibration(self) -> dict[str, Any]:
        return {"accel_offset": list(self.accel_offset), "accel_scale": list(self.accel_scale)}

    def load_accel_calibration(self, values: dict[str, Any]) -> None:
        offset = _numbers(values.get("accel_offset", self.accel_offset), 3, "accel_offset")
        scale = _numbers(values.get("accel_scale", self.accel_scale), 3, "accel_scale")
        if not all(v > 0 for v in scale):
            raise ValueError(f"accel_scale must be positive, got {values['accel_scale']!r}")
        self.accel_offset, self.accel_scale = offset, scale


def boom_frame(v: Sequence[float]) -> tuple[float, float, float]:
    """A vector from the LSM303's own axes, as seed 001 mounts the board (flat side on
    top of the boom: Y along the boresight; pointing north, level, X east and Z up; the
    chip's right-handed frame, the accelerometer reading +1 g on Z at rest) into the
    frame the heading and tilt below work in (x along the boresight, y to its right, z
    up). The irons and the accelerometer's offsets are the chip's: they are taken off
    before this turn, in the chip's frame."""
    return (float(v[1]), float(v[0]), float(v[2]))


def chip_horizontal(x: float, y: float) -> tuple[float, float]:
    """A horizontal vector of :func:`boom_frame` (a hard-iron centre fitted on
    :meth:`CompassSensor.read_field`) back on the chip's X and Y."""
    return float(y), float(x)


def tilt_compensate(m: Sequence[float], a: Sequence[float]) -> tuple[float, float]:
    """Horizontal field (x forward, y) of body-frame field ``m`` given gravity ``a``.

    Roll about x and pitch about y from the accelerometer, then the field rotated back
    to the horizontal plane (the usual LSM303 application-note formulas).
    """
    ax, ay, az = a
    mx, my, mz = m
    roll = math.atan2(ay, az)
    sr, cr = math.sin(roll), math.cos(roll)
    pitch = math.atan2(-ax, ay * sr + az * cr)
    sp, cp = math.sin(pitch), math.cos(pitch)
    return (mx * cp + my * sr * sp + mz * cr * sp, my * cr - mz * sr)


class CompassSensor(_Driver, AccelCalibration):
    """SARCNET azimuth: a magnetometer (LSM303D/AGR), tilt-compensated by its
    accelerometer when one is given, corrected for hard iron (an offset) and soft iron,
    heading + declination + offset, quantised to the sensor's resolution.

    Two soft-iron corrections, each set by its own procedure (which resets the other):
    ``mag_matrix`` (3x3, in the sensor's frame, from the hand-held 12-direction
    calibration) and ``soft_iron`` (2x2 on the horizontal field, from turning the antenna
    round on its mount). The chip is read on its own axes (irons, accelerometer offsets),
    then turned onto the boom's (:func:`boom_frame`): there heading psi gives the
    horizontal field (bx, by) = (cos psi, -sin psi), psi increasing clockwise.
    """

    def __init__(self, caps: SensorCaps, name: str, mag: Vector3, accel: Vector3 | None = None, *,
                 hard_iron: tuple[float, float] = (0.0, 0.0),
                 soft_iron: tuple[float, float, float, float] = (1.0, 0.0, 0.0, 1.0),
                 declination_deg: float = 0.0, offset_deg: float = 0.0):
        _Driver.__init__(self, caps, name)
        AccelCalibration.__init__(self)
        self.mag, self.accel = mag, accel
        self.hard_iron_x, self.hard_iron_y = hard_iron
        self.hard_iron_z = 0.0
        self.mag_matrix: tuple[float, ...] = IDENTITY3
        self.soft_iron = tuple(float(v) for v in soft_iron)
        self.declination_deg = float(declination_deg)
        self.offset_deg = float(offset_deg)

    def read_field(self) -> tuple[float, float]:
        """The raw horizontal field (bx, by): tilt-compensated, irons not removed."""
        m = boom_frame(self.mag.read_vector())
        if self.accel is None:
            return (m[0], m[1])
        return tilt_compensate(m, boom_frame(self.corrected_accel(self.accel.read_vector())))

    def _corrected(self) -> tuple[float, float]:
        """Hard iron off (in the sensor's own frame, where it sits) and the sensor-frame
        soft iron, then tilt compensation, then the horizontal soft iron: the
        horizontal field the heading comes from."""
        m = self.mag.read_vector()
        m = (m[0] - self.hard_iron_x, m[1] - self.hard_iron_y, m[2] - self.hard_iron_z)
        k = self.mag_matrix
        if k != IDENTITY3:
            m = (k[0] * m[0] + k[1] * m[1] + k[2] * m[2], k[3] * m[0] + k[4] * m[1] + k[5] * m[2],
                 k[6] * m[0] + k[7] * m[1] + k[8] * m[2])
        m = boom_frame(m)
        x, y = (m[0], m[1]) if self.accel is None else \
            tilt_compensate(m, boom_frame(self.corrected_accel(self.accel.read_vector())))
        s = self.soft_iron
        if s != (1.0, 0.0, 0.0, 1.0):
            x, y = s[0] * x + s[1] * y, s[2] * x + s[3] * y
        return x, y

    def _heading(self) -> float:
        x, y = self._corrected()
        return math.degrees(math.atan2(-y, x)) + self.declination_deg + self.offset_deg

    def read_deg(self) -> float:
        return self._wrap(quantise(self._heading(), self.caps.resolution_deg))

    def set_reference_deg(self, angle_deg: float) -> None:
        d = float(angle_deg) - self._heading()
        self.offset_deg += wrap180_deg(d)

    def calibration(self) -> dict[str, Any]:
        return {"hard_iron_x": self.hard_iron_x, "hard_iron_y": self.hard_iron_y,
                "hard_iron_z": self.hard_iron_z, "mag_matrix": list(self.mag_matrix),
                "soft_iron": list(self.soft_iron), **self.accel_calibration(),
                "declination_deg": self.declination_deg, "offset_deg": self.offset_deg}

    def load_calibration(self, values: dict[str, Any]) -> None:
        soft = _numbers(values.get("soft_iron", self.soft_iron), 4, "soft_iron")
        matrix = _numbers(values.get("mag_matrix", self.mag_matrix), 9, "mag_matrix")
        self.load_accel_calibration(values)
        self.soft_iron, self.mag_matrix = soft, matrix
        self.hard_iron_x = float(values.get("hard_iron_x", self.hard_iron_x))
        self.hard_iron_y = float(values.get("hard_iron_y", self.hard_iron_y))
        self.hard_iron_z = float(values.get("hard_iron_z", self.hard_iron_z))
        self.declination_deg = float(values.get("declination_deg", self.declination_deg))
        self.offset_deg = float(values.get("offset_deg", self.offset_deg))


class TiltSensor(_Driver, AccelCalibration):
    """SARCNET elevation: the boom's tilt from the accelerometer, atan2(ax, az), after
    the accelerometer's offsets and scales."""

    def __init__(self, caps: SensorCaps, name: str, accel: Vector3, *, offset_deg: float = 0.0):
        _Driver.__init__(self, caps, name)
        AccelCalibration.__init__(self)
        self.accel = accel
        self.offset_deg = float(offset_deg)

    def _tilt(self) -> float:
        """Tilt in -90..270: straight down to over the top and on (the SARCNET
        reads -90..180; atan2's -180..180 would call 180 -180)."""
        ax, _, az = boom_frame(self.corrected_accel(self.accel.read_vector()))
        t = math.degrees(math.atan2(ax, az))
        return t + 360.0 if t < -90.0 else t

    def read_deg(self) -> float:
        t = self._tilt()
        return self._wrap(quantise(t + self.offset_deg, self.caps.resolution_deg))

    def set_reference_deg(self, angle_deg: float) -> None:
        t = self._tilt()
        self.offset_deg += float(angle_deg) - (t + self.offset_deg)

    def calibration(self) -> dict[str, Any]:
        return {"offset_deg": self.offset_deg, **self.accel_calibration()}

    def load_calibration(self, values: dict[str, Any]) -> None:
        self.load_accel_calibration(values)
        self.offset_deg = float(values.get("offset_deg", self.offset_deg))
