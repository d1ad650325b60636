"""The front panel: buttons, IR remote, status LEDs, beeper and display together.

Inputs arrive as gpiozero callbacks (the pin factory's thread on a Pi) and IR events;
``dispatch`` carries each onto the thread that talks to the rotator (the asyncio loop
under ``urc run``, like every protocol session; direct calls in tests). :meth:`update`
runs the LEDs, beeper, IR polling and the zero-setting repeats from the panel's clock;
:meth:`display_rows` gives the text the display shows now. :func:`run_panel` drives
both off the control loop: updates at 20 Hz, and display writes (slow I2C) in a worker
thread at the configured refresh rate, so no tick ever waits for the panel.
"""

from __future__ import annotations

import asyncio
import logging
import time
from typing import Any, Callable

from ..errors import UrcError
from ..protocols.tartu import lcd_contrast
from ..protocols.tartu_codec import LCD_CONTRAST_MAX
from .controls import JOGS, LocalControls, button_action
from .indicators import Beeper, Tone, led_states
from .ir import IrRemote
from .screen import preset_rows, status_rows, zero_rows
from .zeroset import ZeroSetting

log = logging.getLogger("urc.frontpanel")

UPDATE_PERIOD_S = 0.05
#: BIG-RAS SW7 / SW8 / SW10: buttons the panel handles itself (the preset knobs)
PRESET_ACTIONS = {"preset_az": "az", "preset_el": "el", "show_preset": None}
#: a held button that reads up this long without its release arriving is released by
#: :meth:`FrontPanel.update` (longer than a bounce, so a bouncing press is not cut)
LOST_RELEASE_S = 0.1


class FrontPanel:
    def __init__(self, rotator, *, pin_factory: Any = None, buttons: dict[str, int] | None = None,
                 leds: dict[str, int] | None = None, beeper_pin: int | None = None,
                 display: Any = None, ir: tuple[Any, dict[int, str]] | None = None,
                 layout: str = "labelled", jog_speed: float = 1.0, slow_speed: float = 0.2, bounce_time_s: float | None = None,
                 dispatch: Callable[..., None] | None = None, now_s: Callable[[], float] | None = None,
                 wall_s: Callable[[], float] = time.time, beeper_type: str | int = "dc",
                 beep_on_command: bool = False, backlight_pct: int = 100, screensaver_s: float = 0.0,
                 autoturn: bool = False, presets: Any = None, clock: bool = False, timezone: str = "UTC"):
        from gpiozero import LED, Button, Buzzer, PWMOutputDevice

        self.rotator = rotator
        self.now_s = now_s or rotator.clock.now_s
        self.wall_s = wall_s
        self.dispatch = dispatch or (lambda fn, *args: fn(*args))
        self._devices: list[Any] = []
        # BIG-RAS "Beeper type": off, an active (dc) beeper, or a passive one's tone in Hz
        out: Any = None
        if beeper_pin is not None and beeper_type == "dc":
            out = self._device(Buzzer, beeper_pin, pin_factory)
        elif beeper_pin is not None and beeper_type != "off":
            out = Tone(self._device(PWMOutputDevice, beeper_pin, pin_factory, frequency=int(beeper_type)))
        self.beeper = Beeper(out)
        self.beep_on_command = beep_on_command
        self.backlight_pct, self.screensaver_s = backlight_pct, screensaver_s
        self.controls = LocalControls(rotator, jog_speed=jog_speed, slow_speed=slow_speed,
                                      on_result=self._local_result, autoturn=autoturn)
        # what each button does (fixed: the axes do not change while urc runs)
        self.actions = {name: button_action(layout, name, rotator.caps.has_el) for name in (buttons or {})}
        self.buttons = {name: self._device(Button, pin, pin_factory, pull_up=True, bounce_time=bounce_time_s)
                        for name, pin in (buttons or {}).items()}
        self.leds = {name: self._device(LED, pin, pin_factory) for name, pin in (leds or {}).items()}
        self.display = display
        #: the BIG-RAS preset knobs (frontpanel.presets.PresetKnobs), and whether SW10 is held
        self.presets = presets
        self.presets_bus: Any = None
        self.showing_preset = False
        self.clock, self.timezone = clock, timezone
        self.ir = IrRemote(ir[0], ir[1], self.controls) if ir is not None else None
        self.zero: ZeroSetting | None = None
        self._had_fault = False
        self._contrast: int | None = None
        self.callback_errors = 0
        self._up_since_s: dict[str, float] = {}
        #: the target a protocol port last gave (beep_on_command), and when a key was last
        #: pressed here (the screensaver; a target set from here is not a port's command)
        self._target: tuple | None = None
        self._key_s = self.now_s()
        self.asleep = False
        self._light(self.backlight_pct)

    def power_on(self) -> None:
        """Start reacting to the buttons. Both turn buttons held at this moment start
        the G4JNT zero-setting procedure (the buttons are read before any callback is
        attached, so holding them does not also jog)."""
        if self._pressed("cw") and self._pressed("ccw"):
            self.zero = ZeroSetting(self.rotator)
            log.warning("front panel: zero setting (%s %.1f): L/R change, SLOW stores", self.zero.label,
                        self.zero.value_deg)
        for name, button in self.buttons.items():
            button.when_pressed = self._guarded(lambda _dev=None, n=name: self.dispatch(self._press, n))
            button.when_released = self._guarded(lambda _dev=None, n=name: self.dispatch(self._release, n))

    def _guarded(self, fn: Callable[..., None]) -> Callable[..., None]:
        """A button callback that never raises into the pin library's thread: on a Pi
        that is lgpio's one notification thread, which an exception ends for every edge
        of the process (``dispatch`` raises once the event loop is closed). Counted in
        ``callback_errors`` and logged (the first, then every 100th)."""
        def handler(*args: Any) -> None:
            try:
                fn(*args)
            except Exception:
                self.callback_errors += 1
                if self.callback_errors == 1 or self.callback_errors % 100 == 0:
                    log.exception("front panel: button callback failed (%d so far)", self.callback_errors)
        return handler

    def _release_lost(self, now: float) -> None:
        """Release what a button holds while no button doing it reads down: its release
        was lost (a report lgpio dropped, a callback that failed), and hold-to-jog must
        not jog on to the end of travel."""
        for action in self.controls.held_by("button"):
            if self._pressed(action):
                self._up_since_s.pop(action, None)
                continue
            since = self._up_since_s.setdefault(action, now)
            if now - since >= LOST_RELEASE_S - 1e-9:
                self._up_since_s.pop(action, None)
                log.warning("front panel: the %s button reads up but its release never came: released", action)
                self.controls.release(action, "button")

    def _device(self, cls, pin, factory, **kwargs):
        dev = cls(pin, pin_factory=factory, **kwargs)
        self._devices.append(dev)
        return dev

    def _pressed(self, action: str) -> bool:
        """Is a button doing ``action`` down?"""
        return any(self.actions[n] == action and b.is_pressed for n, b in self.buttons.items())

    # ---------------------------------------------------------------- inputs
    def _local_result(self, ok: bool, _text: str) -> None:
        self._woken()
        self.beeper.beep("click" if ok else "refused")

    def _woken(self) -> None:
        """A key was pressed here: the display wakes, the screensaver starts again."""
        self._key_s = self.now_s()
        if self.asleep:
            self.asleep = False
            self._light(self.backlight_pct)

    def _light(self, pct: int) -> None:
        if self.display is not None and hasattr(self.display, "backlight"):
            self.display.backlight(pct)

    def _press(self, name: str) -> None:
        self._woken()
        action = self.actions[name]
        if action is None:  # a button with no function here
            return
        if self.zero is not None and self.zero.active:
            self._zero_press(action)
            return
        if action in PRESET_ACTIONS:
            self._preset_press(action)
            return
        self.controls.press(action, "button")

    def _release(self, name: str) -> None:
        action = self.actions[name]
        if action is None:
            return
        if self.zero is not None and self.zero.active:
            if action in ("cw", "ccw"):
                self.zero.release(JOGS[action][1])
            return
        if action in PRESET_ACTIONS:
            if action == "show_preset":
                self.showing_preset = False
            return
        self.controls.release(action, "button")

    def _preset_press(self, action: str) -> None:
        """SW7 / SW8: that axis to the knob's direction, through the same gate as any
        command (refused: a beep, nothing moves); SW10: show the knobs' direction."""
        if action == "show_preset":
            self.showing_preset = self.presets is not None
            return
        axis = PRESET_ACTIONS[action]
        if self.presets is None or axis not in self.rotator.caps.axes:
            return                       # no knobs wired, or no elevation: no function
        try:
            target = self.presets.preset_deg(axis, self.rotator.status())
            (self.rotator.goto_az if axis == "az" else self.rotator.goto_el)(target)
        except UrcError as exc:          # CommandRejected, an unreadable knob
            self.controls.last_refusal = f"{action}: {exc}"
            log.info("front panel %s refused: %s", action, exc)
            self.beeper.beep("refused")
            return
        log.info("front panel: %s to the preset %.0f deg", axis, target)
        self.beeper.beep("click")

    def _zero_press(self, name: str) -> None:
        zero = self.zero
        if zero is None:  # (called only while a zero setting is active)
            return
        if name in ("cw", "ccw"):
            zero.press(JOGS[name][1], self.now_s())
        elif name == "slow":
            try:
                zero.store()
            except UrcError as exc:
                log.error("front panel: zero not stored: %s", exc)
                self.beeper.beep("refused")
                return
            log.warning("front panel: %s %.1f stored", zero.label, zero.value_deg)
            self.beeper.beep("stored")
        elif name == "stop":
            zero.cancel()
            self.rotator.stop()

    # ---------------------------------------------------------------- outputs
    def update(self, now_s: float | None = None) -> None:
        """LEDs, beeper, IR keys and zero-setting repeats, at the panel's pace."""
        now = self.now_s() if now_s is None else now_s
        if self.ir is not None:
            self.ir.poll()
        if self.zero is not None and self.zero.active:
            self.zero.update(now)
        self._release_lost(now)
        st = self.rotator.status()
        if st.faults and not self._had_fault:
            self.beeper.beep("fault")
            self._woken()
        self._had_fault = bool(st.faults)
        target = (st.target_az_deg, st.target_el_deg)
        if target != self._target:
            # a new target that no key here set: a command from a protocol port
            if self.beep_on_command and st.target_az_deg is not None and now - self._key_s > 1.0:
                self.beeper.beep("command")
            self._target = target
        if self.screensaver_s and not self.asleep and now - self._key_s >= self.screensaver_s:
            self.asleep = True
            self._light(0)
        states = led_states(st, now)
        for name, led in self.leds.items():
            led.value = getattr(states, name)
        self.beeper.update(now)

    def display_rows(self, now_s: float | None = None) -> list[str]:
        now = self.now_s() if now_s is None else now_s
        cols, rows = self.display.cols, self.display.rows
        if self.zero is not None and self.zero.active:
            return zero_rows(self.zero.label, self.zero.value_deg, cols, rows)
        st = self.rotator.status()
        if self.showing_preset:
            return self._preset_screen(st, cols, rows)
        return status_rows(st, now, cols, rows, self.wall_s(), self.timezone, self.clock)

    def _preset_screen(self, st: Any, cols: int, rows: int) -> list[str]:
        shown: dict[str, float | None] = {}
        why = ""
        for axis in st.axes:
            try:
                shown[axis] = self.presets.preset_deg(axis, st)
            except UrcError as exc:
                shown[axis], why = None, str(exc)
        return preset_rows(shown.get("az"), shown.get("el"), st.el is not None, cols, rows, why)

    def refresh_display(self, now_s: float | None = None) -> None:
        if self.display is not None:
            self.display.show(self.display_rows(now_s))
            self.follow_lcdc()

    def follow_lcdc(self) -> None:
        """A Tartu client's LCDC contrast (0..63) reaches a display that has a contrast
        control (the OLED; a PCF8574 backpack's contrast is a trimmer)."""
        level = lcd_contrast(self.rotator)
        if level is not None and level != self._contrast and hasattr(self.display, "contrast"):
            self.display.contrast(round(level * 255 / LCD_CONTRAST_MAX))
            self._contrast = level

    def close(self) -> None:
        self.controls.release_all()
        if self.zero is not None and self.zero.active:
            self.zero.cancel()
        for dev in self._devices:
            dev.close()
        if self.presets_bus is not None:
            self.presets_bus.close()
        if self.display is not None:
            self.display.close()


async def run_panel(panel: FrontPanel, stop: asyncio.Event, refresh_hz: float) -> None:
    """Run the panel beside the control loop until ``stop``: updates on this (asyncio)
    thread, display writes in a worker thread, never more than one at a time."""
    loop = asyncio.get_running_loop()
    writing: asyncio.Future | None = None
    next_refresh_s = 0.0
    while not stop.is_set():
        try:
            panel.update()
            if panel.display is not None and (writing is None or writing.done()) \
                    and loop.time() >= next_refresh_s:
                if writing is not None and writing.exception() is not None:
                    log.error("front panel display: %s", writing.exception())
                rows = panel.display_rows()
                writing = loop.run_in_executor(None, panel.display.show, rows)
                next_refresh_s = loop.time() + 1.0 / refresh_hz
        except Exception:  # the panel must never take urc down
            log.exception("front panel update failed")
        try:
            await asyncio.wait_for(stop.wait(), UPDATE_PERIOD_S)
        except asyncio.TimeoutError:
            pass
    if writing is not None:
        await asyncio.gather(writing, return_exceptions=True)
