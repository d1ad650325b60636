"""The whole configuration: :class:`Config`, its sections, what it derives from the
rotator profile, and how it is written back. Validation runs the cross-checks
(:mod:`.checks`, through :mod:`.owners`) whenever a Config is built; errors read as
:mod:`.issues` words them."""

from __future__ import annotations

import re
from typing import Any

import tomlkit
from pydantic import Field, ValidationError, model_validator

from ..caps import AxisCaps, RotatorCaps
from ..errors import ConfigError
from ..profiles import PROFILES
from .base import Section
from .explain import error_from_validation
from .hardware_sections import HardwareSection
from .issues import describe, error_from_issues
from .mqtt_section import MqttSection
from .owners import cross_check
from .panel_sections import PanelSection
from .sections import (DEFAULT_SERVE, ApiSection, AxisControl, AxisLimits, ControlSection, FaultsSection,
                       KeepoutZone, LimitsSection, OffsetsSection, ParkSection, PointingSection, RotatorSection,
                       ServeEntry, StateSection, StationSection, TrackingSection)


class Config(Section):
    rotator: RotatorSection = RotatorSection()
    hardware: HardwareSection = HardwareSection()
    limits: LimitsSection = LimitsSection()
    offsets: OffsetsSection = OffsetsSection()
    #: ``cfg.park.az_deg`` is the setting; ``cfg.park(caps)`` the resolved position.
    park: ParkSection = ParkSection()
    keepout: tuple[KeepoutZone, ...] = Field(default=(), strict=False)
    control: ControlSection = ControlSection()
    faults: FaultsSection = FaultsSection()
    api: ApiSection = ApiSection()
    state: StateSection = StateSection()
    station: StationSection = StationSection()
    tracking: TrackingSection = TrackingSection()
    pointing: PointingSection = PointingSection()
    #: protocols served and where; None (no [[serve]] at all) = rotctld on 127.0.0.1:4533
    serve: tuple[ServeEntry, ...] | None = Field(default=None, strict=False)
    panel: PanelSection = PanelSection()
    #: None (no [mqtt]) = no broker (urc.mqtt)
    mqtt: MqttSection | None = None

    @property
    def served(self) -> tuple[ServeEntry, ...]:
        return DEFAULT_SERVE if self.serve is None else self.serve

    def check_serve_options(self) -> None:
        """Each served entry's options against its protocol (ConfigError if refused):
        ``urc run`` checks them before anything starts (:mod:`.serve_options`)."""
        from .serve_options import check_serve_options

        check_serve_options(self.served)

    @model_validator(mode="after")
    def _check_against_profile(self) -> Config:
        issues = cross_check(self)
        if issues:
            raise error_from_issues(issues, "<config>")
        return self

    # -- construction --------------------------------------------------------------

    @classmethod
    def from_dict(cls, data: Any, source: str = "<dict>") -> Config:
        """Validate a parsed TOML document (or a dict from the web settings page)."""
        if not isinstance(data, dict):
            raise ConfigError(
                f"{source}: expected a table of settings, found {describe(data)}",
                path=source, key=None, expected="a table of settings", found=data)
        try:
            return cls.model_validate(data)
        except ValidationError as exc:
            raise error_from_validation(exc, source, Config) from None
        except ConfigError as exc:
            issues = getattr(exc, "_issues", None)
            if issues is None:  # pragma: no cover - raised by something we called
                raise
            raise error_from_issues(issues, source) from None

    # -- derived values ---------------------------------------------------------------

    @property
    def caps(self) -> RotatorCaps:
        """The frozen capabilities of ``rotator.profile`` (single-axis when
        ``rotator.elevation`` is false)."""
        return self.rotator.variant(PROFILES[self.rotator.profile])

    def effective_limits(self, caps: RotatorCaps | None = None) -> dict[str, tuple[float, float]]:
        """``{'az': (min_deg, max_deg), 'el': (...)}`` after applying the user limits."""
        caps = caps or self.caps
        out = {}
        for name in ("az", "el"):
            axis: AxisCaps = caps.axis(name)
            lim: AxisLimits = getattr(self.limits, name)
            lo = axis.min_deg if lim.min_deg is None else lim.min_deg
            hi = axis.max_deg if lim.max_deg is None else lim.max_deg
            out[name] = (float(lo), float(hi))
        return out

    def park_position(self, caps: RotatorCaps | None = None) -> tuple[float, float]:
        """``(az_deg, el_deg)`` to park at; same as ``cfg.park(caps)``."""
        return self.park(caps or self.caps)

    def effective_control(self, caps: RotatorCaps | None = None) -> dict[str, dict[str, float]]:
        """Per axis: the control settings after applying the overrides to the caps."""
        caps = caps or self.caps
        out = {}
        for name in ("az", "el"):
            axis: AxisCaps = caps.axis(name)
            c: AxisControl = getattr(self.control, name)
            out[name] = {
                "tolerance_deg": _pick(c.tolerance_deg, axis.tolerance_deg),
                "restart_deg": _pick(c.restart_deg, axis.restart_deg),
                "max_rate_deg_per_s": _pick(c.max_rate_deg_per_s, axis.max_rate_deg_per_s),
                "min_rate_deg_per_s": _pick(c.min_rate_deg_per_s, axis.min_rate_deg_per_s),
                "accel_deg_per_s2": _pick(c.accel_deg_per_s2, axis.accel_deg_per_s2),
                "kp_per_s": float(c.kp_per_s),
                "ki_per_s2": float(c.ki_per_s2),
                "overshoot_deg": _pick(c.overshoot_deg, axis.overshoot_deg),
                "creep_lead_deg": _pick(c.creep_lead_deg, axis.effective_creep_lead_deg),
                "backlash_deg": _pick(c.backlash_deg, axis.backlash_deg),
            }
        return out

    @property
    def control_requires_token(self) -> bool:
        return self.api.control_requires_token

    # -- output -------------------------------------------------------------------------

    def to_dict(self) -> dict[str, Any]:
        """Plain nested dict, None values left out, as it would be written to TOML."""
        return _strip_none(self.model_dump())

    def to_toml(self) -> str:
        """This configuration as a TOML document that loads back to an equal Config."""
        return dump_toml(self.to_dict())


def dump_toml(data: dict[str, Any]) -> str:
    """A configuration's dict (``Config.to_dict``, or part of it) as a TOML document."""
    return tomlkit.dumps(_encodable(data))


def _strip_none(value: Any) -> Any:
    if isinstance(value, dict):
        return {k: _strip_none(v) for k, v in value.items() if v is not None}
    if isinstance(value, (list, tuple)):
        return [_strip_none(v) for v in value]
    return value


def _encodable(value: Any) -> Any:
    """``value`` with each lone surrogate (a JSON string can carry one) replaced by U+FFFD:
    tomlkit would write it raw, and the text could then not be encoded as UTF-8."""
    if isinstance(value, dict):
        return {k: _encodable(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_encodable(v) for v in value]
    if isinstance(value, str):
        return _SURROGATE.sub("\ufffd", value)
    return value


_SURROGATE = re.compile("[\ud800-\udfff]")


def _pick(override: float | None, default: float) -> float:
    return float(default if override is None else override)
