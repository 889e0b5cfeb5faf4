"""The line a library user sees when the first kernel of a process compiles.

Numba compiles a kernel when the cache holds none for it (the first run after an install
or an edit of the package or of a plugin, or a device's first run): a minute or more on a
cold cache, in silence. :func:`install` (run when :mod:`cml_edge.jit` is imported) listens
for Numba's compile events and, at the first compile of a package or kit function in the
process, says what is happening once: through the ``logging`` logger ``cml_edge`` (at INFO)
when the program has configured logging, else as a line on stderr. The command line says
it its own way (:mod:`cml_edge.cli.compiling`): in a process that has imported
:mod:`cml_edge.cli`, this one says nothing.
"""

from __future__ import annotations

import logging
import sys

from numba.core import config, event

LOGGER = logging.getLogger("cml_edge")
OURS = ("cml_edge.", "cml_edge_kit_")
"""The modules whose compiles are announced: the package's and the kit's generated ones."""
_STATE = {"said": False, "installed": False}


def say(message: str) -> None:
    """``message`` through the ``cml_edge`` logger if logging is configured, else on stderr."""
    if LOGGER.hasHandlers():
        LOGGER.info(message)
    else:
        print(f"cml-edge: {message}", file=sys.stderr, flush=True)


class _FirstCompile(event.Listener):
    def on_start(self, ev: event.Event) -> None:
        if _STATE["said"] or "cml_edge.cli" in sys.modules:
            return
        func = getattr(ev.data["dispatcher"], "py_func", None)
        if not (getattr(func, "__module__", None) or "").startswith(OURS):
            return
        _STATE["said"] = True
        say(f"compiling kernels ({func.__module__}.{func.__name__} first): a minute or more "
            f"on a cold cache, once; later runs load them from {config.CACHE_DIR}")

    def on_end(self, ev: event.Event) -> None:
        pass


def install() -> None:
    """Listen for the first compile (once per process)."""
    if not _STATE["installed"]:
        event.register("numba:compile", _FirstCompile())
        _STATE["installed"] = True
