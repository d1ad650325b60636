"""Emulated step/dir driver: the gpio backend's STEP queue and chip on the simulator
(the stage itself, lg's queue on the virtual clock and the chip moving the stepper
model, is the simulator's: :mod:`..sim.stepdrive`, which the plain sim drives too)."""

from __future__ import annotations

from typing import Any

from ..sim.stepdrive import (LG_BAD_PWM_MICROS, LG_ERROR_TEXT, LG_IDLE_WAKE_S, LG_MIN_PERIOD_US,  # noqa: F401
                             LG_TX_BUF, LG_TX_QUEUE_FULL, EmulatedStepDirChip, EmulatedStepper, EmulatedTxQueue,
                             LgError, attach_stepper_model, lg_first_edge_s, lg_raise)


def wire_emulated_stepper(name: str, motor: Any, sensor: Any, world: Any, emu: Any, cfg: Any) -> EmulatedStepper:
    """The simulator's stepper axis behind ``motor``'s pins (:func:`..sim.stepdrive.attach_stepper_model`),
    synced before the sensors and switches read the axis."""
    chip, sync = attach_stepper_model(name, motor, sensor, world, dir_pin=motor.dir_out.pin,
                                      enable_pin=motor.enable.pin if motor.enable is not None else None,
                                      dir_reversed=cfg.dir_reversed, enable_active_low=cfg.enable_active_low)
    emu.syncs.insert(0, sync)           # before the sensors and switches read the axis
    emu.parts[f"{name} stepper"] = chip
    return EmulatedStepper(motor, world, sync)
