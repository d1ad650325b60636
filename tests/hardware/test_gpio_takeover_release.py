"""After a takeover the I/O process lets go of the lines it made safe, so the restarted
control process can claim them (review of the takeover: OutputsHeld.close did nothing,
and lg keeps a line requested until gpio_free or gpiochip_close)."""

from __future__ import annotations

import sys
import types
from pathlib import Path

import pytest

from urc.config import load_config
from urc.hardware.gpio.outputs_only import take_gpio_outputs
from urc.hardware.gpio.pins import PinOut

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


class Kernel:
    """The gpiochip as lg sees it: a line requested by one handle is busy to every other
    until freed; a freed output keeps its level (persist_gpio_outputs)."""

    def __init__(self):
        self.owner: dict[int, int] = {}
        self.level: dict[int, int] = {}


def fake_lgpio(kernel: Kernel) -> types.ModuleType:
    lg = types.ModuleType("lgpio")

    class error(Exception):
        pass

    def gpio_claim_output(h, g, level, flags=0):
        if kernel.owner.get(g, h) != h:
            raise error("GPIO busy")
        kernel.owner[g], kernel.level[g] = h, int(level)
        return 0

    def gpio_write(h, g, level):
        assert kernel.owner.get(g) == h
        kernel.level[g] = int(level)
        return 0

    def gpio_free(h, g):
        if kernel.owner.get(g) == h:
            del kernel.owner[g]
        return 0

    lg.error, lg.gpio_claim_output, lg.gpio_write, lg.gpio_free = error, gpio_claim_output, gpio_write, gpio_free
    return lg


class LGPIOPin:          # (the name claim_output and close go by)
    def __init__(self, factory, n):
        self.factory, self._number = factory, n

    @property
    def state(self):
        return bool(self.factory.kernel.level[self._number])

    @state.setter
    def state(self, v):
        sys.modules["lgpio"].gpio_write(self.factory._handle, self._number, int(bool(v)))


class Factory:
    def __init__(self, kernel, handle):
        self.kernel, self._handle, self.pins = kernel, handle, {}

    def pin(self, n):
        return self.pins.setdefault(n, LGPIOPin(self, n))


@pytest.mark.parametrize("example", ["tartu-urc", "satnogs-v3"])
def test_the_restarted_control_process_can_claim_the_lines_after_a_takeover(monkeypatch, tmp_path, example):
    kernel = Kernel()
    monkeypatch.setitem(sys.modules, "lgpio", fake_lgpio(kernel))
    gpio = load_config(EXAMPLES / f"{example}.toml").hardware.gpio
    held = take_gpio_outputs(gpio, ("az", "el"), Factory(kernel, handle=1),
                              functions=types.SimpleNamespace(function=lambda pin: "output"),
                              sys_pwm=tmp_path)     # (no PWM chip: every pin a line)
    assert held.failed == [] and held.outputs
    lines = {out.pin._number: out.pin.state for out, _ in held.outputs.values()}
    control = Factory(kernel, handle=2)                  # the control process started again
    with pytest.raises(Exception, match="busy"):
        PinOut(control, next(iter(lines)))               # (the fake refuses a held line)
    held.close()
    assert {n: bool(kernel.level[n]) for n in lines} == lines   # freed at their safe levels
    for n, level in lines.items():
        PinOut(control, n, initial=level)                # every line claimable now
    assert all(kernel.owner[n] == 2 for n in lines)
