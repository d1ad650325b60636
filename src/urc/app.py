"""``urc run``'s I/O process: the servers, the tracker, the front panel and the control
process they drive. The composition root: nothing imports this module (building a
rotator from a configuration is :mod:`urc.assembly`)."""

from __future__ import annotations

import asyncio
import contextlib
import logging
import signal
import socket
import threading
from typing import Any, Callable
from pathlib import Path

from .clock import Clock
from .config import Config
from .errors import UrcError

log = logging.getLogger("urc")


class ServiceFailed(UrcError):
    """``urc run`` ended because something failed (not because it was asked to): said in
    one line, and the exit code is non-zero so systemd starts it again."""

def bind_api_socket(host: str, port: int) -> socket.socket:
    """Bind the API port before anything else starts (as uvicorn would bind it)."""
    family = socket.AF_INET6 if ":" in host else socket.AF_INET
    sock = socket.socket(family, socket.SOCK_STREAM)
    try:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        sock.bind((host, port))
    except OSError as exc:
        sock.close()
        raise OSError(f"cannot serve the API on {host}:{port}: {exc.strerror or exc}") from None
    sock.set_inheritable(True)
    return sock


def check_serve_ports(entries) -> None:
    """Every [[serve]] TCP and UDP port can be bound now (OSError naming the entry if
    not): checked before the control process starts and before a fresh state directory
    is marked used, so a busy port refuses the start with nothing started or written.
    (Bound for a moment and released: the servers bind them again moments later.)"""
    from .config import parse_host_port

    for entry in entries:
        kind, where = entry.transport
        if kind not in ("tcp", "udp"):
            continue
        host, port = parse_host_port(where)
        if port == 0:
            continue  # any free port: nothing to check
        sock_type = socket.SOCK_STREAM if kind == "tcp" else socket.SOCK_DGRAM
        try:
            infos = socket.getaddrinfo(host or None, port, type=sock_type, flags=socket.AI_PASSIVE)
        except OSError as exc:
            raise OSError(f"cannot serve {entry.describe()}: {exc}") from None
        for family, type_, proto, _name, addr in infos:
            with socket.socket(family, type_, proto) as probe:
                try:
                    if kind == "tcp":  # as asyncio's create_server binds it
                        probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
                    if family == socket.AF_INET6:
                        probe.setsockopt(socket.IPPROTO_IPV6, socket.IPV6_V6ONLY, 1)
                    probe.bind(addr)
                except OSError as exc:
                    raise OSError(f"cannot serve {entry.describe()}: {exc.strerror or exc}") from None


def _real_hardware(cfg: Config) -> bool:
    backend = cfg.hardware.backend
    return backend != "sim" and not getattr(getattr(cfg.hardware, backend, None), "emulate", False)


def _hardware_key(cfg: Config) -> str:
    """What the hardware lock is named after: a bridge locks its controller's port (two
    bridges to two controllers run side by side; two to one controller do not)."""
    br = cfg.hardware.bridge
    if cfg.hardware.backend != "bridge" or br is None:
        return cfg.hardware.backend
    import os
    import re

    where = os.path.realpath(br.serial) if br.serial else br.tcp
    return "bridge-" + re.sub(r"[^A-Za-z0-9_.-]+", "_", where).strip("_")


async def serve(cfg: Config, state_dir: Path, config_path: Path | None = None) -> None:
    """The ``urc run`` process: servers here, the rotator and its loop in the control
    process (:mod:`urc.link.control_process`), until SIGINT/SIGTERM.

    Start-up takes the instance lock, binds every port and only then starts the control
    process, so a refused start writes no state. Every exit path stops the axes, waits
    for standstill (bounded), leaves every output safe and saves (in the control process).
    """
    from .persistence import check_state_dir

    check_state_dir(state_dir)
    adopted, locks = _adopt_or_lock(cfg, state_dir)
    try:
        api_socket = bind_api_socket(cfg.api.host, cfg.api.port)
        try:
            cfg.check_serve_options()  # (a protocol's options: before the control process, as the ports)
            check_serve_ports(cfg.served)
            await _serve(cfg, state_dir, config_path, api_socket, [lk.fd for lk in locks if lk.fd is not None],
                         adopted)
        finally:
            api_socket.close()
    finally:
        if adopted is not None:
            adopted.conn.close()  # (a start that failed: it is an orphan again, for the next one)
        for lock in locks:
            lock.release()


def _adopt_or_lock(cfg: Config, state_dir: Path) -> tuple[Any, list]:
    """Take over the control process a dead ``urc run`` left flying a bounded motion
    (urc.link.adoption) with the locks it holds; else take the instance locks (waiting
    for a previous urc that is still bringing its axes to rest)."""
    from .link import adoption
    from .link.instance import LOCK_FILE, InstanceLock, hardware_lock_path, lock_instance

    try:
        adopted = adoption.adopt(state_dir, cfg)
    except (adoption.AdoptionRefused, OSError, EOFError) as exc:
        log.warning("not taking over the control process that runs on: %s", exc)
        adopted = None
    if adopted is None:
        return None, lock_instance(state_dir, _hardware_key(cfg), _real_hardware(cfg))
    where = [(Path(state_dir) / LOCK_FILE, f"state dir {state_dir}"),
             (hardware_lock_path(_hardware_key(cfg)), f"the {_hardware_key(cfg)} hardware")]
    return adopted, [InstanceLock.handed_over(fd, path, what) for fd, (path, what) in zip(adopted.lock_fds, where)]


def _api_server(config):
    """uvicorn without its own signal handling: ``serve`` owns SIGINT/SIGTERM and stops
    everything in order, motors first (uvicorn >= 0.29 would capture them, stop serving
    and re-raise them after its own shutdown)."""
    import uvicorn

    class ApiServer(uvicorn.Server):
        @contextlib.contextmanager
        def capture_signals(self):
            yield
    return ApiServer(config)


async def _serve(cfg: Config, state_dir: Path, config_path: Path | None, api_socket: socket.socket,
                 lock_fds: list[int], adopted: Any = None) -> None:
    from .link.control_process import ControlProcess

    stop = asyncio.Event()
    loop = asyncio.get_running_loop()
    from .servers import loop_lag
    loop_lag.start()  # how late this loop runs a 0.1 s timer: /api/status "loop_lag"
    asked: list[str] = []  # why this process stops, when it was asked to (a signal)
    supervised = cfg.faults.control_takeover_s > 0
    # (supervised: a control process that is lost is started again by its watch, and
    # clients keep their connections meanwhile; else urc run ends and systemd restarts it)
    control = ControlProcess(cfg, state_dir, lock_fds, loop=loop,
                             on_lost=None if supervised else lambda _why: loop.call_soon_threadsafe(stop.set))
    if adopted is not None:  # (a control process flying on after a dead urc run: taken over)
        control.adopt(adopted)
    else:
        control.spawn()  # (it builds the rotator while this process imports the web stack)
    try:
        import uvicorn

        from .api import create_api
        from .servers import start_endpoints
        from .servers.limits import (MAX_HTTP_CONNECTIONS, bound_library_logs, capped_http_protocol,
                                     raise_open_file_limit)
        from .rotator.loop import sd_notifier
        tracking_on = cfg.station.configured or bool(cfg.station.gps)
        if tracking_on:  # (lazy: tracking off, this process never loads numpy, sgp4, skyfield)
            from .tracking.service import TrackingService

        raise_open_file_limit()
        bound_library_logs()
    except BaseException:
        control.abandon()
        raise
    rotator = control.wait_ready()
    if adopted is not None:
        await _took_over(rotator, cfg, state_dir, adopted.ready.get("config_settings"))

    def hold_outputs():
        from .assembly import take_outputs

        return take_outputs(cfg, state_dir)

    def said(text: str) -> None:
        log.warning("%s", text)
        print(f"urc: {text}", flush=True)
    control.watch(cfg.faults.control_takeover_s, hold_outputs, said)
    if cfg.faults.control_takeover_s > 0:  # (a takeover then opens the hardware at once)
        from .assembly import prepare_takeover
        threading.Thread(target=prepare_takeover, args=(cfg,), name="urc-takeover-imports", daemon=True).start()
    server = web = stopper = None
    try:
        for sig in (signal.SIGINT, signal.SIGTERM):
            loop.add_signal_handler(sig, lambda sig=sig: (asked.append(sig.name), stop.set()))
        # (planning off the event loop)
        tracking = (TrackingService(rotator, cfg, background=True, step_track=_step_track_maker(cfg))
                    if tracking_on else _TrackingOff())
        api = create_api(rotator, cfg, settings_of=_settings_of, config_path=config_path, state_dir=state_dir,
                         tracker=tracking if tracking.station is not None or tracking.gps is not None else None)
        from uvicorn.protocols.http.auto import AutoHTTPProtocol

        server = _api_server(uvicorn.Config(api, log_level="warning", lifespan="off",
                                            http=capped_http_protocol(AutoHTTPProtocol, MAX_HTTP_CONNECTIONS),
                                            # (counts the connection asking: one more, so every
                                            # admitted connection is served)
                                            limit_concurrency=MAX_HTTP_CONNECTIONS + 1))
        # every protocol port or none (the API port is bound already)
        endpoints = await start_endpoints(cfg.served, rotator.for_sessions())
        caps = rotator.caps
        print(f"urc: profile {caps.name} ({caps.description}) on the {cfg.hardware.backend} backend", flush=True)
        print(f"urc: state in {state_dir}", flush=True)
        print(f"urc: control loop in process {rotator.pid} ({rotator.priority} priority)", flush=True)
        print(f"urc: dashboard on http://{cfg.api.host}:{cfg.api.port}/ ; control API at /api "
              f"(OpenAPI at /openapi.json)", flush=True)
        # (the rotator's start-up events were logged as they happened: not printed again)
        for ep in endpoints:
            print(f"urc: serving {ep.description}", flush=True)
        tracking.start()
        await _announce_tracking(tracking, cfg)

        notify = sd_notifier()
        web = asyncio.create_task(server.serve(sockets=[api_socket]), name="api")
        steps = asyncio.create_task(_step_tracker(tracking, rotator.clock, stop), name="tracker")
        pings = asyncio.create_task(_ping_control(control, stop), name="control-ping")
        from .frontpanel import serve_panel

        panel = asyncio.create_task(serve_panel(cfg, rotator, stop), name="front-panel")
        from .mqtt import build_service

        mqtt = build_service(cfg, rotator, tracking if tracking.station is not None or tracking.gps is not None
                             else None, api.state.web.hub)
        broker = asyncio.create_task(mqtt.run(stop) if mqtt else stop.wait(), name="mqtt")
        notify("READY=1")
        stopper = asyncio.create_task(stop.wait())
        await asyncio.wait({web, stopper}, return_when=asyncio.FIRST_COMPLETED)
        notify("STOPPING=1")
        print("urc: stopping: axes to rest, then outputs safe and state saved", flush=True)
        stop.set()
        for ep in endpoints:
            ep.close()
        tracking.close()
        await asyncio.gather(steps, panel, pings, broker, return_exceptions=True)
    finally:
        # every path: the control process stops the axes, waits for standstill, leaves
        # the outputs safe and saves (a failed start above never got here)
        result = await asyncio.to_thread(control.stop)
        if web is not None:
            server.should_exit = True
            await asyncio.gather(web, return_exceptions=True)
        if stopper is not None:
            stopper.cancel()
        control.release_outputs()  # (held safe until the end: closing is the last thing)
    if control.taken_over:
        raise ServiceFailed(f"{control.taken_over}; the outputs were held safe until urc run ended "
                            "(it could not be started again). The position is uncertain if the antenna was moving.")
    if result["hung"]:
        raise ServiceFailed("the control loop hangs in a tick: outputs made safe, state not saved")
    if result["error"]:
        raise ServiceFailed(f"control loop died: {result['error']}")
    # (exit non-zero when nobody asked: systemd restarts a service that stopped by itself)
    if not asked and result["reason"] != "asked to stop":
        raise ServiceFailed(f"the control process stopped on its own: {result['reason']}")
    if not asked and web.done() and not web.cancelled() and web.exception() is None:
        raise ServiceFailed("the API server stopped on its own")
    if not result["settled"] and result["saved"]:
        print("urc: the axes were not seen to come to rest; saved as moving", flush=True)
    if web.done() and not web.cancelled() and web.exception() is not None:
        raise web.exception()
    print("urc: stopped, state saved" if result["saved"] else "urc: stopped; the state could NOT be saved "
          "(the next start treats the position as uncertain)", flush=True)


def _settings_of(cfg: Config, state_dir: Path | None):
    """A configuration's rotator settings, for the web's settings applied at once: the
    composition root imported only then (the I/O process needs none of it to start)."""
    from .assembly import settings_from_config

    return settings_from_config(cfg, state_dir)


async def _took_over(rotator, cfg: Config, state_dir: Path, config_settings) -> None:
    """Said, and this configuration's settings applied if they are not the ones the
    control process was given (the file changed meanwhile: limits, zones, offsets, speeds;
    applying them ends the motion in flight, as a settings save does)."""
    from .assembly import settings_from_config

    print(f"urc: took over the control process (process {rotator.pid}) that flew on after the last urc run "
          "ended", flush=True)
    settings = settings_from_config(cfg, state_dir)
    if settings != config_settings:
        await asyncio.to_thread(rotator.reconfigure, settings)


class _TrackingOff:
    """What a TrackingService does with no [station] and no GPS: nothing (no station,
    no tracker; it never searches, plans or reads the catalog). Stands in for it so that
    ``urc run`` without tracking does not import the tracking maths."""

    station = gps = None

    def start(self) -> None:
        pass

    async def step(self, now_s: float) -> None:
        pass

    def close(self) -> None:
        pass


async def _announce_tracking(tracking, cfg: Config) -> None:
    if tracking.station is None and tracking.gps is None:
        print("urc: tracking off: no [station] configured", flush=True)
    elif tracking.station is None:
        print(f"urc: station position will come from the GPS on {cfg.station.gps}", flush=True)
    elif cfg.tracking.schedule:
        try:
            # planned on a thread: the protocol ports serve meanwhile (nothing else
            # touches the tracker before the API and the tracker's steps start)
            for p in await asyncio.to_thread(tracking.run_schedule):
                print(f"urc: scheduled {p.name} {p.aos:%Y-%m-%d %H:%M:%S}Z max el {p.max_el_deg:.0f}", flush=True)
        except Exception as exc:  # a bad catalog must not keep the controller from running
            print(f"urc: schedule not run: {exc}", flush=True)


#: how often the tracker looks whether a new setpoint is due (it sends one every 0.2 s)
TRACKER_STEP_S = 0.05


async def _ping_control(control, stop: asyncio.Event) -> None:
    """Tell the control process this one is alive (silent too long: it stops the axes)."""
    from .link.control_process import PING_S

    while not stop.is_set():
        control.ping()
        try:
            await asyncio.wait_for(stop.wait(), PING_S)
        except asyncio.TimeoutError:
            pass


def _step_track_maker(cfg: Config) -> Callable[[Config, Any], Any] | None:
    """What makes the tracker's step-track from ``[pointing]`` (off by default)."""
    if not cfg.pointing.step_track:
        return None
    from .peaking.steptrack import from_config

    return from_config


async def _step_tracker(tracking, clock: Clock, stop: asyncio.Event) -> None:
    """The tracker runs in this process, not the control process: its propagation and
    planning never delay a tick. Each step runs on the tracker's own thread, where the
    API's track commands run too (urc.tracking.service), and is awaited here."""
    while not stop.is_set():
        try:
            await tracking.step(clock.now_s())  # (its setpoints never block the loop)
        except Exception:  # the tracker must never take the controller down
            log.exception("tracker step failed")
        try:
            await asyncio.wait_for(stop.wait(), TRACKER_STEP_S)
        except asyncio.TimeoutError:
            pass
