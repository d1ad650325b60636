"""Every package's registrations with the packages below it, made by importing the
modules that register at import: the checks of the configuration keys whose meaning
each owner knows (urc.config.owners: the hardware backends, the front panel, MQTT, the
protocols).

urc.config imports nothing above it (issue 34), so it cannot load its owners itself;
importing them from config's loader, even lazily, would only move the upward edge. The
owners register when imported, and this module, above them all, is what every entry
point imports before it reads a configuration: urc.cli (the ``urc`` command, and with
it the I/O process of ``urc run``: the web settings page, the tracker), urc.assembly
(the composition root, and so the control process and the test and bench harnesses
that build a rotator) and tests/conftest.py. A configuration checked without it fails
loudly (urc.config.owners), never passes unchecked. Light on purpose: no backend, no
protocol session and no rotator is imported here (``urc status`` and the control
process pay for it at every start).
"""

from __future__ import annotations

from .frontpanel import checks as _panel_checks
from .hardware import factory as _hardware_factory
from .mqtt import config as _mqtt_config
from .protocols import registry as _protocol_registry

#: the modules imported for their registrations
MODULES = (_hardware_factory, _panel_checks, _mqtt_config, _protocol_registry)
