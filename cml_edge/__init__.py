"""cml-edge: a Cognitive Map Learner navigator emulated on neuromorphic synaptic arrays.

The CML (Polykretis & Danielescu 2024, section 2.1) is written once (:mod:`cml_edge.core`)
against the synaptic-array seam; every device (:mod:`cml_edge.backends`: float,
fixed point, crossbar) runs it unchanged, in every world (:mod:`cml_edge.grid`,
:mod:`cml_edge.robot`). The command is :mod:`cml_edge.cli`.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

__version__ = "0.1.0"


def _numba_cache_dir() -> None:
    """Key Numba's on-disk cache by a hash of this package's sources.

    Numba notices a changed source file only for the function defined in it, not
    for the kernels a cached loop inlined from other modules. A cache directory
    per source hash makes any edit start a fresh cache, so a stale kernel can
    never be loaded. A user's own NUMBA_CACHE_DIR is respected.
    """
    if "NUMBA_CACHE_DIR" in os.environ:
        return
    digest = hashlib.sha256()
    root = Path(__file__).parent
    for path in sorted(root.rglob("*.py")):
        digest.update(path.relative_to(root).as_posix().encode())
        digest.update(path.read_bytes())
    base = Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache"))
    os.environ["NUMBA_CACHE_DIR"] = str(base / "cml_edge" / "numba" / digest.hexdigest()[:16])
    try:  # numba may already be imported by the caller; make it re-read the setting
        from numba.core import config

        config.reload_config()
    except ImportError:  # pragma: no cover - numba is a core dependency
        pass


_numba_cache_dir()
