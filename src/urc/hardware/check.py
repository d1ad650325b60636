"""``urc hw check``: commissioning a rotator's parts before the controller runs them.

Lists the configured parts, reads every sensor (an I2C device's id and an AS5600's
magnet status included), shows limit switches and brakes, and measures the safety
chain's timeout on its read-back input (the start-up self-test, :mod:`.safety_test`). With ``move`` each axis is
jogged briefly up and the sensor must count up: a motor turning against its sensor
(reversed wiring) is reported with the pin swap that fixes it in the config.
"""

from __future__ import annotations

import time
from typing import Any, Callable

from ..errors import UrcError

#: what to swap in [hardware.gpio.<axis>] pins when the motor turns against the sensor
REVERSE_FIX = {"vnh5019": "swap ina and inb", "bts7960": "swap rpwm and lpwm",
               "relay": "swap cw and ccw", "lmd18200": "swap the motor's two wires at the LMD18200",
               "pwm_dir": "swap the motor's two wires at the driver board"}


class _Beat:
    """The heartbeat while the check drives a motor: the safety chain (docs/hardware.md)
    cuts motor power without it, as it must while urc is not running its loop."""

    def __init__(self, hw: Any):
        self.hw, self.level = hw, False

    def __call__(self) -> None:
        if self.hw.heartbeat is not None:
            self.level = not self.level
            self.hw.heartbeat.write(self.level)


def _read(sensor: Any) -> tuple[float | None, str]:
    try:
        return float(sensor.read_deg()), ""
    except UrcError as exc:
        return None, str(exc)


def check(hw: Any, caps: Any, *, gpio: Any = None, move: bool = False, jog_duty: float = 0.5,
          jog_s: float = 1.0, sleep: Callable[[float], None] = time.sleep,
          now: Callable[[], float] = time.monotonic, out: Callable[[str], None] = print) -> int:
    """Run the checks; returns the number of problems found."""
    problems = 0
    out(f"backend {hw.backend}, profile {caps.name}")
    if gpio is not None and gpio.heartbeat_pin is not None:
        out(f"  heartbeat GPIO{gpio.heartbeat_pin}: " + (
            f"safety chain, motor power drops {gpio.motor_enable_timeout_s:g} s after its last rising edge"
            if gpio.motor_enable_timeout_s is not None else
            "no safety chain declared (motor_enable_timeout_s): nothing cuts the motors if urc hangs"))
    problems += _chain(hw, sleep, now, out)
    built = getattr(getattr(hw, "gpio", None), "pwm_outputs", None)
    if gpio is not None and built:
        # what was built (a pin the overlay did not route to its channel runs software PWM)
        for where, (pin, what) in built.items():
            out(f"  {where} GPIO{pin}: {what}")
    elif gpio is not None:
        from .gpio.pwm import detect_pwm_chip, pwm_plan
        table = None if gpio.emulate else detect_pwm_chip(gpio)[1]      # a Pi 5's own table
        for where, (pin, ch) in pwm_plan(gpio, table).items():
            out(f"  {where} GPIO{pin}: " + (f"hardware PWM{ch} (planned)" if ch is not None else "software PWM"))
    for label, part in hw.parts:
        ident = getattr(part, "identify", None)
        if ident is None:
            out(f"  {label}: {type(part).__name__}")
            continue
        try:
            out(f"  {label}: {ident()}")
        except UrcError as exc:
            problems += 1
            out(f"  {label}: PROBLEM {exc}")
    for name in caps.axes:  # (a single-axis rotator has no elevation parts to check)
        ax = hw.axis(name)
        ax_caps = caps.axis(name)
        v, err = _read(ax.sensor)
        motor = getattr(ax.motor, "driver", ax.motor)
        out(f"{name}: motor {type(motor).__name__}, sensor {ax_caps.sensor.kind} "
            f"({type(getattr(ax.sensor, 'driver', ax.sensor)).__name__})")
        if v is None:
            problems += 1
            out(f"  sensor: PROBLEM {err}")
        else:
            out(f"  sensor reads {v:.2f} deg")
        if getattr(motor, "position_bound_deg", 0.0):     # (a step count: the chain's cut reset its indexer)
            out(f"  step count: the rotor may be up to {motor.position_bound_deg:.3f} deg from it after "
                f"{motor.supply_offs} motor-supply loss(es) seen on the read-back (the self-test's cut "
                f"included): each resets the {motor.chip.name}'s indexer, 2 full steps; homing clears it")
        problems += _limits(name, ax, out)
        if ax.brake is not None:
            out(f"  brake: {'released' if ax.brake.is_released() else 'engaged'}")
        gpio_ax = getattr(gpio, name, None) if gpio is not None else None
        if gpio_ax is not None and gpio_ax.current_sense_channel is not None:
            out(f"  motor current: {ax.motor.read_current_a():.2f} A (current sense)")
        sensor = getattr(ax.sensor, "driver", ax.sensor)
        counter = getattr(sensor, "counter", None)
        if hasattr(sensor, "lost_edges"):
            lost = sensor.lost_edges()
            out(f"  encoder lost edges: {lost} since the last reference" + (
                f" (position uncertain by up to {sensor.uncertainty_deg():.2f} deg)" if lost else ""))
        if gpio_ax is not None and getattr(counter, "z", None) is not None:
            idx = counter.index_count()
            out("  encoder index: " + ("not seen yet (jog over it: its count gives encoder_index_deg)"
                                       if idx is None else f"last at count {idx}"))
        if move:
            problems += _jog(hw, name, ax, ax_caps, gpio, jog_duty, jog_s, sleep, now, out, _Beat(hw))
    out("no problems found" if not problems else f"{problems} problem(s) found")
    return problems


class _Clock:
    def __init__(self, now: Callable[[], float]):
        self.now_s = now


def _chain(hw: Any, sleep: Callable[[float], None], now: Callable[[], float], out: Callable[[str], None]) -> int:
    """The safety chain measured: its start-up self-test, run here with the motors off
    (:mod:`.safety_test`), shows the timeout the chain really has."""
    timeout_s = getattr(hw, "motor_enable_timeout_s", None)
    if timeout_s is None or getattr(hw, "heartbeat", None) is None:
        return 0
    from .safety_test import self_test
    result = self_test(hw, timeout_s, clock=_Clock(now), sleep=sleep)
    if result.ok is None:
        out(f"  safety chain: {result.why}: the timeout and the cut are not checked")
        return 0
    if result.ok:
        assert result.measured_s is not None
        out(f"  safety chain: measured timeout {result.measured_s:.3f} s (configured {timeout_s:g} s): "
            f"{result.why}")
        return 0
    out(f"  safety chain: PROBLEM {result.why}")
    return 1


def _limits(name: str, ax: Any, out: Callable[[str], None]) -> int:
    """Each limit switch's state; with normally-closed switches (the default) an active
    input also means an open circuit (a broken wire, a connector off): both at once
    cannot be the antenna, so that is reported as a broken limit circuit."""
    active = {}
    for side, sw in (("min", ax.limit_min), ("max", ax.limit_max)):
        if sw is None:
            continue
        active[side] = sw.is_active()
        nc = not getattr(sw, "active_low", True)
        what = "ACTIVE" + (" (normally closed: the switch is open, or its circuit is broken)" if nc else "")
        out(f"  limit switch {side}: {what if active[side] else 'closed circuit, not active' if nc else 'open'}")
    if len(active) == 2 and all(active.values()):
        out(f"  limit switches: PROBLEM both {name} limits read active: a broken limit circuit "
            "(the common wire, the switches' supply, or the connector)")
        return 1
    return 0


def _jog(hw: Any, name: str, ax: Any, ax_caps: Any, gpio: Any, duty: float, jog_s: float,
         sleep: Callable[[float], None], now: Callable[[], float], out: Callable[[str], None],
         beat: Callable[[], None] = lambda: None) -> int:
    if ax.limit_max is not None and ax.limit_max.is_active():
        out("  jog: skipped, the max limit switch is active")
        return 0
    r0, err = _read(ax.sensor)
    if r0 is None:
        out(f"  jog: skipped, no sensor reading ({err})")
        return 1
    if ax.brake is not None:
        ax.brake.set_released(True)
        t_end = now() + ax_caps.brake_release_s + 0.1
        while now() < t_end:
            beat()
            hw.poll(now())
            sleep(0.02)
    t_end = now() + jog_s
    peak_a = 0.0
    try:
        while now() < t_end:
            ax.motor.set_drive(duty)
            beat()
            hw.poll(now())
            sleep(0.02)
            peak_a = max(peak_a, ax.motor.read_current_a())
    finally:
        ax.motor.set_drive(0.0)
    if peak_a > 0.0:
        out(f"  jog: motor current up to {peak_a:.2f} A")
    t_end = now() + 1.0          # let it coast to a stop before the second reading
    while now() < t_end:
        beat()
        hw.poll(now())
        sleep(0.02)
    if ax.brake is not None:
        ax.brake.set_released(False)
    r1, err = _read(ax.sensor)
    if r1 is None:
        out(f"  jog: PROBLEM no sensor reading after the jog ({err})")
        return 1
    delta = r1 - r0
    m = ax_caps.sensor.modulo_deg
    if m:
        delta = (delta + m / 2) % m - m / 2
    res = ax_caps.sensor.resolution_deg + 3 * ax_caps.sensor.noise_deg
    if abs(delta) <= 2 * res:
        out(f"  jog up {duty:.0%} for {jog_s:g} s: the sensor did not move ({delta:+.2f} deg): "
            "check motor power, the brake and the wiring")
        return 1
    if delta < 0:
        kind = getattr(getattr(gpio, name, None), "motor", None) if gpio is not None else None
        fix = REVERSE_FIX.get(kind or "", "swap the motor's two wires")
        sensor_fix = {"encoder": " (or the encoder's enc_a and enc_b)",
                      "as5600": " (or, if the antenna turned the right way, set as5600_reversed = true: "
                                "the AS5600's DIR pin decides which way it counts)"}
        out(f"  jog up: the sensor counted DOWN ({delta:+.2f} deg): reversed wiring. Fix: in "
            f"[hardware.gpio.{name}] {fix}" + sensor_fix.get(ax_caps.sensor.kind, ""))
        return 1
    note = ""
    if ax_caps.sensor.kind == "pulse":
        note = " (a pulse counter takes its direction from the drive: confirm the direction by eye)"
    out(f"  jog up: the sensor counted up {delta:+.2f} deg: motor and sensor agree{note}")
    return 0


__all__ = ["check", "REVERSE_FIX"]
