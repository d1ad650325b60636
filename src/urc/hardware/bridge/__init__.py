"""The ``bridge`` backend: urc in front of a controller the station already owns.

The controller (a GS-232A/B, an Easycomm board, a SPID Rot2Prog/Rot1Prog/MD-01, or
anything Hamlib drives behind ``rotctld``) closes its own motor loop; each axis is a
:class:`~urc.hardware.interfaces.Positioner` (targets in, reports out) and the rotator
service keeps limits, keep-out zones, wrap and flip, planning and faults, exactly as
with ``sim``. Serial or TCP I/O runs on the bridge's own thread (:mod:`.link`); the
control tick only posts targets and reads the latest report.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ...caps import RotatorCaps
from ...clock import Clock
from ..interfaces import AxisHardware, Hardware
from .client import BridgeClient, ClientOptions, folds_at_zenith
from .dialects import BRIDGE_PROTOCOLS, Dialect, make_dialect
from .link import LinkRunner, port_url

__all__ = ["BRIDGE_PROTOCOLS", "BridgeAxis", "BridgeClient", "ClientOptions", "build_bridge_hardware",
           "make_dialect", "report_caps"]


class _NoMotor:
    """A positioner axis has no motor of urc's to drive."""

    def set_drive(self, duty: float) -> None:
        pass

    def read_current_a(self) -> float:
        return 0.0


class _ControllerFault(_NoMotor):
    """The controller's own error report (SatNOGS GS/GE), read by the guard as a motor
    driver's fault output is: it latches a fault in the controller's words, stopping
    every motion and refusing new ones until the error is gone and the fault cleared.
    On the azimuth axis only: one controller, one fault."""

    def __init__(self, client: BridgeClient):
        self.client = client

    def driver_fault(self) -> str | None:
        return self.client.controller_fault() or None


@dataclass
class BridgeAxis:
    """One axis of the bridged controller: its position sensor (the controller's latest
    report) and its positioner (targets posted to the I/O thread)."""

    name: str
    client: BridgeClient
    clock: Clock
    wake: Any = None
    offset_deg: float = 0.0

    # ---- PositionSensor
    @property
    def caps(self):
        return report_caps(self.client.dialect, self.name, self.client.options.over_top)

    def read_deg(self) -> float:
        return self.client.reading(self.name, self.clock.now_s()) + self.offset_deg

    def set_reference_deg(self, angle_deg: float) -> None:
        """Re-reference in software: the controller's own readout is not changed."""
        self.offset_deg = angle_deg - self.client.reading(self.name)

    def calibration(self) -> dict[str, Any]:
        values: dict[str, Any] = {"offset_deg": self.offset_deg} if self.offset_deg else {}
        if self.name == "el" and self.client.over_top():
            # not a constant but saved with them in every state record: a sky-frame report
            # cannot tell which side of the zenith the antenna is on after a restart
            values["over_top"] = True
        return values

    def load_calibration(self, values: dict[str, Any]) -> None:
        self.offset_deg = float(values.get("offset_deg", 0.0))
        if self.name == "el":
            self.client.assume_over_top(bool(values.get("over_top", False)))

    # ---- Positioner
    @property
    def resolution_deg(self) -> float:
        return self.client.dialect.resolution_deg[0 if self.name == "az" else 1]

    def goto(self, target_deg: float) -> None:
        self.client.post(self.name, target_deg - self.offset_deg)
        if self.wake is not None:
            self.wake()

    def request_home(self) -> str:
        """Have the controller home on its endstops ("" = it will be told; else why not)."""
        reason = self.client.request_home()
        if not reason and self.wake is not None:
            self.wake()
        return reason

    def answering(self) -> bool:
        """The link is up and the controller has reported since (its position re-read)."""
        return self.client.error() == ""

    def note_position(self, mech_deg: float) -> None:
        """Where the rotator has this axis, on its turn (before each goto)."""
        self.client.note_position(self.name, mech_deg - self.offset_deg)

    def move(self, end_deg: float, speed_frac: float, rate_deg_per_s: float) -> None:
        self.client.post_move(self.name, end_deg - self.offset_deg, speed_frac, rate_deg_per_s)
        if self.wake is not None:
            self.wake()

    def stop(self) -> None:
        self.client.post(self.name, None)
        if self.wake is not None:
            self.wake()

    def latency_s(self) -> float:
        return self.client.latency_s()

    def sample_interval_s(self) -> float:
        return self.client.sample_interval_s()


def report_caps(dialect: Dialect, axis: str, over_top: bool = False):
    """What the controller's position reports are, as a sensor: absolute, the protocol's
    step; azimuth modulo 360 where the controller reports compass azimuth (rotctld);
    elevation folded at the zenith where such a report cannot tell the side of a rotator
    that flies ``over_top``."""
    from ...caps import SensorCaps

    return SensorCaps(kind="controller", resolution_deg=dialect.report_resolution_deg, absolute=True,
                      modulo_deg=dialect.az_modulo_deg if axis == "az" else None,
                      fold_deg=90.0 if axis == "el" and folds_at_zenith(dialect, over_top) else None)


def bridge_axes(client: BridgeClient, clock: Clock, wake=None) -> tuple[AxisHardware, AxisHardware]:
    axes = []
    for name in ("az", "el"):
        ax = BridgeAxis(name, client, clock, wake)
        motor = _ControllerFault(client) if name == "az" else _NoMotor()
        axes.append(AxisHardware(motor=motor, sensor=ax, positioner=ax))
    return axes[0], axes[1]


@dataclass
class BridgeLink:
    """What the bridge backend built besides the axes (``Hardware.bridge``)."""

    client: BridgeClient
    runner: LinkRunner


def build_bridge_hardware(caps: RotatorCaps, clock: Clock, state_dir: Path, options: dict[str, Any]) -> Hardware:
    """``options["bridge"]``: the ``[hardware.bridge]`` section (urc.config.BridgeSection)."""
    cfg = options["bridge"]
    dialect = make_dialect(cfg.protocol)
    client = BridgeClient(dialect, ClientOptions(timeout_s=cfg.timeout_s, poll_interval_s=cfg.poll_interval_s,
                                                 max_failures=cfg.max_failures,
                                                 stop_before_set=cfg.stop_before_set,
                                                 over_top=caps.el_past_zenith))
    runner = LinkRunner(client, port_url(cfg.serial, cfg.tcp), cfg.baud or dialect.default_baud,
                        reconnect_attempts=cfg.reconnect_attempts, name=f"bridge-{cfg.protocol}")
    az, el = bridge_axes(client, clock, runner.wake)
    runner.start()
    # the rotator restores from the first report: give the link a moment to bring one
    client.wait_report(client.timeout_s + 1.0)
    # a single-axis rotator: the controller's elevation is neither driven nor read
    return Hardware(backend="bridge", az=az, el=el if caps.has_el else None, close_hook=runner.close,
                    bridge=BridgeLink(client, runner))
