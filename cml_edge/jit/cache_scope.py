"""Compiled code specialised for a class from outside the package is cached apart from it.

Numba keeps one cache index per function: a pickled dict from each compiled signature to
its code, read whole at every lookup. A signature names the classes of its arguments (a
device's state ``NamedTuple``), so a training loop compiled for a plugin device puts an
entry naming the plugin's module into the loop's index; once that module is gone (the
plugin file removed, or a command run without it), unpickling the index raises
``ModuleNotFoundError`` for every later lookup of the loop, and every command of the
install fails. And Numba checks only the source of the function itself, not of the
kernels it inlined from another file: an edited plugin would load code compiled from its
old source.

:func:`install` (run when :mod:`cml_edge.jit` is imported) routes each entry by the
modules its key names when pickled (:func:`scope`):

- only the package, Numba, NumPy, llvmlite and the standard library: the function's own
  index, as Numba keeps it;
- any other module (a plugin, a device kit's generated module, a test module): an index of
  its own beside it, named after those modules and a hash of their source files. It is
  read only when a key naming those modules is looked up, which needs them imported, and
  an edit of any of them names another index, so stale code is never loaded;
- a class pickled by value (defined in ``__main__`` or inside a function): not cached,
  since a class rebuilt in another process is another class and its entry could never be
  found again.

An index that cannot be unpickled (written by a release before this routing) is read as
empty: Numba compiles the function again and overwrites it.
"""

from __future__ import annotations

import hashlib
import io
import os
import pickle
import re
import sys
import warnings
from typing import Any

from numba.core import caching
from numba.core.serialize import dumps

OWN = frozenset({"cml_edge", "numba", "numpy", "llvmlite", "builtins"}) | frozenset(
    sys.stdlib_module_names)
"""Top-level packages whose classes may enter a function's own index."""
BY_VALUE = "numba.cloudpickle"
"""The pickler's helpers for what it pickles by value (a class with no importable name)."""
UNCACHED = ""
"""The scope of a key that is not cached (:func:`scope`)."""


class _Recorder(pickle.Unpickler):
    """Unpickles, noting the module of every global the stream names."""

    def __init__(self, data: bytes) -> None:
        super().__init__(io.BytesIO(data))
        self.modules: set[str] = set()

    def find_class(self, module: str, name: str) -> Any:
        self.modules.add(module)
        return super().find_class(module, name)


_SOURCE_HASHES: dict[tuple[str, str, float], str] = {}


def _source_hash(module: str) -> str:
    """A hash of ``module``'s source file (of its name, for a module without one)."""
    path = getattr(sys.modules.get(module), "__file__", None) or ""
    try:
        mtime = os.stat(path).st_mtime if path else 0.0
    except OSError:
        mtime = 0.0
    memo = (module, path, mtime)
    if memo not in _SOURCE_HASHES:
        digest = hashlib.sha256(module.encode())
        try:
            with open(path, "rb") as f:
                digest.update(f.read())
        except OSError:
            pass
        _SOURCE_HASHES[memo] = digest.hexdigest()
    return _SOURCE_HASHES[memo]


def scope(key: Any) -> str | None:
    """Where an index entry of ``key`` goes: None for the function's own index, a name
    for an index of the modules outside :data:`OWN` that the key names,
    :data:`UNCACHED` for a key that pickles a class by value."""
    recorder = _Recorder(dumps(key))
    recorder.load()
    if any(m.startswith(BY_VALUE) for m in recorder.modules):
        return UNCACHED
    foreign = sorted(m for m in recorder.modules if m.split(".")[0] not in OWN)
    if not foreign:
        return None
    digest = hashlib.sha256("".join(_source_hash(m) for m in foreign).encode())
    names = re.sub(r"[^A-Za-z0-9_]+", "_", "-".join(m.rsplit(".", 1)[-1] for m in foreign))
    return f"{names[:40]}-{digest.hexdigest()[:12]}"


def _index_for(index: caching.IndexDataCacheFile, key: Any
               ) -> caching.IndexDataCacheFile | None:
    """The index an entry of ``key`` goes to (``index`` itself, a scoped sibling), or
    None if it is not cached."""
    if getattr(index, "_cml_edge_scoped", False):
        return index
    where = scope(key)
    if where is None:
        return index
    if where == UNCACHED:
        return None
    siblings = index.__dict__.setdefault("_cml_edge_siblings", {})
    if where not in siblings:
        base = index._index_name[:-len(".nbi")]
        sibling = caching.IndexDataCacheFile(index._cache_path, f"{base}.{where}",
                                             index._source_stamp)
        sibling._cml_edge_scoped = True
        siblings[where] = sibling
    return siblings[where]


def install() -> None:
    """Route Numba's cache entries as the module docstring says (once per process)."""
    cls = caching.IndexDataCacheFile
    if getattr(cls, "_cml_edge_scope", False):
        return
    save, load, load_index = cls.save, cls.load, cls._load_index

    def scoped_save(self: caching.IndexDataCacheFile, key: Any, data: Any) -> None:
        target = _index_for(self, key)
        if target is not None:
            save(target, key, data)

    def scoped_load(self: caching.IndexDataCacheFile, key: Any) -> Any:
        target = _index_for(self, key)
        return None if target is None else load(target, key)

    def tolerant_load_index(self: caching.IndexDataCacheFile) -> dict:
        try:
            return load_index(self)
        except (ImportError, AttributeError, pickle.UnpicklingError, EOFError) as exc:
            warnings.warn(f"cml-edge: kernel cache index {self._index_path} is unreadable "
                          f"({exc}); compiling again", RuntimeWarning, stacklevel=2)
            return {}

    cls.save, cls.load, cls._load_index = scoped_save, scoped_load, tolerant_load_index
    cls._cml_edge_scope = True
