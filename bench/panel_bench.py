"""Front-panel display cost: what one refresh takes on the I2C bus and in time.

The displays are driven by the real libraries (RPLCD for the HD44780 on a PCF8574
backpack, luma.oled for the SSD1306) on the emulated chips of urc.frontpanel, which
count the bus transfers. Time is wall time on this machine through the emulated bus
(RPLCD's own settle delays included, no real 100 kHz I2C clock): on a Pi each PCF8574
byte also costs ~0.2 ms of bus time at 100 kHz (an SSD1306 byte ~0.09 ms), given as an estimate. The panel refreshes
from a worker thread at [panel] refresh_hz (default 4), off the control loop.

Prints a table, writes JSON (default bench/results/panel.json).
Usage: python bench/panel_bench.py [--repeat 20]
"""

from __future__ import annotations

import argparse
import statistics
import time

from bench_report import write_json
from urc.frontpanel.lcd import CharLcd, Pcf8574Hd44780

#: one PCF8574 write_byte at 100 kHz: start, address, data, acks, stop (~20 bit times)
PCF8574_BYTE_S = 20 / 100_000
ROWS_A = ["AZ 123.4>130.0   RUN", "EL 045.0>045.0   HLD", "E1 stall az", "TGT 130.0 +45.0"]
ROWS_B = ["AZ 124.1>130.0   RUN", "EL 045.0>045.0   HLD", "LOCAL CW button", "MOVING"]


def lcd_case(rows: int, repeat: int) -> dict:
    chip = Pcf8574Hd44780(0x27, 20, rows)
    lcd = CharLcd(chip, 0x27, 20, rows)
    times, writes = [], []
    for k in range(repeat):
        text = (ROWS_A if k % 2 else ROWS_B)[:rows]
        w0, t0 = chip.writes, time.perf_counter()
        lcd.show(text)
        times.append(time.perf_counter() - t0)
        writes.append(chip.writes - w0)
    assert chip.text() == [r.ljust(20) for r in text]
    n = statistics.mean(writes)
    return {"display": f"HD44780 20x{rows} (PCF8574)", "bus_writes": n, "bytes": n,
            "wall_ms": 1000 * statistics.median(times), "i2c_100k_ms": 1000 * n * PCF8574_BYTE_S}


def oled_case(repeat: int) -> dict | None:
    try:
        from urc.frontpanel.oled import Oled, Ssd1306Bus
    except ImportError:
        return None
    chip = Ssd1306Bus(0x3C, 128, 64)
    calls = {"n": 0, "bytes": 0}
    real = chip.write_i2c_block_data

    def counted(addr, ctrl, data):
        calls["n"] += 1
        calls["bytes"] += len(data) + 2
        real(addr, ctrl, data)
    chip.write_i2c_block_data = counted
    oled = Oled(chip, 0x3C, 128, 64)
    times, sent = [], []
    for k in range(repeat):
        text = ROWS_A if k % 2 else ROWS_B
        b0, t0 = calls["bytes"], time.perf_counter()
        oled.show(text + ["UTC 12:00:00"])
        times.append(time.perf_counter() - t0)
        sent.append(calls["bytes"] - b0)
    n = statistics.mean(sent)
    # 9 bit times per byte at 100 kHz (block writes: one start/address per 32 bytes)
    return {"display": "SSD1306 128x64", "bus_writes": calls["n"] / (repeat + 1), "bytes": n,
            "wall_ms": 1000 * statistics.median(times), "i2c_100k_ms": 1000 * n * 9 / 100_000}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeat", type=int, default=20)
    ap.add_argument("--json", default="bench/results/panel.json")
    args = ap.parse_args()
    rows = [lcd_case(2, args.repeat), lcd_case(4, args.repeat)]
    oled = oled_case(args.repeat)
    if oled:
        rows.append(oled)
    print(f"{'display':<28}{'bytes/refresh':>14}{'wall ms':>10}{'I2C 100k ms (est)':>19}")
    for r in rows:
        print(f"{r['display']:<28}{r['bytes']:>14.0f}{r['wall_ms']:>10.1f}{r['i2c_100k_ms']:>19.1f}")
    write_json({"refreshes": rows, "repeat": args.repeat}, args.json)


if __name__ == "__main__":
    main()
