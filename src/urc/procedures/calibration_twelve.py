"""SARCNET's hand-held 12-direction calibration (seed 001) as a state machine fed with
readings: which faces have been held along the field and gravity, and the fits once all
are done. Applying the result to the sensors is :func:`urc.procedures.calibration.apply_twelve_direction`."""

from __future__ import annotations

import math
from typing import Any, Sequence

import numpy as np

from .calibration_maths import CalibrationError, EllipsoidFit, fit_ellipsoid


class TwelveDirectionCalibration:
    """SARCNET hand-held calibration (seed 001): the sensor board, off the boom, is
    pointed with each of its six faces along the earth's magnetic field and along gravity,
    12 directions; the magnetometer's and accelerometer's offsets and scales (and the
    magnetometer's soft iron) come from ellipsoids fitted to the readings.

    Pure state: :meth:`feed` takes one raw reading pair at a time. A direction counts as
    done once the board has been held within ``TOLERANCE_DEG`` of it, still, for
    ``HOLD_SAMPLES`` readings in a row; only still readings enter the fits (the original
    warns that a bump upsets the accelerometer calibration).
    """

    FACES = ("+X", "-X", "+Y", "-Y", "+Z", "-Z")
    #: the order the console asks for them: gravity first (lay the board on each face),
    #: then the field (each face to the north and down the dip)
    DIRECTIONS = tuple((face, "gravity") for face in FACES) + tuple((face, "field") for face in FACES)
    TOLERANCE_DEG = 15.0
    HOLD_SAMPLES = 5
    #: readings that differ by more than this share of the vector's length are "moving"
    STILL_FRACTION = 0.03
    MAX_SAMPLES = 1200
    #: a fit whose corrected samples scatter more than this off their sphere is refused
    MAX_RMS_REL = 0.05

    def __init__(self) -> None:
        self.done: list[tuple[str, str]] = []
        self.mag: list[tuple[float, float, float]] = []
        self.acc: list[tuple[float, float, float]] = []
        self._prev: tuple[np.ndarray, np.ndarray] | None = None
        self._streak: tuple[tuple[str, str] | None, int] = (None, 0)

    @property
    def remaining(self) -> list[tuple[str, str]]:
        return [d for d in self.DIRECTIONS if d not in self.done]

    @classmethod
    def _facing(cls, v: np.ndarray) -> str | None:
        """The face (+X..-Z) a vector points out of, within the tolerance."""
        n = float(np.linalg.norm(v))
        if not n > 0:
            return None
        i = int(np.argmax(np.abs(v)))
        if abs(v[i]) / n < math.cos(math.radians(cls.TOLERANCE_DEG)):
            return None
        return ("+" if v[i] > 0 else "-") + "XYZ"[i]

    def feed(self, mag: Sequence[float], acc: Sequence[float]) -> tuple[str, str] | None:
        """One raw reading pair. Returns the direction it completed, if any."""
        m, a = np.asarray(mag, dtype=float), np.asarray(acc, dtype=float)
        if m.shape != (3,) or a.shape != (3,) or not (np.all(np.isfinite(m)) and np.all(np.isfinite(a))):
            self._prev, self._streak = None, (None, 0)
            return None
        prev, self._prev = self._prev, (m, a)
        still = prev is not None and all(
            float(np.linalg.norm(v - p)) <= self.STILL_FRACTION * max(float(np.linalg.norm(v)), 1e-12)
            for v, p in zip((m, a), prev))
        if not still:
            self._streak = (None, 0)
            return None
        if len(self.mag) >= self.MAX_SAMPLES:      # keep every other: the spread stays
            self.mag, self.acc = self.mag[::2], self.acc[::2]
        self.mag.append(tuple(float(c) for c in m))   # type: ignore[arg-type]
        self.acc.append(tuple(float(c) for c in a))   # type: ignore[arg-type]
        here: tuple[str, str] | None = next(
            ((face, what) for face, what in ((self._facing(a), "gravity"), (self._facing(m), "field"))
             if face is not None and (face, what) not in self.done), None)
        count = self._streak[1] + 1 if here is not None and here == self._streak[0] else 1
        self._streak = (here, count)
        if here is not None and count >= self.HOLD_SAMPLES:
            self.done.append(here)     # type: ignore[arg-type]
            self._streak = (None, 0)
            return here                # type: ignore[return-value]
        return None

    def fits(self) -> tuple[EllipsoidFit, EllipsoidFit]:
        """(magnetometer, accelerometer) ellipsoids; CalibrationError when the readings
        do not span enough directions yet."""
        return fit_ellipsoid(self.mag), fit_ellipsoid(self.acc)

    def result(self) -> dict[str, Any]:
        """The constants to save: only once all 12 directions are done and both fits are
        good. Raises CalibrationError saying what is missing."""
        if self.remaining:
            missing = ", ".join(f"{f} along {w}" for f, w in self.remaining)
            raise CalibrationError(f"{len(self.done)} of {len(self.DIRECTIONS)} directions done "
                                   f"(missing: {missing})")
        mag, acc = self.fits()
        for name, fit in (("magnetometer", mag), ("accelerometer", acc)):
            if fit.rms_rel > self.MAX_RMS_REL:
                raise CalibrationError(f"{name} readings scatter {fit.rms_rel * 100:.1f}% off their "
                                       "sphere (bumped, or a magnet nearby?)")
        # the magnetometer: centre = hard iron, the sphere map (scaled to keep the mean
        # radius 1 in the sensor's units' ratio) = soft iron; heading needs directions only
        sq = np.asarray(mag.to_sphere).reshape(3, 3)
        sq = sq / np.linalg.det(sq) ** (1.0 / 3.0)
        return {"mag_offset": list(mag.centre), "mag_scale": list(mag.half_extent),
                "mag_matrix": [float(v) for v in sq.ravel()], "mag_axis_ratio": mag.axis_ratio,
                "mag_rms_rel": mag.rms_rel, "accel_offset": list(acc.centre),
                "accel_scale": list(acc.half_extent), "accel_rms_rel": acc.rms_rel}
