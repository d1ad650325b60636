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

import dataclasses
import math
import random
import time
from typing import Any, Sequence

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

    def absolute_count(self) -> int:
        """The count from the shaft's 0 deg (where an index mark is placed)."""
        return self._raw()

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


def rotation_taking(u: Sequence[float], v: Sequence[float], twist_deg: float = 0.0) -> tuple[float, ...]:
    """Row-major 3x3 rotation that turns direction ``u`` onto direction ``v``, then
    turns ``twist_deg`` about ``v`` (Rodrigues' formula)."""
    def unit(w: Sequence[float]) -> list[float]:
        n = math.sqrt(sum(c * c for c in w))
        return [c / n for c in w]

    def rodrigues(axis: Sequence[float], angle: float) -> list[list[float]]:
        x, y, z = axis
        c, s, t = math.cos(angle), math.sin(angle), 1.0 - math.cos(angle)
        return [[c + x * x * t, x * y * t - z * s, x * z * t + y * s],
                [y * x * t + z * s, c + y * y * t, y * z * t - x * s],
                [z * x * t - y * s, z * y * t + x * s, c + z * z * t]]

    a, b = unit(u), unit(v)
    cross = [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
    dot = max(-1.0, min(1.0, sum(p * q for p, q in zip(a, b))))
    n = math.sqrt(sum(c * c for c in cross))
    if n < 1e-12:   # parallel or opposite: any axis at right angles to u
        perp = [0.0, -a[2], a[1]] if abs(a[0]) < 0.9 else [-a[2], 0.0, a[0]]
        first = rodrigues(unit(perp), 0.0 if dot > 0 else math.pi)
    else:
        first = rodrigues([c / n for c in cross], math.atan2(n, dot))
    second = rodrigues(b, math.radians(twist_deg))
    return tuple(sum(second[i][k] * first[k][j] for k in range(3)) for i in range(3) for j in range(3))


def _apply(m: Sequence[float], v: Sequence[float]) -> tuple[float, float, float]:
    return (m[0] * v[0] + m[1] * v[1] + m[2] * v[2], m[3] * v[0] + m[4] * v[1] + m[5] * v[2],
            m[6] * v[0] + m[7] * v[1] + m[8] * v[2])


class SensorBoard:
    """The SARCNET sensor board (one LSM303: magnetometer + accelerometer) as a hand can
    hold it for the 12-direction calibration.

    Mounted (the default) its parts read the boom's mechanics. :meth:`hold` takes it off
    the boom: both parts then read the earth's field and gravity as seen by the board in
    that orientation, with the board's own hard/soft iron and accelerometer errors
    (:class:`SimSensorParams`). The level frame: x magnetic north, z down (where level
    gravity reads (0, 0, 1) g); the field there is (1, 0, tan dip) horizontal units.
    """

    FACES = {"+x": (1, 0, 0), "-x": (-1, 0, 0), "+y": (0, 1, 0), "-y": (0, -1, 0),
             "+z": (0, 0, 1), "-z": (0, 0, -1)}

    def __init__(self, params: SimSensorParams):
        self.params = params
        #: level frame -> board frame, row-major 3x3; None: mounted on the boom
        self.rotation: tuple[float, ...] | None = None

    @property
    def held(self) -> bool:
        return self.rotation is not None

    def field_level(self) -> tuple[float, float, float]:
        return (1.0, 0.0, math.tan(math.radians(self.params.dip_deg)))

    def hold(self, rotation: Sequence[float]) -> None:
        """Hold the board so that level-frame vectors v read as ``rotation @ v``."""
        r = tuple(float(v) for v in rotation)
        if len(r) != 9 or not all(math.isfinite(v) for v in r):
            raise ValueError(f"rotation must be 9 finite numbers, got {rotation!r}")
        self.rotation = r

    def point(self, face: str, along: str, twist_deg: float = 0.0) -> None:
        """Hold the board with ``face`` (+x, -x, +y, -y, +z, -z) along the earth's
        magnetic field (``along="field"``) or gravity (``"gravity"``), turned
        ``twist_deg`` about that direction."""
        target = self.field_level() if along == "field" else (0.0, 0.0, 1.0)
        if along not in ("field", "gravity") or face not in self.FACES:
            raise ValueError(f"face +x..-z along field|gravity, got {face!r} along {along!r}")
        # the board frame's face direction must read as the target: R @ target = face
        self.hold(rotation_taking(target, self.FACES[face], twist_deg))

    def release(self) -> None:
        """Back on the boom."""
        self.rotation = None

    def change_conditions(self, **changes: Any) -> None:
        """The magnetic conditions near the board (or its accelerometer) change: any of
        :class:`SimSensorParams`' hard_iron_x/y/z, soft_iron, dip_deg, accel_bias_g,
        accel_scale (the reason the document gives to calibrate again)."""
        allowed = {"hard_iron_x", "hard_iron_y", "hard_iron_z", "soft_iron", "dip_deg",
                   "accel_bias_g", "accel_scale"}
        unknown = set(changes) - allowed
        if unknown:
            raise ValueError(f"unknown board conditions {sorted(unknown)}; expected {sorted(allowed)}")
        self.params = dataclasses.replace(self.params, **changes)

    def magnetic(self, mounted: tuple[float, float, float]) -> tuple[float, float, float]:
        """The magnetometer's reading before noise: soft then hard iron on the field."""
        p = self.params
        v = mounted if self.rotation is None else _apply(self.rotation, self.field_level())
        if p.soft_iron != (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0):
            v = _apply(p.soft_iron, v)
        return (v[0] + p.hard_iron_x, v[1] + p.hard_iron_y, v[2] + p.hard_iron_z)

    def gravity(self, mounted: tuple[float, float, float]) -> tuple[float, float, float]:
        """The accelerometer's reading before noise: scale and bias on gravity."""
        p = self.params
        v = mounted if self.rotation is None else _apply(self.rotation, (0.0, 0.0, 1.0))
        k, b = p.accel_scale, p.accel_bias_g
        return (k[0] * v[0] + b[0], k[1] * v[1] + b[1], k[2] * v[2] + b[2])


class SimMagnetometer(_SimPart):
    """The chip's field for magnetic heading psi (horizontal strength 1, level), on its
    own axes as seed 001 mounts it: (-sin psi + hx, cos psi + hy, 0) with hard iron hx,
    hy, plus noise (turning clockwise, the field swings from Y towards -X); off the
    boom, what its :class:`SensorBoard` is held to see."""

    def __init__(self, *args: Any, noise_deg: float, board: SensorBoard | None = None):
        super().__init__(*args)
        self.noise_deg = noise_deg
        self.board = board or SensorBoard(self._p)

    def read_vector(self) -> tuple[float, float, float]:
        psi = math.radians(self._angle() - self._p.declination_deg)
        sigma = math.radians(self.noise_deg)
        # on the boom as seed 001 mounts the board: X to the right of the boresight
        # (east when pointing north), Y along it, Z up (the chip's own axes)
        x, y, z = self.board.magnetic((-math.sin(psi), math.cos(psi), 0.0))
        return (x + self._gauss(sigma), y + self._gauss(sigma),
                z + self._gauss(sigma) if self.board.held else z)


class SimAccelerometer(_SimPart):
    """The chip's accelerometer on the boom raised to elevation el: (0, sin el, cos el)
    g (at rest it reads +1 g up its Z), plus noise; off the boom, what its
    :class:`SensorBoard` is held to see."""

    def __init__(self, *args: Any, noise_deg: float, board: SensorBoard | None = None):
        super().__init__(*args)
        self.noise_deg = noise_deg
        self.board = board or SensorBoard(self._p)

    def read_vector(self) -> tuple[float, float, float]:
        el = math.radians(self._angle())
        sigma = math.radians(self.noise_deg)
        # the boom raised by el turns the chip about its X axis: Y (the boresight) up
        gx, gy, gz = self.board.gravity((0.0, math.sin(el), math.cos(el)))
        return (gx + self._gauss(sigma) if self.board.held else gx, gy + self._gauss(sigma),
                gz + self._gauss(sigma))


class SimStageAccelerometer(SimAccelerometer):
    """The compass board's accelerometer where no tilt sensor shares it (a single-axis
    rotator): the board sits level on the azimuth stage, so on the boom it reads plain
    gravity (as the sim's magnetometer reads the level field); in the hand, what its
    :class:`SensorBoard` is held to see. It gives the 12-direction calibration the
    accelerometer half it needs, as the LSM303's own does on the gpio backend."""

    def _angle(self) -> float:
        return 0.0


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
                drive: DirectionTracker, board: SensorBoard | None = None,
                compass_accel_rng: random.Random | None = None) -> FaultySensor:
    """The driver for ``caps.kind`` on simulated parts. ``referenced``: incremental
    sensors start referenced to the true angle (a fresh installation), else they read
    0 + counts. ``drive``: where a pulse counter takes its direction from.
    ``compass_accel_rng``: the compass has an accelerometer of its own (no elevation
    axis whose tilt sensor would carry it), with this noise stream."""
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
        accel = None if compass_accel_rng is None else SimStageAccelerometer(
            axis, params, compass_accel_rng, noise, noise_deg=caps.noise_deg, board=board)
        driver = CompassSensor(caps, axis_name, SimMagnetometer(*part, noise_deg=caps.noise_deg, board=board),
                               accel, hard_iron=(params.hard_iron_x, params.hard_iron_y),
                               declination_deg=params.declination_deg)
    elif kind == "magnetometer":
        driver = TiltSensor(caps, axis_name, SimAccelerometer(*part, noise_deg=caps.noise_deg, board=board))
    else:  # pragma: no cover - SensorKind is a closed Literal
        raise ValueError(f"unknown sensor kind {kind!r}")
    if referenced and kind in ("encoder", "pulse"):
        driver.set_reference_deg(axis.sensor_side_deg())
    return FaultySensor(driver)
