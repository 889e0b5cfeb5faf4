"""cml-edge: a Cognitive Map Learner navigator emulated on neuromorphic synaptic arrays.

The CML (Polykretis & Danielescu 2024, section 2.1) is written once (:mod:`cml_edge.core`)
against the synaptic-array seam; every device (:mod:`cml_edge.backends`: float,
fixed point, crossbar) runs it unchanged, in every world (:mod:`cml_edge.grid`,
:mod:`cml_edge.robot`). The command is :mod:`cml_edge.cli`.
"""

from __future__ import annotations

import hashlib
import importlib.abc
import importlib.util
import os
import sys
from pathlib import Path

__version__ = "0.1.0"

GYMNASIUM_ENVS = {
    "cml_edge/GridNav-v0": ("cml_edge.grid.env:GridNavEnv", {}),
    "cml_edge/GridNavGoal-v0": ("cml_edge.grid.env:GridNavEnv", {"goal_conditioned": True}),
    "cml_edge/GridNav3D-v0": ("cml_edge.grid.env:GridNavEnv", {"dims": 3}),
    "cml_edge/RobotNav-v0": ("cml_edge.robot.env:RobotNavEnv", {}),
    "cml_edge/DroneNav-v0": ("cml_edge.drone.env:DroneNavEnv", {}),
}
"""The Gymnasium environment ids of the grid (:mod:`cml_edge.grid.env`), the robot
(:mod:`cml_edge.robot.env`) and the drone (:mod:`cml_edge.drone.env`), and their entry
points and keyword arguments."""


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


def register_envs() -> None:
    """Register :data:`GYMNASIUM_ENVS` with Gymnasium (idempotent); the environments'
    modules are imported only when one is made."""
    import gymnasium

    for env_id, (entry_point, kwargs) in GYMNASIUM_ENVS.items():
        if env_id not in gymnasium.registry:
            gymnasium.register(id=env_id, entry_point=entry_point, kwargs=dict(kwargs),
                               max_episode_steps=None)


class _RegisterOnGymnasiumImport(importlib.abc.MetaPathFinder):
    """Registers the environments right after ``gymnasium`` is first imported, so that
    ``import cml_edge`` registers them without importing Gymnasium itself."""

    def find_spec(self, name, path, target=None):
        if name != "gymnasium":
            return None
        sys.meta_path.remove(self)
        spec = importlib.util.find_spec(name)
        if spec is not None and spec.loader is not None:
            exec_module = spec.loader.exec_module

            def exec_then_register(module):
                exec_module(module)
                register_envs()

            spec.loader.exec_module = exec_then_register
        return spec


def _register_envs_lazily() -> None:
    if "gymnasium" in sys.modules:
        register_envs()
    elif not any(isinstance(f, _RegisterOnGymnasiumImport) for f in sys.meta_path):
        sys.meta_path.insert(0, _RegisterOnGymnasiumImport())


_numba_cache_dir()
_register_envs_lazily()
