"""Local controls (front-panel buttons, IR remote keys) through the rotator's command gate.

Every action goes through the Rotator service's public methods, so limits, keep-out
zones and faults are enforced there as for any protocol. While a control is held it is
registered with :meth:`Rotator.hold_local`: the local operator wins, and motion commands
from protocols and the API are refused ("local control active") until it is released;
a stop is accepted from anyone.

Actions: ``cw``/``ccw``/``up``/``down`` jog while held and stop that axis on release
(hold to jog, like the Tartu toggle switches and the G4JNT buttons); ``slow`` held with a
jog makes it slow (the G4JNT 'slow' button); ``stop`` stops both axes; ``park`` parks.
"""

from __future__ import annotations

import logging
from typing import Callable

from ..errors import UrcError

log = logging.getLogger("urc.frontpanel")

#: jog actions: the axis and direction each drives
JOGS = {"cw": ("az", 1), "ccw": ("az", -1), "up": ("el", 1), "down": ("el", -1)}
ACTIONS = (*JOGS, "slow", "stop", "park")


class LocalControls:
    """Press/release of named actions from any local source (a button, an IR key).

    ``on_result(ok, text)`` hears each outcome (the beeper: a click for accepted, an
    error pattern for refused).
    """

    def __init__(self, rotator, *, jog_speed: float = 1.0, slow_speed: float = 0.2,
                 on_result: Callable[[bool, str], None] | None = None):
        self.rotator = rotator
        self.jog_speed = jog_speed
        self.slow_speed = slow_speed
        self.on_result = on_result or (lambda ok, text: None)
        #: (source, action) pairs held now
        self._held: set[tuple[str, str]] = set()
        self.last_refusal = ""

    @staticmethod
    def hold_name(source: str, action: str) -> str:
        return f"{action.upper()} {source}"

    def held(self, action: str) -> bool:
        return any(a == action for _, a in self._held)

    def press(self, action: str, source: str = "button") -> bool:
        """An action's control went down. Returns whether the rotator accepted it."""
        if action not in ACTIONS:
            raise ValueError(f"unknown front-panel action {action!r}")
        self._held.add((source, action))
        self.rotator.hold_local(self.hold_name(source, action), True)
        try:
            if action in JOGS:
                self._jog(action)
            elif action == "stop":
                self.rotator.stop()
            elif action == "park":
                self.rotator.park(local=True)
            elif action == "slow":
                # a jog already under way changes speed
                for jog in [a for _, a in self._held if a in JOGS]:
                    self._jog(jog)
        except UrcError as exc:  # CommandRejected, or a hardware failure
            self.last_refusal = f"{action}: {exc}"
            log.info("front panel %s refused: %s", action, exc)
            self.on_result(False, self.last_refusal)
            return False
        self.on_result(True, action)
        return True

    def release(self, action: str, source: str = "button") -> None:
        """An action's control came up: a jog stops its axis unless another source
        still jogs it that way."""
        self._held.discard((source, action))
        self.rotator.hold_local(self.hold_name(source, action), False)
        if action in JOGS and not self.held(action):
            axis = JOGS[action][0]
            other = [a for _, a in self._held if a in JOGS and JOGS[a][0] == axis]
            if other:
                self._safe_jog(other[0])
            else:
                self.rotator.stop(axis)
        elif action == "slow":
            for jog in [a for _, a in self._held if a in JOGS]:
                self._safe_jog(jog)

    def release_all(self, source: str | None = None) -> None:
        """Release everything held (by one source, or by all)."""
        for src, action in sorted(self._held):
            if source is None or src == source:
                self.release(action, src)

    def _jog(self, action: str) -> None:
        axis, direction = JOGS[action]
        speed = self.slow_speed if self.held("slow") else self.jog_speed
        self.rotator.move(axis, direction, speed, local=True)

    def _safe_jog(self, action: str) -> None:
        try:
            self._jog(action)
        except UrcError as exc:
            self.on_result(False, f"{action}: {exc}")
