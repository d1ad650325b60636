"""What of a configuration applies to this station: ``urc settings show`` prints that.

A configuration holds every key with its default, also those that mean nothing for the
parts chosen: ``reply_port`` on a TCP port, a compass chip on a BIG-RAS (pulse
sensors), stepper timing on a relay motor, the simulator's table on a Pi. Shown, they
read as settings in force. Left out here (they stay in the document and the file).
"""

from __future__ import annotations

from typing import Any

from .schema import Config

#: [hardware.gpio.<axis>] keys by the sensor kind they belong to (the profile's)
_SENSOR_KEYS = {
    "magnetometer": ("compass", "declination_deg"),
    "as5600": ("as5600_reversed",),
    "pulse": ("pulse_debounce_s",),
    "encoder": ("encoder_counts_per_deg", "encoder_index_deg", "encoder_index_period_deg", "encoder_drift_counts"),
    "pot": ("adc_channel", "adc_reference_channel", "adc_reference_v", "pot_law", "pot_m", "pot_c"),
}
#: ... by the motor kind
_MOTOR_KEYS = {
    "relay": ("relay_dead_time_s", "relay_pulse_hz"),
    "stepdir": ("stepper_driver", "microsteps", "steps_per_deg", "enable_active_low", "dir_reversed", "as5600_check"),
}
#: the ADC serves a pot and the motor current
_ADC_KEYS = ("adc", "spi_device")
_CURRENT_KEYS = ("current_sense_v_per_a",)
_LIMIT_KEYS = ("limit_active_low", "limit_debounce_s")
#: [[serve]] keys by the transport they belong to
_SERVE_KEYS = {"reply_port": "udp", "baud": "serial"}


def applicable(cfg: Config) -> dict[str, Any]:
    """``cfg.to_dict()`` without the keys that do not apply to its parts."""
    data = cfg.to_dict()
    hw = data.get("hardware", {})
    for backend in ("sim", "gpio", "bridge"):
        if backend != cfg.hardware.backend:
            hw.pop(backend, None)
    for entry in data.get("serve", []):
        kind = next((k for k in ("tcp", "pty", "serial", "udp") if k in entry), None)
        for key, belongs in _SERVE_KEYS.items():
            if kind != belongs:
                entry.pop(key, None)
    gpio = hw.get("gpio")
    if gpio is not None:
        caps = cfg.caps
        for name in ("az", "el"):
            ax = gpio.get(name)
            if ax is None:
                continue
            if name not in caps.axes:
                gpio.pop(name)
                continue
            _prune_axis(ax, caps.axis(name).sensor.kind)
    return data


def _prune_axis(ax: dict[str, Any], sensor_kind: str) -> None:
    motor = ax.get("motor")
    # a stepper's step count is its sensor, whatever the profile's (an AS5600 may check it)
    sensor = "stepcount" if motor == "stepdir" else sensor_kind
    drop = [k for kind, keys in _SENSOR_KEYS.items() if kind != sensor for k in keys]
    drop += [k for kind, keys in _MOTOR_KEYS.items() if kind != motor for k in keys]
    if motor in ("relay", "stepdir"):
        drop.append("pwm_frequency_hz")
    if sensor != "pot" and ax.get("current_sense_channel") is None:
        drop += [*_ADC_KEYS, *_CURRENT_KEYS]
    pins = ax.get("pins", {})
    if "limit_min" not in pins and "limit_max" not in pins:
        drop += list(_LIMIT_KEYS)
    for key in drop:
        ax.pop(key, None)
