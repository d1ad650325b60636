"""A 20x2 / 20x4 HD44780 character LCD on a PCF8574 I2C backpack, through RPLCD.

RPLCD opens its own SMBus by port number; :class:`CharLcd` hands it a bus object
instead (an smbus2.SMBus on a Pi, :class:`Pcf8574Hd44780` in emulation), so the same
driver code runs against the emulated chip in tests.

The Tartu controller's own display (a MIDAS COG module) sets its contrast in software
(LCDC); a PCF8574 backpack's contrast is a trimmer on the board, so urc has no contrast
control for this display (the OLED has one).
"""

from __future__ import annotations

from typing import Any

from RPLCD.i2c import CharLCD

# PCF8574 backpack wiring (the common one, and RPLCD's): P0 RS, P1 RW, P2 E,
# P3 backlight, P4-P7 D4-D7
_RS, _E, _BL = 0x01, 0x04, 0x08
#: DDRAM address of each row's first character (HD44780, 20-column modules)
ROW_ADDRESSES = (0x00, 0x40, 0x14, 0x54)


class _InjectedBusLcd(CharLCD):
    """RPLCD's PCF8574 CharLCD on a bus object given to it (not one it opens)."""

    def __init__(self, bus: Any, **kwargs: Any):
        self._injected_bus = bus
        super().__init__(**kwargs)

    def _init_connection(self) -> None:
        self.bus = self._injected_bus


class CharLcd:
    """Rows of text on the LCD; a row is rewritten only when it changed."""

    def __init__(self, bus: Any, address: int = 0x27, cols: int = 20, rows: int = 2):
        self.cols, self.rows = cols, rows
        self._lcd = _InjectedBusLcd(bus, i2c_expander="PCF8574", address=address, cols=cols, rows=rows,
                                    auto_linebreaks=False, charmap="A00")
        self._shown: list[str | None] = [None] * rows

    def show(self, lines: list[str]) -> None:
        for r, text in enumerate(lines[:self.rows]):
            text = text[:self.cols].ljust(self.cols)
            if self._shown[r] != text:
                self._lcd.cursor_pos = (r, 0)
                self._lcd.write_string(text)
                self._shown[r] = text

    def backlight(self, pct: int) -> None:
        """The backpack switches its backlight (P3) only: on above 0 %; at 0 the text
        goes too (the BIG-RAS screensaver: the display dark)."""
        on = pct > 0
        self._lcd.backlight_enabled = on
        self._lcd.display_enabled = on

    def close(self) -> None:
        try:
            self._lcd.close(clear=True)
        except Exception:  # the bus may already be gone at shutdown
            pass


class Pcf8574Hd44780:
    """An emulated PCF8574 backpack with an HD44780 behind it: an smbus2-like bus that
    decodes every byte written back into the controller's state (4-bit nibbles latched
    on the E falling edge; instructions clear, home, entry mode, display on/off,
    function set, set DDRAM address; data into DDRAM). ``text()`` is what the glass
    shows. Reads and other addresses raise OSError like a missing device."""

    def __init__(self, address: int = 0x27, cols: int = 20, rows: int = 2):
        self.address, self.cols, self.rows = address, cols, rows
        self.ddram = bytearray(b" " * 0x80)
        self.addr = 0
        self.increment = 1
        self.four_bit = False
        self.display_on = False
        self.backlight = False
        self.writes = 0
        self._last = 0
        self._high: int | None = None     # the first nibble of a byte in 4-bit mode
        self._rs = 0

    # ---- the smbus2 surface RPLCD uses
    def write_byte(self, address: int, value: int) -> None:
        if address != self.address:
            raise OSError(121, f"no device at 0x{address:02x}")  # EREMOTEIO, as smbus2 gives
        self.writes += 1
        self.backlight = bool(value & _BL)
        if self._last & _E and not value & _E:
            self._latch(self._last)
        self._last = value

    def read_byte(self, address: int) -> int:
        raise OSError(121, "the PCF8574 backpack is write-only here")

    def close(self) -> None:
        pass

    # ---- the HD44780
    def _latch(self, value: int) -> None:
        nibble, rs = value >> 4, value & _RS
        if not self.four_bit:
            # 8-bit mode: D0-D3 are not wired, each strobe is a whole instruction
            self._execute(nibble << 4, rs)
            return
        if self._high is None:
            self._high, self._rs = nibble, rs
            return
        byte, self._high = (self._high << 4) | nibble, None
        self._execute(byte, self._rs)

    def _execute(self, byte: int, rs: int) -> None:
        if rs:
            self.ddram[self.addr & 0x7F] = byte
            self.addr = (self.addr + self.increment) & 0x7F
        elif byte & 0x80:
            self.addr = byte & 0x7F
        elif byte & 0x20:                      # function set: DL bit
            self.four_bit = not byte & 0x10
        elif byte & 0x08:                      # display on/off control
            self.display_on = bool(byte & 0x04)
        elif byte & 0x04:                      # entry mode set
            self.increment = 1 if byte & 0x02 else -1
        elif byte & 0x02:                      # return home
            self.addr = 0
        elif byte & 0x01:                      # clear display
            self.ddram[:] = b" " * 0x80
            self.addr = 0

    def text(self) -> list[str]:
        return [self.ddram[a:a + self.cols].decode("ascii", "replace") for a in ROW_ADDRESSES[:self.rows]]
