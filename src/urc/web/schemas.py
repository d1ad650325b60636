"""Request and response bodies shared by the HTTP API's routes.

Angles are JSON numbers (strict: ``"45"`` and ``true`` are refused, not coerced), finite
and in range, or the request is a 422 naming the field. Unknown fields are refused too:
a misspelt ``el_dge`` must not be silently dropped while the antenna moves.
"""

from __future__ import annotations

from typing import Annotated

from pydantic import BaseModel, ConfigDict, Field

#: azimuth in a request: pointing or mechanical, a cable-wrap side beyond 0..360 included
AzDeg = Annotated[float, Field(strict=True, allow_inf_nan=False, ge=-360.0, le=720.0)]
#: elevation in a request (over-the-top rotators reach 180)
ElDeg = Annotated[float, Field(strict=True, allow_inf_nan=False, ge=-90.0, le=180.0)]
#: any other finite number in degrees (offsets, switch positions)
Deg = Annotated[float, Field(strict=True, allow_inf_nan=False, ge=-720.0, le=720.0)]


class Strict(BaseModel):
    """Request bodies: unknown fields are an error."""

    model_config = ConfigDict(extra="forbid")


class Ok(BaseModel):
    ok: bool = True


class Problem(BaseModel):
    """401/403/404/413 answers (FastAPI's ``HTTPException`` shape)."""

    detail: str


class Refusal(BaseModel):
    """409: the command was understood and refused (limits, keep-out, a fault, busy...)."""

    ok: bool = False
    error: str
    reason: str


class FieldError(BaseModel):
    loc: list[str | int]
    msg: str
    type: str


class Invalid(BaseModel):
    """422: the request did not validate; each entry names the field."""

    detail: list[FieldError]


#: documented on every control route (the answers a refused command can get)
CONTROL_RESPONSES: dict[int | str, dict] = {
    401: {"model": Problem, "description": "control needs the API token"},
    403: {"model": Problem, "description": "control from another site or through a foreign host name"},
    409: {"model": Refusal, "description": "refused by the rotator (limits, keep-out, fault, busy)"},
    413: {"model": Problem, "description": "request body too large"},
    422: {"model": Invalid, "description": "invalid request (each error names its field)"},
}
