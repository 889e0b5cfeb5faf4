"""Numba's cache index, saved by one process at a time.

The report, a sweep and a chip run start worker processes that share one kernel cache
folder. Numba reads a function's cache index, adds an entry and writes it back
(``IndexDataCacheFile.save``) without a lock. Two processes that save two signatures of
one function at once could therefore lose one entry, which the next run compiles again,
or both pick the same data file name, leaving an index entry that names the other
process's code. :func:`install` (run when :mod:`cml_edge.jit` is imported, so in every
process that runs a kernel) holds a file lock (``fcntl.flock`` on a file in ``.locks``
under the cache folder, let go when its process ends, however it ends) around each save.

Without ``fcntl`` (Windows) or where the lock file cannot be made, nothing is locked:
the behaviour is Numba's own.

A lock around each compile as well (a second process that needs a kernel another is
compiling waits, then loads it) was measured and not kept: three cold full reports with
it took 511-533 s, three without 445-490 s (benchmarks/README.md, "The targets on a free
machine").
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Iterator
from typing import Any

try:
    import fcntl
except ImportError:  # pragma: no cover - not on POSIX
    fcntl = None  # type: ignore[assignment]

from numba.core import caching


@contextlib.contextmanager
def _locked(path: str) -> Iterator[None]:
    """Hold an exclusive lock on file ``path`` (waiting for it), unless the file cannot be
    made."""
    if fcntl is None:
        yield
        return
    try:
        os.makedirs(os.path.dirname(path), exist_ok=True)
        fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
    except OSError:
        yield
        return
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        yield
    finally:
        os.close(fd)  # lets the lock go


def install() -> None:
    """Wrap Numba's ``IndexDataCacheFile.save`` with the lock of the module docstring (once
    per process)."""
    save = caching.IndexDataCacheFile.save
    if getattr(save, "_cml_edge_lock", False):
        return

    def locked_save(self: caching.IndexDataCacheFile, key: Any, data: Any) -> None:
        with _locked(os.path.join(self._cache_path, ".locks",
                                  os.path.basename(self._index_path) + ".lock")):
            save(self, key, data)

    locked_save._cml_edge_lock = True  # type: ignore[attr-defined]
    caching.IndexDataCacheFile.save = locked_save  # type: ignore[method-assign]
