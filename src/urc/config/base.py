"""What every section of the schema shares: strict, frozen, no unknown keys."""

from __future__ import annotations

from typing import Any

from pydantic import BaseModel, ConfigDict, Field

_MODEL_CONFIG = ConfigDict(strict=True, frozen=True, extra="forbid", validate_default=False)


def num(default: Any = None, *, ge: float | None = None, le: float | None = None,
        gt: float | None = None, lt: float | None = None, description: str = "") -> Any:
    """A finite number field (ints accepted)."""
    return Field(default=default, ge=ge, le=le, gt=gt, lt=lt, allow_inf_nan=False,
                 description=description)


class Section(BaseModel):
    model_config = _MODEL_CONFIG
