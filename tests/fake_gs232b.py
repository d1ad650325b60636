"""A GS-232B controller on a pseudo-terminal, in the test process: it turns at a fixed
rate, answers C2 / W / S properly, then (on request) garbage or nothing at all, and can
vanish as a controller whose process dies does. Shared by the bridge tests
(tests/hardware/test_bridge_processes.py) and the bridged dashboard's browser test."""

from __future__ import annotations

import os
import re
import threading
import time
import tty


class FakeGs232b:
    """A GS-232B on a pty (RATE_DEG_PER_S on both axes) that answers properly, then (on
    request) garbage or nothing at all; ``ignore_while_moving``: a new target while it
    moves is ignored (some controllers need a stop first). It records every byte it is
    sent, and the targets it ignored."""

    #: half the downstream's (berkeley) top speed: its legs take seconds, not tens
    RATE_DEG_PER_S = 20.0

    def __init__(self, link: str, ignore_while_moving: bool = False):
        self.master, self.slave = os.openpty()
        tty.setraw(self.slave)
        self.link = link
        os.symlink(os.ttyname(self.slave), link)
        self.az = self.el = 0.0
        self.target = (0.0, 0.0)
        self.mode = "answer"    # | "garbage" | "silent"
        self.ignore_while_moving = ignore_while_moving
        self.ignored: list[tuple[float, float]] = []
        self.received = b""
        self.received_at_switch = -1
        self._stop = threading.Event()
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def switch_to(self, mode: str) -> None:
        self.received_at_switch = len(self.received)
        self.mode = mode

    def _run(self) -> None:
        buf, last = b"", time.monotonic()
        os.set_blocking(self.master, False)
        while not self._stop.is_set():
            now = time.monotonic()
            for i, tgt in ((0, self.target[0]), (1, self.target[1])):
                cur = self.az if i == 0 else self.el
                reach = self.RATE_DEG_PER_S * (now - last)
                step = max(-reach, min(reach, tgt - cur))
                if i == 0:
                    self.az += step
                else:
                    self.el += step
            last = now
            try:
                data = os.read(self.master, 256)
            except (BlockingIOError, OSError):
                time.sleep(0.005)
                continue
            self.received += data
            buf += data
            while b"\r" in buf:
                line, buf = buf.split(b"\r", 1)
                if self.mode == "silent":
                    continue
                if self.mode == "garbage":
                    os.write(self.master, b"\x00\x13#?AZ=x\r\n")
                elif line == b"C2":
                    os.write(self.master, b"AZ=%03d  EL=%03d\r\n" % (round(self.az), round(self.el)))
                elif m := re.fullmatch(rb"W(\d{3}) (\d{3})", line):
                    target = (float(m.group(1)), float(m.group(2)))
                    if self.ignore_while_moving and self.target != (self.az, self.el):
                        self.ignored.append(target)
                    else:
                        self.target = target
                elif line == b"S":
                    self.target = (self.az, self.el)

    def vanish(self) -> None:
        """Gone as a controller whose process dies: both ends of its pty close (the
        kernel hangs up the side urc holds); its link stays behind, dangling."""
        self._stop.set()
        self.thread.join(2)
        for fd in (self.master, self.slave):
            if fd >= 0:
                os.close(fd)
        self.master = self.slave = -1

    def close(self) -> None:
        self.vanish()
        os.unlink(self.link)
