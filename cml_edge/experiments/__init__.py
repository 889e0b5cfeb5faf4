"""The paper's experiments as commands (``cml-edge sweep NAME``), plus five past it.

One readable module per experiment; each lists its (configuration x seed) tasks for
the sweep engine (:mod:`cml_edge.engine.sweep`) and writes ``results.json``, ``results.csv``
and ``figure.png`` (:mod:`cml_edge.experiments.common`).
"""

from __future__ import annotations

from importlib import import_module
from types import ModuleType

from cml_edge.errors import InputError

EXPERIMENTS = ("convergence", "hyperparams", "exploration", "generalization", "obstacles",
               "maps", "backends", "choices", "levels", "sensors")


def get(name: str) -> ModuleType:
    """The module of experiment ``name``; InputError naming the allowed ones otherwise."""
    if name not in EXPERIMENTS:
        raise InputError(f"unknown experiment {name!r}; allowed: {', '.join(EXPERIMENTS)}")
    return import_module(f"cml_edge.experiments.{name}")
