"""The urc configuration file: a small, strict TOML schema.

Every key is optional; ``load_config(None)`` gives the defaults, so urc runs with no file
at all. Anything wrong (a TOML syntax error, a wrong type, a value out of range, an
unknown key, a limit outside what the rotator profile can do) raises
:class:`urc.errors.ConfigError` whose message names the file, the dotted key, what was
expected and what was found::

    /etc/urc.toml: limits.az.max_deg: expected a number (degrees), found 'abc' (str)

Values are typed strictly: ``"1.5"`` (a string) is not a number and ``1`` is not ``true``;
integers are accepted where a float is expected.

Cross-checks that need the rotator profile (user limits inside the profile's range, park
inside the limits, control overrides within the profile's capabilities ...) run whenever a
:class:`Config` is built. The per-instance values here never go into the frozen caps
(docs/ARCHITECTURE.md, convention 4); use :meth:`Config.effective_limits`, :meth:`Config.park` and
:meth:`Config.effective_control` to combine the two.

The package, by concern:

* :mod:`.sections`, :mod:`.hardware_sections`, :mod:`.panel_sections`, :mod:`.schema`:
  the schema (:class:`Config` and its sections);
* :mod:`.checks`: the cross-checks; each backend's own section is checked beside its
  builder (:mod:`urc.hardware.gpio.checks`, :mod:`urc.hardware.bridge.checks`), the
  panel's in :mod:`urc.frontpanel.checks`;
* :mod:`.issues`, :mod:`.explain`: how a problem is worded;
* :mod:`.toml_read`: TOML in; out is ``Config.to_toml`` (tomlkit; editing a user's file in place
  is :mod:`urc.web.toml_edit`).
"""

from __future__ import annotations

from importlib import resources

from . import checks  # noqa: F401  (registers the cross-checks the schema's validator runs)
from .hardware_sections import BridgeSection, GpioAxis, GpioSection, HardwareSection, SimSection
from .panel_sections import PanelButtons, PanelIr, PanelLcd, PanelLeds, PanelOled, PanelSection
from .schema import Config
from .sections import (DEFAULT_SERVE, ApiSection, AxisControl, AxisLimits, ControlSection, FaultsSection,
                       KeepoutZone, LimitsSection, OffsetsSection, ParkSection, RotatorSection, ScheduleEntry,
                       ServeEntry, StateSection, StationSection, TrackingSection)
from .toml_read import load_config, loads_config
from .values import parse_host_port

__all__ = [
    "DEFAULT_SERVE", "EXAMPLE_CONFIG", "ApiSection", "AxisControl", "AxisLimits", "BridgeSection", "Config",
    "ControlSection", "FaultsSection", "GpioAxis", "GpioSection", "HardwareSection", "KeepoutZone",
    "LimitsSection", "OffsetsSection", "PanelButtons", "PanelIr", "PanelLcd", "PanelLeds", "PanelOled",
    "PanelSection", "ParkSection", "RotatorSection", "ScheduleEntry", "ServeEntry", "SimSection",
    "StateSection", "StationSection", "TrackingSection", "load_config", "loads_config", "parse_host_port",
]

#: the annotated example configuration shipped with urc (``urc config example``)
EXAMPLE_CONFIG: str = resources.files("urc").joinpath("config_example.toml").read_text(encoding="utf-8")
