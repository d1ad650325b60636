"""Build a rotator from a configuration: the composition root that ``urc run``'s control
process, the tools (``urc hw check``) and the tests and benchmarks share. Nothing here
starts a server; :mod:`urc.app` (which nothing imports) runs the service."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any, cast

from . import registrations  # noqa: F401  (the configuration's owners' checks: see that module)
from .clock import Clock
from .config import Config
from .control.faults import FaultLimits
from .control.law import AxisTuning
from .hardware import Hardware, build_hardware
from .persistence import StateStore
from .pointing.store import pointing_for
from .profiles import get_profile
from .model.settings import RotatorSettings, default_fault_limits, default_tuning
from .rotator.rotator import Rotator

STATE_FILE = "state.json"


def settings_from_config(cfg: Config, state_dir: Path | None = None) -> RotatorSettings:
    """The rotator's settings from ``cfg``, with the fitted pointing model stored in
    ``state_dir`` (urc.pointing.store; none without one, or if it is damaged:
    :func:`urc.pointing.store.pointing_for` says why)."""
    caps = cfg.rotator.variant(get_profile(cfg.rotator.profile))
    if caps.loop_hz != cfg.rotator.loop_hz:
        caps = replace(caps, loop_hz=cfg.rotator.loop_hz)
    if cfg.hardware.backend == "bridge" and cfg.hardware.bridge is not None:  # (checked: it is)
        caps = bridged_caps(caps, cfg.hardware.bridge.protocol)
    limits = cfg.effective_limits(caps)
    control = cfg.effective_control(caps)
    tunings: dict[str, AxisTuning] = {}
    faults: dict[str, FaultLimits] = {}
    for name in ("az", "el"):
        ax = caps.axis(name)
        c = control[name]
        tunings[name] = replace(default_tuning(ax), tolerance_deg=c["tolerance_deg"],
                                restart_deg=c["restart_deg"], max_rate_deg_per_s=c["max_rate_deg_per_s"],
                                min_rate_deg_per_s=c["min_rate_deg_per_s"],
                                accel_deg_per_s2=c["accel_deg_per_s2"], kp_per_s=c["kp_per_s"],
                                ki_per_s2=c["ki_per_s2"], overshoot_deg=c["overshoot_deg"],
                                creep_lead_deg=c["creep_lead_deg"], backlash_deg=c["backlash_deg"])
        f = cfg.faults
        faults[name] = replace(default_fault_limits(ax, *limits[name]),
                               stall_timeout_s=f.stall_timeout_s, runaway_deg=f.runaway_deg,
                               sensor_jump_deg=f.sensor_jump_deg, overcurrent_a=f.overcurrent_a,
                               min_rate_deg_per_s=c["min_rate_deg_per_s"])
    park_az, park_el = cfg.park_position(caps)
    zones = tuple(z.keep_out(i) for i, z in enumerate(cfg.keepout))
    return RotatorSettings(
        caps=caps, az_limits_deg=limits["az"], el_limits_deg=limits["el"],
        park_az_deg=park_az, park_el_deg=park_el,
        # (a south zero point: the mechanical frame starts at south)
        az_offset_deg=cfg.offsets.az_deg + cfg.rotator.zero_offset_deg, el_offset_deg=cfg.offsets.el_deg,
        flip=cfg.rotator.flip is True, pass_flip=cfg.rotator.flip_enabled(caps), zones=zones,
        pointing_deg=pointing_for(state_dir)[0], idle_park_s=cfg.park.idle_park_s,
        az_tuning=tunings["az"], el_tuning=tunings["el"], az_faults=faults["az"], el_faults=faults["el"],
        save_interval_s=cfg.state.save_interval_s, watchdog_s=_stall_s(cfg),
        watchdog_recover_s=cfg.faults.watchdog_recover_s, watchdog_latch_stalls=cfg.faults.watchdog_latch_stalls,
        watchdog_latch_window_s=cfg.faults.watchdog_latch_window_s).completed()


def _stall_s(cfg: Config) -> float:
    """How late a tick is a stall: ``[faults] watchdog_s``, or sooner where a safety part
    cuts motor power sooner (its timeout): a freeze that dropped the relay interrupted the
    motion, and the relay closes again on its own when ticks come back, so urc must count
    it (issue 33: 20 freezes of 0.5 s flapped the relay 20 times, 30 deg of jerky travel,
    none of them seen as a stall)."""
    parts = [getattr(section, "motor_enable_timeout_s", None) for section in (cfg.hardware.sim, cfg.hardware.gpio)]
    return min([cfg.faults.watchdog_s, *(t for t in parts if t is not None)])


def bridged_caps(caps, protocol: str):
    """A profile behind an external controller: its mechanics stay, its sensor is the
    controller's position report (absolute, the protocol's step; compass azimuth through
    Easycomm and rotctld, whose reports the bridge unfolds over the top)."""
    from .hardware.bridge import make_dialect, report_caps

    dialect = make_dialect(protocol)
    return replace(caps, az=replace(caps.az, sensor=report_caps(dialect, "az", caps.el_past_zenith)),
                   el=replace(caps.el, sensor=report_caps(dialect, "el", caps.el_past_zenith)))


#: least wall time between simulator-truth writes on a fast virtual clock: a write (an
#: atomic replace, which ext4 flushes) waits ~2-3 ms, and at 0.02 s it was a tenth of a
#: simulated pass's wall time; ``fast_virtual`` trades restart exactness for speed anyway
FAST_VIRTUAL_TRUTH_WALL_S = 0.25


def hardware_options(cfg: Config, fast_virtual: bool = False) -> dict:
    """The backend options a configuration gives (``build_hardware``)."""
    sim = cfg.hardware.sim
    options: dict[str, Any] = {"seed": sim.seed, "wind": sim.wind,
               "truth_wall_interval_s": FAST_VIRTUAL_TRUTH_WALL_S if fast_virtual else 0.0}
    if sim.start_az_deg is not None:
        options["start_az_deg"] = sim.start_az_deg
    if sim.start_el_deg is not None:
        options["start_el_deg"] = sim.start_el_deg
    if sim.motor_enable_timeout_s is not None:
        options["motor_enable_timeout_s"] = sim.motor_enable_timeout_s
    options["pointing_error"] = sim.pointing_error  # (None: a perfect mount)
    if cfg.hardware.bridge is not None:
        options["bridge"] = cfg.hardware.bridge
    if cfg.hardware.gpio is not None:
        options["gpio"] = cfg.hardware.gpio
    return options


def take_outputs(cfg: Config, state_dir: Path) -> Hardware:
    """The hardware opened afresh with every output driven safe (motors off, brakes
    engaged, heartbeat low): the I/O process's hold on the outputs once the control
    process that had them is dead. Close it to let go."""
    from .clock import RealClock

    gpio = cfg.hardware.gpio
    if cfg.hardware.backend == "gpio" and gpio is not None and not gpio.emulate:
        # on iron: the outputs only, no bus I/O (a bus error must not keep them driving)
        from .hardware.gpio.outputs_only import take_gpio_outputs
        return take_gpio_outputs(gpio, settings_from_config(cfg).caps.axes)  # type: ignore[return-value]
    hardware = build_hardware(cfg.hardware.backend, settings_from_config(cfg).caps, RealClock(), state_dir,
                              hardware_options(cfg))
    hardware.drive_safe()
    return hardware


def prepare_takeover(cfg: Config) -> list[str]:
    """Import now what :func:`take_outputs` will need, so a takeover costs the opening of
    the hardware alone: cold, the imports took 0.3-0.4 s on a loaded machine, every
    millisecond of it with a dead process's motor still driving where no safety part is
    wired. Only imports: nothing is opened (the control process holds the hardware).
    Returns the modules that could not be imported (a takeover will then say why)."""
    import importlib

    from .hardware.factory import load_backend

    load_backend(cfg.hardware.backend)  # (what take_outputs' build_hardware needs)
    modules = []
    gpio = cfg.hardware.gpio
    if cfg.hardware.backend == "gpio" and gpio is not None:
        modules = ["urc.hardware.gpio.emulate"] if gpio.emulate else \
            ["gpiozero.pins.lgpio", "urc.hardware.gpio.outputs_only"]
    missing = []
    for name in modules:
        try:
            importlib.import_module(name)
        except Exception:  # (no lgpio here: the takeover's own attempt reports it)
            missing.append(name)
    return missing


def build_rotator(cfg: Config, clock: Clock, state_dir: Path, durable_state: bool = True,
                  fast_virtual: bool = False) -> Rotator:
    """Everything ``urc run`` builds, minus the servers: for tests and benchmarks too.

    ``durable_state=False`` skips fsync (virtual-time tests); ``fast_virtual=True`` also
    skips it and spaces simulator-truth writes in wall time (benchmarks: restart exactness
    of the simulated iron on the virtual clock is traded for speed).
    """
    settings = settings_from_config(cfg, state_dir)
    if fast_virtual:
        durable_state = False
    state_dir.mkdir(parents=True, exist_ok=True)
    options = hardware_options(cfg, fast_virtual)
    hardware = build_hardware(cfg.hardware.backend, settings.caps, clock, state_dir, options)
    if cfg.faults.overcurrent_a == 0:
        # 0 = the backend knows its motors best
        default_a = hardware.overcurrent_a
        if default_a:
                settings = replace(settings,
                               az_faults=replace(settings.fault_limits("az"), overcurrent_a=default_a.get("az", 0.0)),
                               el_faults=replace(settings.fault_limits("el"), overcurrent_a=default_a.get("el", 0.0)))
    # a backend may keep the state itself: the gpio backend's FRAM store (StateStore's
    # interface, not derived from it)
    store = cast(StateStore, hardware.state_store) if hardware.state_store is not None else \
        StateStore(state_dir / STATE_FILE, durable=durable_state)
    rotator = Rotator(settings, hardware, clock, store)
    if problem := pointing_for(state_dir)[1]:
        rotator.announce(problem)  # (the start goes on without it: a model is no safety part)
    power_fail = hardware.power_fail
    if power_fail is not None:
        # BIG-RAS saves its position on a power-fail interrupt: urc also stops at once
        power_fail.on_fail, power_fail.save = rotator.power_fail, rotator.save_now
        if not power_fail.supply_ok():   # low already at start: no edge will come
            rotator.power_fail("power-fail input low at start")
    return rotator
