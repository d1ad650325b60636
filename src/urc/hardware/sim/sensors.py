"""Simulated sensor *parts*, and the drivers the simulator builds on them.

The simulator provides what the real chips deliver (:mod:`urc.hardware.parts`): an x4
quadrature count, unsigned pulses, ADC counts, the AS5600's raw angle and magnet status,
magnetometer and accelerometer vectors. The position sensor the controller sees is the
same driver (:mod:`urc.hardware.drivers.sensors`) real iron uses, so conversion and
calibration code run identically on both.

Each part reads the mechanical state of its :class:`AxisPhysics` (load or gear side,
per ``SimSensorParams.on_load``) and models quantisation, noise and quirks. Noise comes
from a seeded ``random.Random``, so a run is exactly repeatable. Injected faults
(stuck, jump, dead) are applied on top of the driver's reading by :class:`FaultySensor`.
"""

from __future__ import annotations

import math
import random
import time
from typing import Any

from ...caps import SensorCaps
from ...errors import SensorError
from ..drivers.motors import DirectionTracker
from ..drivers.sensors import (As5600Sensor, CompassSensor, PotSensor, QuadratureEncoder,
                               SpidPulseSensor, TiltSensor, wrap)
from ..parts import MagnetStatus
from .params import SimSensorParams
from .physics import AxisPhysics


class _SimPart:
    def __init__(self, axis: AxisPhysics, params: SimSensorParams, rng: random.Random, noise: bool):
        self._axis = axis
        self._p = params
        self._rng = rng
        self._noise = noise

    def _angle(self) -> float:
        return self._axis.sensor_side_deg()

    def _gauss(self, sigma: float) -> float:
        return self._rng.gauss(0.0, sigma) if (self._noise and sigma > 0.0) else 0.0


class SimQuadratureCounter(_SimPart):
    """x4 count of an encoder with ``counts_per_deg`` counts per degree; 0 at power-on.
    The index mark (``SimSensorParams.index_deg``) latches the count when passed."""

    def __init__(self, *args: Any, counts_per_deg: int):
        super().__init__(*args)
        self.counts_per_deg = counts_per_deg
        self._c0 = self._raw()
        idx = self._p.index_deg
        self._index_side = None if idx is None else (self._angle() >= idx)
        self._index_count: int | None = None

    def _raw(self) -> int:
        return math.floor(self._angle() * self.counts_per_deg + 1e-9)

    def count(self) -> int:
        return self._raw() - self._c0

    def index_count(self) -> int | None:
        return self._index_count

    def errors(self) -> int:
        return 0

    def after_advance(self) -> None:
        if self._index_side is not None:
            side = self._angle() >= self._p.index_deg  # type: ignore[operator]
            if side != self._index_side:
                self._index_side = side
                self._index_count = self.count()


class SimPulseCounter(_SimPart):
    """The reed contact's pulses as the physics loop saw every edge (no direction)."""

    def count(self) -> int:
        return self._axis.pulse_edges


class SimPotAdc(_SimPart):
    """A pot on a 10-bit ADC whose reference is the pot supply (full scale 1024).

    ``ratiometric`` (G4JNT loaded pot): N = 2048 x/(1+x); ``linear``: N = 1023 x.
    """

    full_scale_counts = 1024

    def wiper_fraction(self) -> float:
        p = self._p
        x = (self._angle() - p.pot_start_deg) / p.pot_span_deg
        return 0.0 if x < 0.0 else 1.0 if x > 1.0 else x

    def read_counts(self, noisy: bool = True) -> int:
        x = self.wiper_fraction()
        ideal = 2048.0 * x / (1.0 + x) if self._p.pot_law == "ratiometric" else 1023.0 * x
        n = round(ideal + (self._gauss(self._p.adc_noise_counts) if noisy else 0.0))
        return 0 if n < 0 else 1023 if n > 1023 else n

    def read_reference_counts(self) -> int:
        return self.full_scale_counts


class SimAs5600(_SimPart):
    """AS5600 raw angle (12 bits, rare one-count glitches) and a magnet in its window."""

    COUNTS = 4096

    def __init__(self, *args: Any):
        super().__init__(*args)
        self.status = MagnetStatus(detected=True)

    def read_raw_angle(self, noisy: bool = True) -> int:
        c = round(self._angle() / 360.0 * self.COUNTS)
        if noisy and self._noise and self._p.glitch_prob > 0.0:
            if self._rng.random() < self._p.glitch_prob:
                c += 1 if self._rng.random() < 0.5 else -1
        return c % self.COUNTS

    def magnet_status(self) -> MagnetStatus:
        return self.status


class SimMagnetometer(_SimPart):
    """Body-frame field for magnetic heading psi (horizontal strength 1, level):
    (cos psi + hx, -sin psi + hy, 0) with hard iron hx, hy, plus noise."""

    def __init__(self, *args: Any, noise_deg: float):
        super().__init__(*args)
        self.noise_deg = noise_deg

    def read_vector(self) -> tuple[float, float, float]:
        p = self._p
        psi = math.radians(self._angle() - p.declination_deg)
        sigma = math.radians(self.noise_deg)
        return (math.cos(psi) + p.hard_iron_x + self._gauss(sigma),
                -math.sin(psi) + p.hard_iron_y + self._gauss(sigma), 0.0)


class SimAccelerometer(_SimPart):
    """Gravity on the boom tilted to elevation el: (sin el, 0, cos el) g, plus noise."""

    def __init__(self, *args: Any, noise_deg: float):
        super().__init__(*args)
        self.noise_deg = noise_deg

    def read_vector(self) -> tuple[float, float, float]:
        el = math.radians(self._angle())
        sigma = math.radians(self.noise_deg)
        gx = math.sin(el) + self._gauss(sigma)
        gz = math.cos(el) + self._gauss(sigma)
        return (gx, 0.0, gz)


class FaultySensor:
    """A driver with the simulator's injected sensor faults on top of its reading.

    Everything but ``read_deg`` is the driver's own (``__getattr__``), so calibration
    sees the driver's declared interface.
    """

    def __init__(self, driver: Any):
        self.driver = driver
        self.fault_dead = False
        self.fault_jump_deg = 0.0
        self.fault_stuck_deg: float | None = None
        #: slow_read: the next ``fault_slow_reads`` reads each block this long (a bus
        #: timing out, clock stretching): a stall inside the control tick
        self.fault_slow_s = 0.0
        self.fault_slow_reads = 0

    def __getattr__(self, name: str) -> Any:
        return getattr(self.__dict__["driver"], name)

    def read_deg(self) -> float:
        d = self.driver
        if self.fault_slow_reads > 0:
            self.fault_slow_reads -= 1
            time.sleep(self.fault_slow_s)
        if self.fault_dead:
            raise SensorError(f"{d.name} sensor ({d.caps.kind}): no reading")
        if self.fault_stuck_deg is not None:
            return self.fault_stuck_deg
        return wrap(d.read_deg() + self.fault_jump_deg, d.caps.modulo_deg)

    def freeze(self) -> None:
        """Fault: the reading stops changing at its present value."""
        self.fault_stuck_deg = None
        self.fault_stuck_deg = self.read_deg()

    def after_advance(self) -> None:
        """Called by the world after each physics advance (index marks etc.)."""
        hook = getattr(self.driver, "counter", None)
        if isinstance(hook, SimQuadratureCounter):
            hook.after_advance()


def make_sensor(axis_name: str, caps: SensorCaps, axis: AxisPhysics, params: SimSensorParams,
                rng: random.Random, *, noise: bool, referenced: bool,
                drive: DirectionTracker) -> FaultySensor:
    """The driver for ``caps.kind`` on simulated parts. ``referenced``: incremental
    sensors start referenced to the true angle (a fresh installation), else they read
    0 + counts. ``drive``: where a pulse counter takes its direction from."""
    kind = caps.kind
    part = (axis, params, rng, noise)
    driver: Any
    if kind == "encoder":
        driver = QuadratureEncoder(caps, axis_name, SimQuadratureCounter(
            *part, counts_per_deg=round(1.0 / caps.resolution_deg)))
    elif kind == "pulse":
        driver = SpidPulseSensor(caps, axis_name, SimPulseCounter(*part), drive)
    elif kind == "pot":
        full = 4096.0 if params.pot_law == "ratiometric" else 1023.0
        driver = PotSensor(caps, axis_name, SimPotAdc(*part), law=params.pot_law,
                           m=params.pot_span_deg / full, c=params.pot_start_deg)
    elif kind == "as5600":
        driver = As5600Sensor(caps, axis_name, SimAs5600(*part))
    elif kind == "magnetometer" and axis_name == "az":
        driver = CompassSensor(caps, axis_name, SimMagnetometer(*part, noise_deg=caps.noise_deg),
                               hard_iron=(params.hard_iron_x, params.hard_iron_y),
                               declination_deg=params.declination_deg)
    elif kind == "magnetometer":
        driver = TiltSensor(caps, axis_name, SimAccelerometer(*part, noise_deg=caps.noise_deg))
    else:  # pragma: no cover - SensorKind is a closed Literal
        raise ValueError(f"unknown sensor kind {kind!r}")
    if referenced and kind in ("encoder", "pulse"):
        driver.set_reference_deg(axis.sensor_side_deg())
    return FaultySensor(driver)
