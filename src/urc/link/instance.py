"""One urc per state directory (and per hardware): an exclusive lock held while running.

Two controllers on one state file overwrite each other's position, and on real iron both
would drive the motors. ``fcntl.flock`` locks go away with the process (even on kill -9),
so a crash never leaves a stale lock behind. The lock is taken before anything is built
or written: a refused start leaves the state untouched.
"""

from __future__ import annotations

import fcntl
import logging
import os
import tempfile
import time
from pathlib import Path

from ..errors import UrcError

log = logging.getLogger(__name__)

LOCK_FILE = "urc.lock"
#: how long a start waits for a previous urc whose I/O process is gone while its control
#: process still brings the axes to rest and saves (control_process.STOP_TIMEOUT_S)
STOPPING_WAIT_S = 30.0


class InstanceLocked(UrcError):
    """Another urc holds the state directory or the hardware."""


class InstanceLock:
    def __init__(self, path: Path, what: str):
        self.path = Path(path)
        self.what = what
        self._fd: int | None = None

    def acquire(self, stopping_wait_s: float = STOPPING_WAIT_S) -> "InstanceLock":
        self.path.parent.mkdir(parents=True, exist_ok=True)
        fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
        give_up_s = time.monotonic() + stopping_wait_s
        waited = False
        while True:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                break
            except OSError:
                holder = os.pread(fd, 64, 0).decode(errors="replace").strip() or "unknown"
                if _stopping(holder) and time.monotonic() < give_up_s:
                    if not waited:
                        log.warning("%s: waiting (at most %.0f s) for the urc that held it (pid %s) to bring "
                                    "its axes to rest and save", self.what, stopping_wait_s, holder.split()[0])
                        waited = True
                    time.sleep(0.1)  # its control process is bringing the axes to rest
                    continue
                os.close(fd)
                raise InstanceLocked(f"{self.what} is in use by another urc (pid {holder}, lock {self.path}); "
                                     "stop that one first, or give this one another --state-dir") from None
        _say(fd)
        self._fd = fd
        return self

    @property
    def fd(self) -> int | None:
        return self._fd

    @classmethod
    def handed_over(cls, fd: int, path: Path, what: str) -> "InstanceLock":
        """A lock held through a descriptor a control process handed over (adoption)."""
        lock = cls(path, what)
        lock._fd = fd
        claim(fd)
        return lock

    def release(self) -> None:
        if self._fd is not None:
            os.close(self._fd)  # closing drops the flock
            self._fd = None


def hardware_lock_path(backend: str) -> Path:
    """Where the lock for a machine's real hardware lives (shared by every state dir)."""
    base = Path("/run/lock")
    if not (base.is_dir() and os.access(base, os.W_OK)):
        base = Path(tempfile.gettempdir())
    return base / f"urc-{backend}.lock"


def lock_instance(state_dir: Path, backend: str, real_hardware: bool) -> list[InstanceLock]:
    """Lock the state directory, and the hardware when it is real (a simulator or an
    emulation lives in its state dir). Raises :class:`InstanceLocked`."""
    locks = [InstanceLock(Path(state_dir) / LOCK_FILE, f"state dir {state_dir}").acquire()]
    if real_hardware:
        try:
            locks.append(InstanceLock(hardware_lock_path(backend), f"the {backend} hardware").acquire())
        except InstanceLocked:
            locks[0].release()
            raise
    return locks


def _say(fd: int, *words: str) -> None:
    """Write who holds the lock (this process) and how, into the lock file (the lock is
    the descriptor's: the text is only what a waiting start reads)."""
    try:
        os.ftruncate(fd, 0)
        os.pwrite(fd, (" ".join((str(os.getpid()), *words)) + "\n").encode(), 0)
    except OSError:
        pass


def mark_stopping(fd: int) -> None:
    """In a control process whose I/O process is gone: say in the lock file (still held
    through the inherited descriptor) that this holder is on its way out."""
    _say(fd, "stopping")


def mark_adoptable(fd: int) -> None:
    """In a control process whose I/O process is gone while a bounded motion flies on:
    the next urc run of this state directory takes it over (urc.link.adoption)
    rather than wait for it."""
    _say(fd, "adoptable", "stopping")


def claim(fd: int) -> None:
    """A lock handed over with a control process (urc.link.adoption): held by this
    process from now on, and said so in its file."""
    _say(fd)


def _stopping(holder: str) -> bool:
    """The lock's holder is leaving: it said so, or the process that wrote its pid is gone
    (an I/O process killed before its control process could say so)."""
    parts = holder.split()
    if "stopping" in parts:
        return True
    if not parts or not parts[0].isdigit():
        return False
    try:
        os.kill(int(parts[0]), 0)
    except ProcessLookupError:
        return True
    except OSError:
        return False
    return False


def skip_exit_collection() -> None:
    """At the end of a urc process whose work is done (outputs safe, state saved, ports
    closed): the interpreter's collections while it finalises ~1000 modules' objects only
    delay the exit (0.2 s on an idle machine, up to 1 s on a busy one: every stop and
    ``systemctl restart`` waits for it, and urc run waits for its control process's).
    Frozen objects are left to the OS; nothing of urc's waits for a collection to
    release it."""
    import gc

    gc.freeze()
