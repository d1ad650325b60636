"""lgpio's notification FIFO in a directory of each process's own (``LG_WD``).

Importing lgpio opens its notification pipe at once (``lgpio.py``: ``_notify_thread =
_callback_thread()``, then ``open('.lgd-nfy<handle>')``). lg's C side names it
``<work dir>/.lgd-nfy<handle>``, removing any file of that name first (``lgNotify.c``,
``xCreatePipe``: ``unlink``, then ``mkfifo``); the work dir is ``LG_WD`` if set, else
the current directory, and lg changes into it (``lgUtil.c``, ``lguGetWorkDir``). Every
process gets handle 0, so urc's two processes (the I/O process and the control process
it spawns, in one working directory) made the same FIFO: the second's ``unlink`` can come
between the first's C ``open`` and its Python ``open``, and the first then reads the
other's edge reports while its own go to a pipe nobody reads.

So before lgpio is imported, :func:`notify_dir` sets ``LG_WD`` to a new directory of this
process's own (``$XDG_RUNTIME_DIR`` or the temp dir, ``urc-lgpio-<pid>-*``, mode 0700);
the import hook :func:`install` calls it whenever anything imports lgpio (gpiozero's
LGPIOFactory, the takeover's warm-up import) and puts the working directory back after
lg's ``chdir``. ``LG_WD`` set by someone else is the parent of those directories; a
child process inherits ``LG_WD`` but makes its own (the owner's pid is noted beside it).
Directories of processes that are gone are removed.
"""

from __future__ import annotations

import atexit
import importlib.abc
import importlib.machinery
import logging
import os
import shutil
import sys
import tempfile
from pathlib import Path
from types import ModuleType
from typing import Any, Sequence

log = logging.getLogger(__name__)

#: lg's environment variable (lgpio.h: ``#define LG_WD "LG_WD"``)
LG_WD = "LG_WD"
#: the pid whose directory LG_WD names (set beside it by :func:`notify_dir`)
OWNER = "URC_LG_WD_PID"
PREFIX = "urc-lgpio-"


def _base() -> Path:
    given = os.environ.get(LG_WD)
    if given and os.environ.get(OWNER):            # a urc process's own: its parent is the base
        return Path(given).parent
    if given:                                      # the user's: ours go inside it
        return Path(given)
    run = os.environ.get("XDG_RUNTIME_DIR")
    if run and os.path.isdir(run) and os.access(run, os.W_OK):
        return Path(run)
    return Path(tempfile.gettempdir())


def _prune(base: Path) -> None:
    """Remove the directories of urc processes that are gone (a kill leaves its FIFO)."""
    try:
        entries = list(base.glob(f"{PREFIX}*"))
    except OSError:
        return
    for d in entries:
        pid = d.name[len(PREFIX):].split("-", 1)[0]
        if not pid.isdigit() or int(pid) == os.getpid():
            continue
        try:
            os.kill(int(pid), 0)
            continue                               # alive
        except ProcessLookupError:
            pass
        except PermissionError:
            continue                               # alive, someone else's
        shutil.rmtree(d, ignore_errors=True)


def notify_dir() -> Path:
    """This process's own lgpio work directory, made and put in ``LG_WD`` on first call
    (again after a fork: the pid differs)."""
    pid = str(os.getpid())
    if os.environ.get(OWNER) == pid and os.environ.get(LG_WD):
        return Path(os.environ[LG_WD])
    base = _base()
    base.mkdir(parents=True, exist_ok=True)
    _prune(base)
    d = Path(tempfile.mkdtemp(prefix=f"{PREFIX}{pid}-", dir=base))
    os.environ[LG_WD] = str(d)
    os.environ[OWNER] = pid
    atexit.register(shutil.rmtree, d, True)
    return d


class _CwdKeepingLoader(importlib.abc.Loader):
    """lgpio's own loader, with the working directory put back after lg's ``chdir``."""

    def __init__(self, loader: Any):
        self.loader = loader

    def create_module(self, spec: importlib.machinery.ModuleSpec) -> ModuleType | None:
        return self.loader.create_module(spec)  # type: ignore[no-any-return]

    def exec_module(self, module: ModuleType) -> None:
        cwd = os.getcwd()
        try:
            self.loader.exec_module(module)
        finally:
            os.chdir(cwd)

    def __getattr__(self, name: str) -> Any:      # get_source etc. for tracebacks
        return getattr(self.loader, name)


class _BeforeLgpio(importlib.abc.MetaPathFinder):
    def find_spec(self, fullname: str, path: Sequence[str] | None,
                  target: ModuleType | None = None) -> importlib.machinery.ModuleSpec | None:
        if fullname != "lgpio":
            return None
        try:
            notify_dir()
        except OSError as exc:                     # lgpio then works as before, in the cwd
            log.warning("lgpio: no notify directory of this process's own (%s): LG_WD unchanged", exc)
            return None
        spec = importlib.machinery.PathFinder.find_spec(fullname, path)
        if spec is None or spec.loader is None:
            return spec
        spec.loader = _CwdKeepingLoader(spec.loader)
        return spec


_FINDER = _BeforeLgpio()


def install() -> None:
    """Make every later import of lgpio in this process get its own ``LG_WD`` first."""
    if "lgpio" in sys.modules:
        if os.environ.get(OWNER) != str(os.getpid()):
            log.warning("lgpio was imported before urc could give it a notify directory of this "
                        "process's own (LG_WD)")
        return
    if _FINDER not in sys.meta_path:
        sys.meta_path.insert(0, _FINDER)
