"""Numba's cache index, saved by one process at a time; a signature compiled by one
process at a time.

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

A lock around each compile as well: :func:`install` also holds a lock per function and
signature (a file named by their hash) while a process compiles it, so a second process
that needs the same kernel at the same time waits, then loads it from the cache, where
it used to compile it too. The first run's warm-up (:mod:`cml_edge.engine.warmup`)
compiles a run's parts in several processes at once, and their parts share kernels. The
lock is taken only for a function cached on disk whose signature the process has not
compiled or loaded yet, and not again inside itself (a process compiling a signature
holds its lock). A wait ends after :data:`WAIT_S` at most, and the process then
compiles the kernel itself. Measured earlier in the report's pool, before the warm-up,
the lock made no gain: three cold full reports with it took 511-533 s, three without
445-490 s (benchmarks/README.md, "The targets on a free machine").
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import time
from collections.abc import Iterator
from typing import Any

try:
    import fcntl
except ImportError:  # pragma: no cover - not on POSIX
    fcntl = None  # type: ignore[assignment]

from numba.core import caching, dispatcher, sigutils

WAIT_S = 600.0
"""The longest a process waits for another to compile a kernel before compiling it too."""
_HELD: set[str] = set()
"""The compile locks this process holds (a compile nests the compiles of its callees)."""


@contextlib.contextmanager
def _locked(path: str, wait_s: float | None = None) -> Iterator[None]:
    """Hold an exclusive lock on file ``path`` (waiting for it; at most ``wait_s`` seconds,
    then going on without it), unless the file cannot be made."""
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
        if wait_s is None:
            fcntl.flock(fd, fcntl.LOCK_EX)
        else:
            end = time.monotonic() + wait_s
            while True:
                try:
                    fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                    break
                except BlockingIOError:
                    if time.monotonic() > end:
                        break
                    time.sleep(0.05)
        yield
    finally:
        os.close(fd)  # lets the lock go


def _compile_lock(disp: dispatcher.Dispatcher, sig: Any) -> str | None:
    """The lock file of ``disp`` compiling ``sig``, or None where no lock is needed (a
    function not cached on disk, or a signature this process already has)."""
    cache_file = getattr(getattr(disp, "_cache", None), "_cache_file", None)
    if cache_file is None:
        return None
    args, _ = sigutils.normalize_signature(sig)
    if tuple(args) in disp.overloads:
        return None
    digest = hashlib.sha256(f"{cache_file._index_path}{args!r}".encode()).hexdigest()[:24]
    return os.path.join(cache_file._cache_path, ".locks", digest + ".compile")


def install() -> None:
    """Wrap Numba's ``IndexDataCacheFile.save`` and ``Dispatcher.compile`` with the locks of
    the module docstring (once per process)."""
    save = caching.IndexDataCacheFile.save
    if getattr(save, "_cml_edge_lock", False):
        return
    compile_ = dispatcher.Dispatcher.compile

    def locked_compile(self: dispatcher.Dispatcher, sig: Any) -> Any:
        path = _compile_lock(self, sig)
        if path is None or path in _HELD:
            return compile_(self, sig)
        with _locked(path, WAIT_S):
            _HELD.add(path)
            try:
                return compile_(self, sig)  # (loads what another process compiled)
            finally:
                _HELD.discard(path)

    def locked_save(self: caching.IndexDataCacheFile, key: Any, data: Any) -> None:
        with _locked(os.path.join(self._cache_path, ".locks",
                                  os.path.basename(self._index_path) + ".lock")):
            save(self, key, data)

    locked_save._cml_edge_lock = True  # type: ignore[attr-defined]
    caching.IndexDataCacheFile.save = locked_save  # type: ignore[method-assign]
    dispatcher.Dispatcher.compile = locked_compile  # type: ignore[method-assign]
