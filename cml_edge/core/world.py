"""The worlds a CML navigates, as a scenario sees them: one small protocol and one registry.

A world (the grid of paper 2.1-2.4, :mod:`cml_edge.grid.world`; the wheeled robot of 2.5,
:mod:`cml_edge.robot.world`) trains a model on a device, plans an evaluation condition's
problems with it and summarises what it planned, and pools those summaries over seeds.
The scenarios (:mod:`cml_edge.scenarios`) run every world through :class:`World` alone,
found by its name in :data:`WORLDS`.

What a world is given is JSON, as the scenarios' registry writes it
(:mod:`cml_edge.scenarios.registry`): ``run``, the training settings of one run (the
grid's arena side, walks, steps and schedule; the robot's walks and steps), and ``part``,
one evaluation condition (its ``name``, the problems: ``trials`` from ``eval_seed``, on
the grid also an arena, obstacles or a map, a planner and a step budget). Everything runs
on the compiled ``direct`` path (:data:`PATH`), where the arrays count every operation.

Adding a world: a module with an object that meets :class:`World`, and one line in
:data:`WORLDS`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from importlib import import_module
from typing import TYPE_CHECKING, Any, NamedTuple, Protocol

import numpy as np

from cml_edge.errors import InputError

if TYPE_CHECKING:
    from cml_edge.core.cml import CML

PATH = "direct"
"""The compute path of a world's runs: the arrays count every operation there, as in
``cml-edge emulate``."""

WORLDS = {"grid": "cml_edge.grid.world:GRID", "robot": "cml_edge.robot.world:ROBOT",
          "drone": "cml_edge.drone.world:DRONE"}
"""World name -> ``module:object`` of its :class:`World` (imported when first asked)."""


class Trained(NamedTuple):
    """What :meth:`World.train` made: the model and each walk's mean training error."""

    cml: CML
    train_error: np.ndarray


class World(Protocol):
    """What a scenario needs of a world (module docstring)."""

    name: str

    def train(self, seed: int, run: Mapping[str, Any], backend: str,
              backend_options: Mapping[str, Any], chip: int | None) -> Trained:
        """Make model ``seed`` on the device (``backend`` with its config fields; its arrays
        on the chip of chip seed ``chip``, None: of the model seed) and train it as ``run``
        says (the local rule, Eqs. 1-3)."""
        ...

    def twin(self, seed: int, run: Mapping[str, Any]) -> CML:
        """The float64 twin of model ``seed``, trained on the same walks
        (:mod:`cml_edge.core.fidelity`)."""
        ...

    def relearn(self, cml: CML, twin: CML, seed: int, run: Mapping[str, Any], walks: int,
                done: int) -> None:
        """``walks`` more walks of in-situ relearning of ``cml`` and its ``twin``, after
        ``done`` such walks (the seed's walk streams continued); InputError in a world
        that does not relearn."""
        ...

    def plan(self, cml: CML, part: Mapping[str, Any], run: Mapping[str, Any]) -> Any:
        """Plan the problems of ``part`` with ``cml``: what :meth:`summarise` reads."""
        ...

    def summarise(self, seed: int, cml: CML, twin: CML, part: Mapping[str, Any],
                  planned: Any) -> dict[str, Any]:
        """The part's JSON record of one model: its settings, the summary of what was
        planned (success, e_pos of Eq. 8, the path overhead of Eq. 9 as ``overhead_mean``),
        the per-trial outcomes :meth:`pool` reads, and the fidelity against ``twin``
        (weight error, decision agreement, read SNR and ``decisions``)."""
        ...

    def pool(self, records: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
        """The summary of a part over the trials of several models' records."""
        ...


def get_world(name: str) -> World:
    """The world called ``name``; InputError naming the known ones otherwise."""
    if name not in WORLDS:
        raise InputError(f"unknown world {name!r}; allowed: {', '.join(WORLDS)}")
    module, attr = WORLDS[name].split(":")
    return getattr(import_module(module), attr)
