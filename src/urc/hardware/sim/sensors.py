"""Simulated position sensors (implement ``urc.hardware.interfaces.PositionSensor``).

Each reads the mechanical state of its :class:`AxisPhysics` (load or gear side, per
``SimSensorParams.on_load``) and models the real part's quantisation, noise and
quirks. Noise comes from a seeded ``random.Random``, so a run is exactly repeatable.
Injected faults (stuck, jump, dead) are applied here, on top of the reading.
"""

from __future__ import annotations

import math
import random
import time
from typing import Any

from ...caps import SensorCaps
from ...errors import SensorError
from .params import SimSensorParams
from .physics import AxisPhysics


class SimSensor:
    """Common part: fault handling and modulo wrap around ``_read()``."""

    def __init__(self, caps: SensorCaps, axis: AxisPhysics, params: SimSensorParams,
                 rng: random.Random, noise: bool, name: str):
        self.caps = caps
        self.name = name
        self._axis = axis
        self._p = params
        self._rng = rng
        self._noise = noise
        # injected faults
        self.fault_dead = False
        self.fault_jump_deg = 0.0
        self.fault_stuck_deg: float | None = None
        #: slow_read: the next ``fault_slow_reads`` reads each block this long (a bus
        #: timing out, clock stretching): a stall inside the control tick
        self.fault_slow_s = 0.0
        self.fault_slow_reads = 0

    # -- PositionSensor -----------------------------------------------------
    def read_deg(self) -> float:
        if self.fault_slow_reads > 0:
            self.fault_slow_reads -= 1
            time.sleep(self.fault_slow_s)
        if self.fault_dead:
            raise SensorError(f"{self.name} sensor ({self.caps.kind}): no reading")
        if self.fault_stuck_deg is not None:
            return self.fault_stuck_deg
        return self._wrap(self._read(noisy=True) + self.fault_jump_deg)

    def set_reference_deg(self, angle_deg: float) -> None:
        raise NotImplementedError

    def calibration(self) -> dict[str, Any]:
        return {}

    def load_calibration(self, values: dict[str, Any]) -> None:
        pass

    # -- internals ----------------------------------------------------------
    def _read(self, noisy: bool) -> float:
        raise NotImplementedError

    def _wrap(self, v: float) -> float:
        m = self.caps.modulo_deg
        if m:
            v %= m
            if v >= m:        # -1e-17 % 360 == 360.0
                v = 0.0
        return v

    def _angle(self) -> float:
        return self._axis.sensor_side_deg()

    def _gauss(self, sigma: float) -> float:
        return self._rng.gauss(0.0, sigma) if (self._noise and sigma > 0.0) else 0.0

    def freeze(self) -> None:
        """Fault: the reading stops changing at its present value."""
        try:
            self.fault_stuck_deg = self._wrap(self._read(noisy=False) + self.fault_jump_deg)
        except SensorError:
            self.fault_stuck_deg = self._wrap(self._angle())

    def after_advance(self) -> None:
        """Called by the world after each physics advance (index marks etc.)."""


class _Incremental(SimSensor):
    """Counts x resolution + reference; counts start at 0 at power-on."""

    reference_deg = 0.0

    def counts(self) -> int:
        raise NotImplementedError

    def _read(self, noisy: bool) -> float:
        return self.counts() * self.caps.resolution_deg + self.reference_deg

    def set_reference_deg(self, angle_deg: float) -> None:
        self.reference_deg = float(angle_deg) - self.counts() * self.caps.resolution_deg

    def calibration(self) -> dict[str, Any]:
        return {"reference_deg": self.reference_deg}

    def load_calibration(self, values: dict[str, Any]) -> None:
        if "reference_deg" in values:
            self.reference_deg = float(values["reference_deg"])


class EncoderSensor(_Incremental):
    """Incremental quadrature encoder: signed counts, 1/resolution counts per degree."""

    def __init__(self, *args: Any, **kw: Any):
        super().__init__(*args, **kw)
        self.counts_per_deg = round(1.0 / self.caps.resolution_deg)
        self._c0 = self._raw_counts()
        idx = self._p.index_deg
        self._index_side = None if idx is None else (self._angle() >= idx)
        self._index_seen = False
        self.index_counts: int | None = None

    def _raw_counts(self) -> int:
        return math.floor(self._angle() * self.counts_per_deg + 1e-9)

    def counts(self) -> int:
        return self._raw_counts() - self._c0

    def index_seen(self) -> bool:
        """True once the index mark (``SimSensorParams.index_deg``) has passed."""
        return self._index_seen

    def after_advance(self) -> None:
        if self._index_side is not None:
            side = self._angle() >= self._p.index_deg  # type: ignore[operator]
            if side != self._index_side:
                self._index_side = side
                self._index_seen = True
                self.index_counts = self.counts()


class PulseSensor(_Incremental):
    """SPID/BIG-RAS single-channel pulses: no direction information.

    The counter (kept by the physics loop, which sees every edge) adds or subtracts
    according to the direction of the motor's last non-zero *commanded* drive, so
    coasting after a reversal, backlash wobble or a reversed motor make it miscount.
    """

    def counts(self) -> int:
        return self._axis.pulse_count


class PotSensor(SimSensor):
    """Potentiometer on a 10-bit ADC.

    ``ratiometric`` (G4JNT): the loaded pot gives N = 2048 x/(1+x); the driver
    linearises P = 4096 N/(2048-N) (= 4096 x) and bearing = M*P + C + Z.
    ``linear`` (G-5500): N = 1023 x, bearing = M*N + C + Z.
    """

    def __init__(self, *args: Any, **kw: Any):
        super().__init__(*args, **kw)
        p = self._p
        full = 4096.0 if p.pot_law == "ratiometric" else 1023.0
        self.m_deg_per_unit = p.pot_span_deg / full
        self.c_deg = p.pot_start_deg
        self.z_deg = 0.0
        #: ratiometric: 1024 x the divider's drive gain as the driver assumes it (the
        #: G4JNT constant K, 2048 for its gain of 2); P = 4096 N / (K - N)
        self.k_counts = 2048.0
        self.last_counts = 0

    def wiper_fraction(self) -> float:
        p = self._p
        x = (self._angle() - p.pot_start_deg) / p.pot_span_deg
        return 0.0 if x < 0.0 else 1.0 if x > 1.0 else x

    def adc_counts(self, noisy: bool = True) -> int:
        x = self.wiper_fraction()
        ideal = 2048.0 * x / (1.0 + x) if self._p.pot_law == "ratiometric" else 1023.0 * x
        n = round(ideal + (self._gauss(self._p.adc_noise_counts) if noisy else 0.0))
        return 0 if n < 0 else 1023 if n > 1023 else n

    def linearised(self, n: int) -> float:
        """The driver's P (ratiometric) or N (linear) before M, C, Z."""
        if self._p.pot_law == "ratiometric":
            return 4096.0 * n / (self.k_counts - n) if n < self.k_counts else 4096.0 * 1023
        return float(n)

    def _read(self, noisy: bool) -> float:
        n = self.adc_counts(noisy)
        if noisy:
            self.last_counts = n
        return self.m_deg_per_unit * self.linearised(n) + self.c_deg + self.z_deg

    def set_reference_deg(self, angle_deg: float) -> None:
        self.z_deg += float(angle_deg) - self._read(noisy=False)

    def calibration(self) -> dict[str, Any]:
        cal = {"M": self.m_deg_per_unit, "C": self.c_deg, "Z": self.z_deg}
        if self._p.pot_law == "ratiometric":
            cal["K"] = self.k_counts
        return cal

    def load_calibration(self, values: dict[str, Any]) -> None:
        self.m_deg_per_unit = float(values.get("M", self.m_deg_per_unit))
        self.c_deg = float(values.get("C", self.c_deg))
        self.z_deg = float(values.get("Z", self.z_deg))
        if self._p.pot_law == "ratiometric":
            self.k_counts = float(values.get("K", self.k_counts))

    def last_units(self) -> float:
        """The linearised reading (P) behind the last position read."""
        return self.linearised(self.last_counts)


class As5600Sensor(SimSensor):
    """AS5600 12-bit absolute magnetic encoder on the axis (modulo 360)."""

    COUNTS = 4096

    def __init__(self, *args: Any, **kw: Any):
        super().__init__(*args, **kw)
        self.zero_deg = 0.0

    def raw_counts(self, noisy: bool = True) -> int:
        c = round(self._angle() / 360.0 * self.COUNTS)
        if noisy and self._noise and self._p.glitch_prob > 0.0:
            if self._rng.random() < self._p.glitch_prob:
                c += 1 if self._rng.random() < 0.5 else -1
        return c % self.COUNTS

    def _read(self, noisy: bool) -> float:
        return self.raw_counts(noisy) * (360.0 / self.COUNTS) - self.zero_deg

    def set_reference_deg(self, angle_deg: float) -> None:
        self.zero_deg = self.raw_counts(noisy=False) * (360.0 / self.COUNTS) - float(angle_deg)

    def calibration(self) -> dict[str, Any]:
        return {"zero_deg": self.zero_deg}

    def load_calibration(self, values: dict[str, Any]) -> None:
        self.zero_deg = float(values.get("zero_deg", self.zero_deg))


class CompassSensor(SimSensor):
    """SARCNET azimuth: heading from a (tilt-compensated) magnetometer.

    Body-frame horizontal field for magnetic heading psi (field strength 1):
    bx = cos psi + hx, by = -sin psi + hy (hard iron hx, hy) plus noise. The driver
    subtracts its hard-iron estimate, takes atan2 and adds the declination. Shipped
    calibrated: the estimate equals the simulated hard iron.
    """

    def __init__(self, *args: Any, **kw: Any):
        super().__init__(*args, **kw)
        p = self._p
        self.hard_iron_x, self.hard_iron_y = p.hard_iron_x, p.hard_iron_y
        self.declination_deg = p.declination_deg
        self.offset_deg = 0.0

    def _heading(self, noisy: bool) -> float:
        p = self._p
        psi = math.radians(self._angle() - p.declination_deg)
        sigma = math.radians(self.caps.noise_deg) if noisy else 0.0
        bx = math.cos(psi) + p.hard_iron_x + self._gauss(sigma)
        by = -math.sin(psi) + p.hard_iron_y + self._gauss(sigma)
        h = math.degrees(math.atan2(-(by - self.hard_iron_y), bx - self.hard_iron_x))
        return h + self.declination_deg + self.offset_deg

    def _read(self, noisy: bool) -> float:
        q = self.caps.resolution_deg
        return round(self._heading(noisy) / q) * q

    def set_reference_deg(self, angle_deg: float) -> None:
        d = float(angle_deg) - self._heading(noisy=False)
        self.offset_deg += (d + 180.0) % 360.0 - 180.0

    def calibration(self) -> dict[str, Any]:
        return {"hard_iron_x": self.hard_iron_x, "hard_iron_y": self.hard_iron_y,
                "declination_deg": self.declination_deg, "offset_deg": self.offset_deg}

    def load_calibration(self, values: dict[str, Any]) -> None:
        self.hard_iron_x = float(values.get("hard_iron_x", self.hard_iron_x))
        self.hard_iron_y = float(values.get("hard_iron_y", self.hard_iron_y))
        self.declination_deg = float(values.get("declination_deg", self.declination_deg))
        self.offset_deg = float(values.get("offset_deg", self.offset_deg))


class TiltSensor(SimSensor):
    """SARCNET elevation: accelerometer tilt angle atan2(g sin el, g cos el) + noise."""

    def __init__(self, *args: Any, **kw: Any):
        super().__init__(*args, **kw)
        self.offset_deg = 0.0

    def _tilt(self, noisy: bool) -> float:
        el = math.radians(self._angle())
        sigma = math.radians(self.caps.noise_deg) if noisy else 0.0
        gx = math.sin(el) + self._gauss(sigma)
        gz = math.cos(el) + self._gauss(sigma)
        return math.degrees(math.atan2(gx, gz)) + self.offset_deg

    def _read(self, noisy: bool) -> float:
        q = self.caps.resolution_deg
        return round(self._tilt(noisy) / q) * q

    def set_reference_deg(self, angle_deg: float) -> None:
        self.offset_deg += float(angle_deg) - self._tilt(noisy=False)

    def calibration(self) -> dict[str, Any]:
        return {"offset_deg": self.offset_deg}

    def load_calibration(self, values: dict[str, Any]) -> None:
        self.offset_deg = float(values.get("offset_deg", self.offset_deg))


def make_sensor(axis_name: str, caps: SensorCaps, axis: AxisPhysics, params: SimSensorParams,
                rng: random.Random, *, noise: bool, referenced: bool) -> SimSensor:
    """Build the sensor for ``caps.kind``; ``referenced``: incremental sensors start
    referenced to the true angle (a fresh installation), else they read 0 + counts."""
    kind = caps.kind
    cls: type[SimSensor]
    if kind == "encoder":
        cls = EncoderSensor
    elif kind == "pulse":
        cls = PulseSensor
    elif kind == "pot":
        cls = PotSensor
    elif kind == "as5600":
        cls = As5600Sensor
    elif kind == "magnetometer":
        cls = CompassSensor if axis_name == "az" else TiltSensor
    else:  # pragma: no cover - SensorKind is a closed Literal
        raise ValueError(f"unknown sensor kind {kind!r}")
    sensor = cls(caps, axis, params, rng, noise, axis_name)
    if referenced and isinstance(sensor, _Incremental):
        sensor.set_reference_deg(axis.sensor_side_deg())
    return sensor
