"""Local controls (front-panel buttons, IR remote keys) through the rotator's command gate.

Every action goes through the Rotator service's public methods, so limits, keep-out
zones and faults are enforced there as for any protocol. While a control is held it is
registered with :meth:`Rotator.hold_local`: the local operator wins, and motion commands
from protocols and the API are refused ("local control active") until it is released;
a stop is accepted from anyone.

Actions: ``cw``/``ccw``/``up``/``down`` jog while held and stop that axis on release
(hold to jog, like the Tartu toggle switches and the G4JNT buttons); ``slow`` held with a
jog makes it slow (the G4JNT 'slow' button); ``stop`` stops both axes; ``park`` parks.

Autoturn (BIG-RAS menu, ``[panel] autoturn = true``): a jog held for ``AUTOTURN_HOLD_S``
(5 s) goes on after its button is let go, until a button is pressed again (that press
only ends the autoturn) or the axis reaches its end of travel.

On a rotator without elevation (``[rotator] elevation = false``) UP/DOWN have no
function: pressing them does nothing at all (no hold over the clients, no beep), like
the BIG-RAS's unused buttons with "Elevation: OFF". ``[panel] layout`` says how the
buttons are wired (:data:`LAYOUTS`); :func:`button_action` gives what each does.
"""

from __future__ import annotations

import logging
from typing import Callable

from ..errors import UrcError

log = logging.getLogger("urc.frontpanel")

#: BIG-RAS Autoturn: how long a jog must be held to go on by itself
AUTOTURN_HOLD_S = 5.0

#: jog actions: the axis and direction each drives
JOGS = {"cw": ("az", 1), "ccw": ("az", -1), "up": ("el", 1), "down": ("el", -1)}
ACTIONS = (*JOGS, "slow", "stop", "park")

#: ``labelled``: each button does what its name says (Tartu, G4JNT, a home-made panel).
#: ``big-ras``: the BIG-RAS five-button row (seed 002), wired under its two-axis
#: functions, left to right down, up, stop, ccw, cw. With elevation off that row turns
#: left on the far left button, right on the far right one, stops on the middle one;
#: the second and fourth have no function.
LAYOUTS = ("labelled", "big-ras")
_AZ_ONLY_REMAP = {"labelled": {}, "big-ras": {"down": "ccw", "up": None, "ccw": None}}


def button_action(layout: str, button: str, has_el: bool) -> str | None:
    """What the button wired as ``button`` does on this rotator (None: nothing)."""
    if has_el:
        return button
    return _AZ_ONLY_REMAP[layout].get(button, button)


class LocalControls:
    """Press/release of named actions from any local source (a button, an IR key).

    ``on_result(ok, text)`` hears each outcome (the beeper: a click for accepted, an
    error pattern for refused).
    """

    def __init__(self, rotator, *, jog_speed: float = 1.0, slow_speed: float = 0.2,
                 on_result: Callable[[bool, str], None] | None = None, autoturn: bool = False):
        self.rotator = rotator
        self.jog_speed = jog_speed
        self.slow_speed = slow_speed
        self.on_result = on_result or (lambda ok, text: None)
        self.autoturn = autoturn
        #: (source, action) pairs held now, and since when
        self._held: set[tuple[str, str]] = set()
        self._since_s: dict[tuple[str, str], float] = {}
        #: axes turning on by themselves (Autoturn): axis -> the jog action
        self.autoturning: dict[str, str] = {}
        self.last_refusal = ""

    @staticmethod
    def hold_name(source: str, action: str) -> str:
        return f"{action.upper()} {source}"

    def held(self, action: str) -> bool:
        return any(a == action for _, a in self._held)

    def held_by(self, source: str) -> list[str]:
        """The actions ``source`` holds now."""
        return sorted(a for s, a in self._held if s == source)

    def press(self, action: str, source: str = "button") -> bool:
        """An action's control went down. Returns whether the rotator accepted it."""
        if action not in ACTIONS:
            raise ValueError(f"unknown front-panel action {action!r}")
        if not self._has_axis(action):
            log.debug("front panel %s: no such axis, no function", action)
            return False
        if self.autoturning:
            # a press ends the autoturn, and only that (the BIG-RAS: "until one of the
            # buttons is pressed again")
            for axis in list(self.autoturning):
                self.autoturning.pop(axis)
                self.rotator.stop(axis)
            self.on_result(True, "autoturn ended")
            return True
        self._held.add((source, action))
        self._since_s[(source, action)] = self.rotator.clock.now_s()
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
        if not self._has_axis(action):
            return
        if (source, action) not in self._held:
            return      # (the press that ended an autoturn)
        self._held.discard((source, action))
        held_s = self.rotator.clock.now_s() - self._since_s.pop((source, action), 0.0)
        self.rotator.hold_local(self.hold_name(source, action), False)
        if action in JOGS and not self.held(action):
            axis = JOGS[action][0]
            other = [a for _, a in self._held if a in JOGS and JOGS[a][0] == axis]
            if other:
                self._safe_jog(other[0])
            elif self.autoturn and held_s >= AUTOTURN_HOLD_S:
                self.autoturning[axis] = action      # goes on to its end of travel
                log.info("front panel: autoturn %s", action)
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

    def _has_axis(self, action: str) -> bool:
        return action not in JOGS or JOGS[action][0] in self.rotator.caps.axes

    def _jog(self, action: str) -> None:
        axis, direction = JOGS[action]
        speed = self.slow_speed if self.held("slow") else self.jog_speed
        self.rotator.move(axis, direction, speed, local=True)

    def _safe_jog(self, action: str) -> None:
        try:
            self._jog(action)
        except UrcError as exc:
            self.on_result(False, f"{action}: {exc}")
