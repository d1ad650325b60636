"""A 128x64 (or 128x32) SSD1306 OLED on I2C, as on the Berkeley rotor's control board
(seed 004), through luma.oled on an injected smbus2-like bus (an smbus2.SMBus on a Pi,
:class:`Ssd1306Bus` in emulation). luma.oled and Pillow install cleanly from PyPI (pure
Python plus Pillow's wheels), so no hand-written framebuffer driver is needed; they are
in the ``pi`` extra and imported only when an OLED is configured.
"""

from __future__ import annotations

from typing import Any

#: SSD1306 commands that take argument bytes, and how many
_ARGS = {0x20: 1, 0x21: 2, 0x22: 2, 0x81: 1, 0x8D: 1, 0xA8: 1, 0xD3: 1, 0xD5: 1, 0xD9: 1, 0xDA: 1,
         0xDB: 1, 0x26: 6, 0x27: 6, 0x29: 5, 0x2A: 5, 0xA3: 2}
#: pixel rows of one text row (Pillow's default bitmap font is 11 px high)
LINE_PX = 12


def load_font():
    from PIL import ImageFont

    return ImageFont.load_default()


class Oled:
    """Rows of text on an SSD1306; the frame is sent only when the text changed."""

    def __init__(self, bus: Any, address: int = 0x3C, width: int = 128, height: int = 64,
                 contrast: int = 0xCF):
        from luma.core.interface.serial import i2c
        from luma.oled.device import ssd1306

        self.device = ssd1306(i2c(bus=bus, address=address), width=width, height=height)
        self.rows = height // LINE_PX
        self.cols = 21
        self.font = load_font()
        self._shown: list[str] | None = None
        #: the configured contrast: what a backlight of 100 % gives
        self.full_contrast = contrast
        self.contrast(contrast)

    def show(self, lines: list[str]) -> None:
        if lines == self._shown:
            return
        self.device.display(render(lines, self.device.width, self.device.height, self.font))
        self._shown = list(lines)

    def contrast(self, level: int) -> None:
        """0..255 (the SSD1306's own contrast register)."""
        self.device.contrast(max(0, min(255, int(level))))

    def backlight(self, pct: int) -> None:
        """Brightness in percent of the configured contrast; 0 switches the panel off
        (the BIG-RAS screensaver), more switches it on again."""
        if pct <= 0:
            self.device.hide()
            return
        self.device.show()
        self.contrast(round(self.full_contrast * pct / 100))

    def close(self) -> None:
        try:
            self.device.cleanup()
        except Exception:  # the bus may already be gone at shutdown
            pass


def render(lines: list[str], width: int, height: int, font=None):
    """The 1-bit frame for some text rows (also what tests compare the glass with)."""
    from PIL import Image, ImageDraw

    img = Image.new("1", (width, height))
    draw = ImageDraw.Draw(img)
    for r, text in enumerate(lines):
        draw.text((0, r * LINE_PX), text.rstrip(), fill=1, font=font or load_font())
    return img


class Ssd1306Bus:
    """An emulated SSD1306 on an smbus2-like bus: decodes the command stream (control
    byte 0x00) and writes display data (0x40) into GDDRAM with the column/page window
    set by 0x21/0x22 in horizontal addressing mode. ``image()`` is what the glass shows."""

    def __init__(self, address: int = 0x3C, width: int = 128, height: int = 64):
        self.address, self.width, self.height = address, width, height
        self.gddram = bytearray(width * height // 8)
        self.contrast: int | None = None
        self.on = False
        self._pending: list[int] = []
        self._col = (0, width - 1)
        self._page = (0, height // 8 - 1)
        self._x, self._p = 0, 0

    def write_i2c_block_data(self, address: int, control: int, data: list[int]) -> None:
        if address != self.address:
            raise OSError(121, f"no device at 0x{address:02x}")
        if control == 0x00:
            for b in data:
                self._command_byte(b)
        elif control == 0x40:
            for b in data:
                self._data_byte(b)
        else:
            raise OSError(5, f"bad SSD1306 control byte 0x{control:02x}")

    def close(self) -> None:
        pass

    def _command_byte(self, b: int) -> None:
        self._pending.append(b)
        op = self._pending[0]
        if len(self._pending) <= _ARGS.get(op, 0):
            return
        args, self._pending = self._pending[1:], []
        if op == 0x21:
            self._col, self._x = (args[0], args[1]), args[0]
        elif op == 0x22:
            self._page, self._p = (args[0], args[1]), args[0]
        elif op == 0x81:
            self.contrast = args[0]
        elif op in (0xAE, 0xAF):
            self.on = op == 0xAF

    def _data_byte(self, b: int) -> None:
        self.gddram[self._p * self.width + self._x] = b
        if self._x < self._col[1]:
            self._x += 1
            return
        self._x = self._col[0]
        self._p = self._p + 1 if self._p < self._page[1] else self._page[0]

    def image(self):
        from PIL import Image

        img = Image.new("1", (self.width, self.height))
        px = img.load()
        assert px is not None  # (a new image is loaded)
        for y in range(self.height):
            for x in range(self.width):
                px[x, y] = (self.gddram[(y // 8) * self.width + x] >> (y % 8)) & 1
        return img
