"""The bodies of the commands the HTTP API and MQTT share, checked before anything is sent.

Angles are JSON numbers (strict: ``"45"`` and ``true`` are refused, not coerced), finite
and in range, or the command is refused naming the field. Unknown fields are refused too:
a misspelt ``el_dge`` must not be silently dropped while the antenna moves. (The class
names and docstrings are the API's published schema names: /openapi.json.)
"""

from __future__ import annotations

from datetime import datetime
from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator

#: azimuth in a request: pointing or mechanical, a cable-wrap side beyond 0..360 included
AzDeg = Annotated[float, Field(strict=True, allow_inf_nan=False, ge=-360.0, le=720.0)]
#: elevation in a request (over-the-top rotators reach 180)
ElDeg = Annotated[float, Field(strict=True, allow_inf_nan=False, ge=-90.0, le=180.0)]
#: any other finite number in degrees (offsets, switch positions)
Deg = Annotated[float, Field(strict=True, allow_inf_nan=False, ge=-720.0, le=720.0)]
Axis = Literal["az", "el"]


class Strict(BaseModel):
    """Request bodies: unknown fields are an error."""

    model_config = ConfigDict(extra="forbid")


# ------------------------------------------------------------------ motion
class GotoRequest(Strict):
    az_deg: AzDeg
    #: None: azimuth only (the elevation keeps its target; a single-axis rotator has none)
    el_deg: ElDeg | None = None


class PositionRequest(Strict):
    az_deg: AzDeg | None = None
    el_deg: ElDeg | None = None


class MoveRequest(Strict):
    """Move (jog) one axis; also the body of the control API's /api/move."""

    axis: Axis
    direction: Literal[-1, 1]
    speed: float = Field(1.0, strict=True, gt=0.0, le=1.0, allow_inf_nan=False,
                         description="fraction of the axis' top speed")


class StopRequest(Strict):
    """One axis, or both (None); also the body of the control API's /api/stop."""

    axis: Axis | None = None


# ------------------------------------------------------------------ tracking
class TrackRequest(Strict):
    kind: Literal["sun", "moon", "satellite", "point", "azel", "nmea"]
    name: str | None = Field(None, min_length=1, max_length=100)
    #: an NMEA GGA stream (balloon): a device path or tcp:HOST:PORT
    source: str | None = Field(None, min_length=1, max_length=200, pattern=r"^(tcp:[\w.\-\[\]:]+|/[\w./\-]+)$")
    norad: int | None = Field(None, ge=1, le=999_999_999)
    lat_deg: float | None = Field(None, ge=-90.0, le=90.0, strict=True, allow_inf_nan=False)
    lon_deg: float | None = Field(None, ge=-180.0, le=360.0, strict=True, allow_inf_nan=False)
    alt_m: float | None = Field(None, ge=-1000.0, le=1e8, strict=True, allow_inf_nan=False)
    az_deg: AzDeg | None = None
    el_deg: ElDeg | None = None

    @model_validator(mode="after")
    def _needs(self) -> "TrackRequest":
        need = {"satellite": (), "point": ("lat_deg", "lon_deg"), "azel": ("az_deg", "el_deg"),
                "nmea": ("source",)}.get(self.kind, ())
        missing = [k for k in need if getattr(self, k) is None]
        if missing:
            raise ValueError(f"kind {self.kind!r} needs {', '.join(missing)}")
        if self.kind == "satellite" and self.name is None and self.norad is None:
            raise ValueError("kind 'satellite' needs name or norad")
        return self


class PassRequest(Strict):
    norad: int = Field(ge=1, le=999_999_999, strict=True)
    aos: datetime


# ------------------------------------------------------------------ calibration
class ZeroRequest(Strict):
    az_deg: AzDeg | None = None
    el_deg: ElDeg | None = None


class AxisRequest(Strict):
    axis: Axis


class PotPoint(Strict):
    bearing_deg: AzDeg
    p: float = Field(strict=True, allow_inf_nan=False)


class PotApplyRequest(Strict):
    axis: Axis
    points: list[PotPoint] = Field(min_length=2, max_length=2)


class HomingRequest(Strict):
    axis: Axis
    speed_frac: float | None = Field(None, strict=True, gt=0.0, le=1.0, allow_inf_nan=False)
    switch_deg: Deg | None = None


# ------------------------------------------------------------------ simulator (debug)
FaultKind = Literal["sensor_stuck", "sensor_jump", "sensor_dead", "jam", "runaway", "limit_switch",
                    "reverse_wiring", "slow_read"]


class SimFault(Strict):
    axis: Axis
    kind: FaultKind
    deg: Deg | None = Field(None, description="sensor_jump: offset of the reading")
    duty: float | None = Field(None, strict=True, allow_inf_nan=False, ge=-1.0, le=1.0,
                               description="runaway: stuck duty")
    which: Literal["min", "max", "both"] | None = Field(None, description="limit_switch: which one")
    delay_s: float | None = Field(None, strict=True, allow_inf_nan=False, ge=0.0, le=10.0,
                                  description="slow_read: how long each slow read blocks")
    reads: int | None = Field(None, strict=True, ge=0, le=1000, description="slow_read: how many reads")


class SimClear(Strict):
    axis: Axis
    kind: FaultKind | None = None
