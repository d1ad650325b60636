"""Reading a large element catalog in a process of its own.

Reading and checking a catalog is Python code: 30 000 sets are ~0.6 s of CPU, 100 000
about 2 s, more on a Raspberry Pi. On a thread of urc run's I/O process it shares
Python's global lock with the event loop: on a loaded two-core machine the loop's
0.1 s timer then ran 50-190 ms late again and again, once 836 ms, close to the 1 s of
silence after which the control process stops the axes (issue 33). A process has its
own lock. It is started for each read (a catalog changes seldom; no idle process kept)
with the ``spawn`` method (forking a process that runs threads can copy a held lock).

It hands the catalog back packed (urc.tracking.elements._Packed) through a temporary
file, read straight into one anonymous memory map here: records, index and names.
(Sent through the pipe, tens of MB passed through the C heap, which kept much of them:
RSS grew with every reload.)

Small catalogs are read where they are asked for: below ISOLATED_READ_BYTES the read
costs less than starting a process.
"""

from __future__ import annotations

import multiprocessing
import os
import tempfile
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool

from .elements import Catalog, _Packed

#: a catalog file larger than this (~3 500 sets) is read in a process of its own
ISOLATED_READ_BYTES = 1_000_000


def read_catalog(directory: str | os.PathLike[str]) -> Catalog:
    """:meth:`Catalog.load`, in a process of its own when the file is large (blocking:
    call it from a worker thread). A process that died is answered by a read here."""
    try:
        size = Catalog.path_in(directory).stat().st_size
    except OSError:
        size = 0
    if size <= ISOLATED_READ_BYTES:
        return Catalog.load(directory)
    try:
        with ProcessPoolExecutor(max_workers=1, mp_context=multiprocessing.get_context("spawn")) as pool:
            path, layout = pool.submit(_load, os.fspath(directory)).result()
    except BrokenProcessPool:  # killed, out of memory: the read must still happen
        return Catalog.load(directory)
    try:
        with open(path, "rb", buffering=0) as fh:
            return Catalog._of_packed(_Packed.read(fh, layout))
    finally:
        os.unlink(path)


def _load(directory: str) -> tuple[str, tuple[int, int, int]]:
    """In the process: read the catalog, write it packed to a temporary file."""
    packed = Catalog.load(directory)._packed
    fd, path = tempfile.mkstemp(prefix="urc-catalog-")
    with os.fdopen(fd, "wb") as fh:
        return path, packed.write(fh)


__all__ = ["ISOLATED_READ_BYTES", "read_catalog"]
