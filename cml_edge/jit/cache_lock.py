"""One compile of each kernel among processes that share Numba's cache.

The report, a sweep and a chip run start worker processes that share one kernel cache
folder. On an empty cache, two workers that need the same function for the same types
compiled it side by side, each for the whole 10-30 s a loop takes, when one could have
loaded what the other saved. And Numba's cache index is read, changed and written back
without a lock (``IndexDataCacheFile.save``), so two processes saving two signatures of
one function at once could lose one entry (compiled again by the next run), or have both
pick the same data file name and leave an index entry that names the other's code.

:func:`install` (called when :mod:`cml_edge.jit.kernel` is imported, so in every process
that runs a kernel) adds two file locks (``fcntl.flock``, in ``.locks`` under the cache
folder; a lock is let go when its process ends, however it ends):

- A compile of a cml_edge function for one signature holds that signature's lock: a
  second process that needs it waits, then loads it from the cache. The locks are taken
  in call order (a function's compile takes its callees' locks), so two processes can
  never wait on each other. A process that holds a lock takes it again freely (a
  recursive compile); it waits holding Numba's compiler lock, so one thread of a
  process compiles at a time, as in Numba itself.
- A save into a function's index holds that index's lock, so every entry is kept.

Without ``fcntl`` (Windows) or where the cache folder cannot be written, nothing is
locked: the behaviour is Numba's own. The compiled code is the same either way; only
who compiles it, and when, changes.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any

try:
    import fcntl
except ImportError:  # pragma: no cover - not on POSIX
    fcntl = None  # type: ignore[assignment]

from numba.core import caching, sigutils
from numba.core.compiler_lock import global_compiler_lock
from numba.core.dispatcher import Dispatcher

SCOPE = ("cml_edge.",)
"""The modules whose functions' compiles are locked (their names start so)."""

_held: set[str] = set()
"""The lock files this process holds (a compile nested in another of the same key, a
recursive function, passes through)."""


@contextlib.contextmanager
def _locked(path: str) -> Iterator[None]:
    """Hold an exclusive lock on file ``path`` (waiting for it) unless this process
    already does, or the file cannot be made."""
    if fcntl is None or path in _held:
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
        _held.add(path)
        try:
            yield
        finally:
            _held.discard(path)
            fcntl.flock(fd, fcntl.LOCK_UN)
    finally:
        os.close(fd)


def compile_lock_path(dispatcher: Any, sig: Any) -> str | None:
    """The lock file of ``dispatcher``'s compile for ``sig``; None when it is not a
    cml_edge function cached on disk."""
    cache = getattr(dispatcher, "_cache", None)
    module = getattr(getattr(dispatcher, "py_func", None), "__module__", "") or ""
    if not isinstance(cache, caching.Cache) or not module.startswith(SCOPE):
        return None
    args, _ = sigutils.normalize_signature(sig)
    index = cache._cache_file._index_path
    name = hashlib.sha256(f"{index}|{args!r}".encode()).hexdigest()[:24]
    return str(Path(cache.cache_path) / ".locks" / f"{name}.lock")


def install() -> None:
    """Wrap Numba's ``Dispatcher.compile`` and ``IndexDataCacheFile.save`` with the locks
    of the module docstring (once per process)."""
    if getattr(Dispatcher.compile, "_cml_edge_lock", False):
        return
    compile_ = Dispatcher.compile
    save = caching.IndexDataCacheFile.save

    def locked_compile(self: Dispatcher, sig: Any) -> Any:
        path = compile_lock_path(self, sig)
        if path is None or tuple(sigutils.normalize_signature(sig)[0]) in self.overloads:
            return compile_(self, sig)
        with global_compiler_lock, _locked(path):  # one thread of a process waits
            return compile_(self, sig)

    def locked_save(self: caching.IndexDataCacheFile, key: Any, data: Any) -> None:
        with _locked(os.path.join(self._cache_path, ".locks",
                                  os.path.basename(self._index_path) + ".lock")):
            save(self, key, data)

    locked_compile._cml_edge_lock = True  # type: ignore[attr-defined]
    Dispatcher.compile = locked_compile  # type: ignore[method-assign]
    caching.IndexDataCacheFile.save = locked_save  # type: ignore[method-assign]
