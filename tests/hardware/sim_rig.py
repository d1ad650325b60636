"""Helpers for the simulator backend tests: build a sim rotator on a virtual clock.

(Not a conftest.py: other test folders import the root ``conftest`` by name, and a
second conftest.py here would shadow it. Test modules import ``rig`` from here.)"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from urc.clock import VirtualClock
from urc.hardware.interfaces import Hardware
from urc.hardware.sim import SimWorld, build_sim_hardware
from urc.profiles import PROFILES


class Rig:
    """A simulated rotator, its world and the virtual clock that drives it."""

    def __init__(self, profile: str, state_dir: Path, **options: Any):
        self.caps = PROFILES[profile]
        self.clock = VirtualClock()
        options.setdefault("wind", False)
        options.setdefault("truth_file", None)
        self.hw: Hardware = build_sim_hardware(self.caps, self.clock, state_dir, options)
        self.world: SimWorld = self.hw.world
        self.hw.poll(self.clock.now_s())

    def run(self, seconds: float, step_s: float = 0.02) -> None:
        n = round(seconds / step_s)
        for _ in range(n):
            self.clock.advance(step_s)
            self.hw.poll(self.clock.now_s())

    def truth(self, axis: str) -> dict[str, Any]:
        return self.world.truth()[axis]

    def release_brake(self, axis: str) -> None:
        brake = self.hw.axis(axis).brake
        if brake is not None:
            brake.set_released(True)
            self.run(self.caps.axis(axis).brake_release_s + 0.04)
            assert brake.is_released()


@pytest.fixture
def rig(tmp_path):
    def make(profile: str, **options: Any) -> Rig:
        return Rig(profile, tmp_path, **options)
    return make
