"""Assemble a rotator from configuration, and run it as the ``urc run`` process."""

from __future__ import annotations

import asyncio
import logging
import signal
from dataclasses import replace
from pathlib import Path

from .clock import Clock, RealClock
from .config import Config
from .control.faults import FaultLimits
from .control.law import AxisTuning
from .hardware import build_hardware
from .persistence import StateStore
from .profiles import get_profile
from .service import Rotator, RotatorSettings
from .service.settings import default_fault_limits, default_tuning

log = logging.getLogger("urc")

STATE_FILE = "state.json"


def settings_from_config(cfg: Config) -> RotatorSettings:
    caps = get_profile(cfg.rotator.profile)
    if caps.loop_hz != cfg.rotator.loop_hz:
        caps = replace(caps, loop_hz=cfg.rotator.loop_hz)
    if cfg.hardware.backend == "bridge":
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
                                accel_deg_per_s2=c["accel_deg_per_s2"], kp_per_s=c["kp_per_s"],
                                ki_per_s2=c["ki_per_s2"], overshoot_deg=c["overshoot_deg"],
                                creep_lead_deg=c["creep_lead_deg"], backlash_deg=c["backlash_deg"])
        f = cfg.faults
        faults[name] = replace(default_fault_limits(ax, *limits[name]),
                               stall_timeout_s=f.stall_timeout_s, runaway_deg=f.runaway_deg,
                               sensor_jump_deg=f.sensor_jump_deg, overcurrent_a=f.overcurrent_a)
    park_az, park_el = cfg.park_position(caps)
    zones = tuple(z.keep_out(i) for i, z in enumerate(cfg.keepout))
    return RotatorSettings(
        caps=caps, az_limits_deg=limits["az"], el_limits_deg=limits["el"],
        park_az_deg=park_az, park_el_deg=park_el,
        az_offset_deg=cfg.offsets.az_deg, el_offset_deg=cfg.offsets.el_deg,
        flip=cfg.rotator.flip is True, pass_flip=cfg.rotator.flip_enabled(caps), zones=zones, idle_park_s=cfg.park.idle_park_s,
        az_tuning=tunings["az"], el_tuning=tunings["el"], az_faults=faults["az"], el_faults=faults["el"],
        save_interval_s=cfg.state.save_interval_s, watchdog_s=cfg.faults.watchdog_s).completed()


def bridged_caps(caps, protocol: str):
    """A profile behind an external controller: its mechanics stay, its sensor is the
    controller's position report (absolute, the protocol's step)."""
    from .hardware.bridge import make_dialect, report_caps

    dialect = make_dialect(protocol)
    return replace(caps, az=replace(caps.az, sensor=report_caps(dialect, "az")),
                   el=replace(caps.el, sensor=report_caps(dialect, "el")))


def build_rotator(cfg: Config, clock: Clock, state_dir: Path, durable_state: bool = True,
                  fast_virtual: bool = False) -> Rotator:
    """Everything ``urc run`` builds, minus the servers: for tests and benchmarks too.

    ``durable_state=False`` skips fsync (virtual-time tests); ``fast_virtual=True`` also
    skips it and spaces simulator-truth writes in wall time (benchmarks: restart exactness
    of the simulated iron on the virtual clock is traded for speed).
    """
    settings = settings_from_config(cfg)
    if fast_virtual:
        durable_state = False
    state_dir.mkdir(parents=True, exist_ok=True)
    sim = cfg.hardware.sim
    options = {"seed": sim.seed, "wind": sim.wind, "truth_wall_interval_s": 0.02 if fast_virtual else 0.0}
    if sim.start_az_deg is not None:
        options["start_az_deg"] = sim.start_az_deg
    if sim.start_el_deg is not None:
        options["start_el_deg"] = sim.start_el_deg
    if cfg.hardware.bridge is not None:
        options["bridge"] = cfg.hardware.bridge
    hardware = build_hardware(cfg.hardware.backend, settings.caps, clock, state_dir, options)
    if cfg.faults.overcurrent_a == 0:
        # 0 = the backend knows its motors best
        default_a = hardware.extra.get("overcurrent_a")
        if default_a:
                settings = replace(settings,
                               az_faults=replace(settings.az_faults, overcurrent_a=default_a.get("az", 0.0)),
                               el_faults=replace(settings.el_faults, overcurrent_a=default_a.get("el", 0.0)))
    return Rotator(settings, hardware, clock, StateStore(state_dir / STATE_FILE, durable=durable_state))


async def serve(cfg: Config, state_dir: Path, clock: Clock | None = None,
                config_path: Path | None = None) -> None:
    """The ``urc run`` process: control loop + HTTP API until SIGINT/SIGTERM."""
    import uvicorn

    from .api import create_api
    from .service.loop import run_realtime

    clock = clock or RealClock()
    rotator = build_rotator(cfg, clock, state_dir)
    stop = asyncio.Event()
    loop = asyncio.get_running_loop()
    for sig in (signal.SIGINT, signal.SIGTERM):
        loop.add_signal_handler(sig, stop.set)
    from .tracking.service import TrackingService

    tracking = TrackingService(rotator, cfg)
    tracking.start()
    api = create_api(rotator, cfg, config_path=config_path, state_dir=state_dir,
                     tracker=tracking if tracking.station is not None or tracking.gps is not None else None)
    server = uvicorn.Server(uvicorn.Config(api, host=cfg.api.host, port=cfg.api.port,
                                           log_level="warning", lifespan="off"))
    server.install_signal_handlers = lambda: None  # ours above stop everything in order
    caps = rotator.caps
    print(f"urc: profile {caps.name} ({caps.description}) on the {cfg.hardware.backend} backend", flush=True)
    print(f"urc: state in {state_dir}", flush=True)
    print(f"urc: dashboard on http://{cfg.api.host}:{cfg.api.port}/ ; control API at /api "
          f"(OpenAPI at /openapi.json)", flush=True)
    for event in rotator.status().events:
        print(f"urc: {event}", flush=True)
    from .servers import start_endpoints

    try:
        endpoints = await start_endpoints(cfg.served, rotator)
    except BaseException:
        rotator.shutdown()
        rotator.hw.close()
        raise
    for ep in endpoints:
        print(f"urc: serving {ep.description}", flush=True)
    if tracking.station is None and tracking.gps is None:
        print("urc: tracking off: no [station] configured", flush=True)
    elif tracking.station is None:
        print(f"urc: station position will come from the GPS on {cfg.station.gps}", flush=True)
    elif cfg.tracking.schedule:
        try:
            for p in tracking.run_schedule():
                print(f"urc: scheduled {p.name} {p.aos:%Y-%m-%d %H:%M:%S}Z max el {p.max_el_deg:.0f}", flush=True)
        except Exception as exc:  # a bad catalog must not keep the controller from running
            print(f"urc: schedule not run: {exc}", flush=True)

    def after_tick(now_s: float) -> None:
        try:
            tracking.step(now_s)
        except Exception:  # the tracker must never take the control loop down
            log.exception("tracker step failed")
    control = asyncio.create_task(run_realtime(rotator, clock, stop, after_tick), name="control-loop")
    web = asyncio.create_task(server.serve(), name="api")
    stopper = asyncio.create_task(stop.wait())
    done, _ = await asyncio.wait({control, web, stopper}, return_when=asyncio.FIRST_COMPLETED)
    stop.set()
    server.should_exit = True
    for ep in endpoints:
        ep.close()
    tracking.close()
    await asyncio.gather(control, web, return_exceptions=True)
    stopper.cancel()
    rotator.shutdown()
    rotator.hw.close()
    for task in done:
        if task is not stopper and task.exception() is not None:
            raise task.exception()
    print("urc: stopped, state saved", flush=True)
