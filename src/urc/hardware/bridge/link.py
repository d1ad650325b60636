"""The bridge's I/O: a serial line or TCP socket (pyserial does both: a device path or
``socket://host:port``), served by one thread so that no read or write ever runs on
the control tick. The thread asks the client engine what to send, waits for the
answer within the protocol's timeout, and reconnects with a bounded back-off when the
link goes away."""

from __future__ import annotations

import logging
import termios
import threading
import time

import serial

from .client import BridgeClient
from .dialects import Exchange

log = logging.getLogger("urc.bridge")

#: reconnect back-off: first wait, growth factor, longest wait (seconds)
BACKOFF_FIRST_S, BACKOFF_FACTOR, BACKOFF_MAX_S = 0.5, 2.0, 5.0


class LinkError(OSError):
    """The link failed (closed, vanished device, no such host)."""


class Timeout(Exception):
    def __init__(self, partial: bytes):
        self.partial = partial


def port_url(serial_path: str | None, tcp: str | None) -> str:
    return f"socket://{tcp}" if tcp else str(serial_path)


class SyncLink:
    """One open connection; blocking exchanges (only ever called from the I/O thread
    or from ``urc hw check``)."""

    def __init__(self, url: str, baud: int, timeout_s: float):
        self.url, self.baud, self.timeout_s = url, baud, timeout_s
        try:
            self.port = serial.serial_for_url(url, baudrate=baud, timeout=timeout_s, write_timeout=timeout_s)
        except (serial.SerialException, OSError, ValueError) as exc:
            why = getattr(exc, "strerror", None) or str(exc)
            raise LinkError(f"cannot open {url}: {why}") from None

    def exchange(self, ex: Exchange, stopping: threading.Event | None = None) -> bytes | None:
        """Write ``ex``; return its whole answer (None when it has none). Raises Timeout
        (with what arrived) or LinkError."""
        try:
            if ex.flush_before:
                self.port.reset_input_buffer()
            self.port.write(ex.request)
            self.port.flush()
            if ex.reply is None:
                return None
            buf = b""
            deadline = time.monotonic() + self.timeout_s
            while (n := ex.reply.complete(buf)) is None:
                remaining = deadline - time.monotonic()
                if remaining <= 0 or (stopping is not None and stopping.is_set()):
                    raise Timeout(buf)
                self.port.timeout = min(remaining, 0.1)
                buf += self.port.read(max(1, self.port.in_waiting))
            return buf[:n]
        except serial.SerialTimeoutException as exc:
            raise LinkError(f"write timed out: {exc}") from None
        except (serial.SerialException, OSError) as exc:
            raise LinkError(str(exc) or type(exc).__name__) from None
        except termios.error as exc:
            # pyserial flushes a tty with termios, whose error is no OSError: a pty whose
            # other end closed fails here first (it used to end the I/O thread, and the
            # fault then read "no position report" instead of "link lost")
            raise LinkError(f"port failed: {exc.args[-1] if exc.args else exc}") from None

    def close(self) -> None:
        try:
            self.port.close()
        except Exception:  # closing a vanished device must not raise
            pass


class LinkRunner:
    """The I/O thread of one bridge."""

    def __init__(self, client: BridgeClient, url: str, baud: int, reconnect_attempts: int = 30,
                 name: str = "bridge"):
        self.client, self.url, self.baud = client, url, baud
        self.reconnect_attempts = reconnect_attempts
        self._link: SyncLink | None = None
        self._stopping = threading.Event()
        self._wake = threading.Event()
        self._thread = threading.Thread(target=self._run, name=f"{name}-io", daemon=True)

    def start(self) -> None:
        self._thread.start()

    def wake(self) -> None:
        """A new target was posted: no need to wait for the next poll slot."""
        self._wake.set()

    def close(self, timeout_s: float = 3.0) -> None:
        """Tell the controller to stop (urc stops or exits), then close the link."""
        self._stopping.set()
        self._wake.set()
        self._thread.join(timeout_s)

    # ---------------------------------------------------------------- the thread
    def _run(self) -> None:
        failures, backoff_s = 0, BACKOFF_FIRST_S
        while not self._stopping.is_set():
            if self._link is None:
                try:
                    self._link = SyncLink(self.url, self.baud, self.client.timeout_s)
                except LinkError as exc:
                    failures += 1
                    if failures == 1:
                        self.client.link_down(str(exc), time.monotonic())
                    self.client.reconnecting(failures, self.reconnect_attempts, str(exc))
                    if failures > self.reconnect_attempts:
                        log.error("bridge %s: %s", self.client.dialect.name, self.client.error())
                        return
                    self._stopping.wait(backoff_s)
                    backoff_s = min(backoff_s * BACKOFF_FACTOR, BACKOFF_MAX_S)
                    continue
                log.info("bridge %s: connected to %s", self.client.dialect.name, self.url)
                failures, backoff_s = 0, BACKOFF_FIRST_S
                self.client.link_up(time.monotonic())
            ex, wait_s = self.client.next_exchange(time.monotonic())
            if ex is None:
                self._wake.wait(min(wait_s, 0.05))
                self._wake.clear()
                continue
            self._run_exchange(ex)
            if self._link is not None and self.client.link_broken():
                self._drop(f"{self.client.options.max_failures} bad or missing answers in a row", failures=True)
        self._final_stop()

    def _run_exchange(self, ex: Exchange) -> None:
        sent_s = time.monotonic()
        try:
            data = self._link.exchange(ex, self._stopping)
        except Timeout as exc:
            self.client.timed_out(ex, exc.partial, time.monotonic())
            return
        except LinkError as exc:
            self._drop(str(exc))
            return
        except Exception as exc:  # the I/O thread must never die: a surprise is a lost link
            log.exception("bridge %s: unexpected error on the link", self.client.dialect.name)
            self._drop(f"unexpected {type(exc).__name__}: {exc}")
            return
        if data is None:
            self.client.sent(ex, time.monotonic())
        else:
            self.client.answered(ex, data, sent_s, time.monotonic())
        if ex.settle_s:
            self._stopping.wait(ex.settle_s)

    def _drop(self, reason: str, failures: bool = False) -> None:
        self.client.link_down(reason, time.monotonic(), failures)
        if self._link is not None:
            self._link.close()
            self._link = None

    def _final_stop(self) -> None:
        if self._link is None:
            return
        try:
            self._link.exchange(self.client.dialect.stop())
            log.info("bridge %s: controller told to stop", self.client.dialect.name)
        except (LinkError, Timeout) as exc:
            log.warning("bridge %s: final stop not confirmed: %s", self.client.dialect.name, exc)
        self._link.close()
        self._link = None
