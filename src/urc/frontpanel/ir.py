"""An IR remote through the Linux input subsystem (python-evdev).

The kernel's gpio-ir receiver driver and rc-core decode the remote (NEC, RC-5, ...) with
a keymap and deliver ordinary key events on /dev/input/eventN: value 1 key down, 2
auto-repeat, 0 key up (rc-core sends the up itself when the repeats stop, so a held
key jogs and letting go stops, like a panel button). The config maps key names
(``KEY_LEFT``) to panel actions.

A source is anything with evdev's ``InputDevice.read_one()`` (non-blocking: an event
with ``type``/``code``/``value`` or None); evdev itself is imported only here, and only
when an IR device is configured (it is in the ``pi`` extra).
"""

from __future__ import annotations

import logging
from typing import Any

from .controls import ACTIONS, LocalControls

log = logging.getLogger("urc.frontpanel")

EV_KEY = 0x01
#: the key map a fresh config gets: a common NEC remote's arrows, OK and a power/stop
DEFAULT_KEYS = {"KEY_RIGHT": "cw", "KEY_LEFT": "ccw", "KEY_UP": "up", "KEY_DOWN": "down",
                "KEY_OK": "stop", "KEY_STOP": "stop", "KEY_HOME": "park", "KEY_0": "slow"}


def key_codes(keys: dict[str, str]) -> dict[int, str]:
    """Key names (``KEY_LEFT``, or a number) -> codes, through evdev's own table."""
    from evdev import ecodes

    out = {}
    for name, action in keys.items():
        if action not in ACTIONS:
            raise ValueError(f"IR key {name}: unknown action {action!r}")
        code = int(name, 0) if name[:1].isdigit() else ecodes.ecodes.get(name)
        if code is None:
            raise ValueError(f"IR key {name!r} is not an evdev key name (KEY_...)")
        out[code] = action
    return out


def open_device(path: str) -> Any:
    from evdev import InputDevice

    return InputDevice(path)


class IrRemote:
    """Feeds a source's key events to the local controls; a vanished device releases
    every key it held (nothing keeps jogging on a lost receiver)."""

    SOURCE = "IR"

    def __init__(self, source: Any, codes: dict[int, str], controls: LocalControls):
        self.source = source
        self.codes = codes
        self.controls = controls
        self.error = ""

    def poll(self) -> None:
        if self.source is None:
            return
        try:
            while (ev := self.source.read_one()) is not None:
                self._event(ev)
        except OSError as exc:  # unplugged, driver unloaded
            self.error = f"IR receiver lost: {exc}"
            log.error("%s", self.error)
            self.source = None
            self.controls.release_all(self.SOURCE)

    def _event(self, ev: Any) -> None:
        if ev.type != EV_KEY or ev.code not in self.codes:
            return
        action = self.codes[ev.code]
        if ev.value == 1:
            self.controls.press(action, self.SOURCE)
        elif ev.value == 0:
            self.controls.release(action, self.SOURCE)
        # value 2 (auto-repeat) keeps what the key-down started


class EmulatedKeys:
    """An IR receiver emulated: keys pressed by :meth:`press`/:meth:`release`, read
    back through evdev's ``read_one()`` interface (``urc run`` with ``emulate``, and the
    tests, where /dev/uinput is not available to make a real evdev device)."""

    def __init__(self):
        self._queue: list[Any] = []

    def _put(self, code: int, value: int) -> None:
        from types import SimpleNamespace

        self._queue.append(SimpleNamespace(type=EV_KEY, code=code, value=value))

    def press(self, code: int) -> None:
        self._put(code, 1)

    def repeat(self, code: int) -> None:
        self._put(code, 2)

    def release(self, code: int) -> None:
        self._put(code, 0)

    def read_one(self) -> Any:
        return self._queue.pop(0) if self._queue else None
