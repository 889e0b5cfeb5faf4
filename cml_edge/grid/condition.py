"""An evaluation condition on the grid, one record: where the trained model plans, which
pairs, with which planner and step budget.

A :class:`Condition` is an empty arena of ``size`` (None: the training arena's) with
``obstacles`` point obstacles placed from ``eval_seed``, or a MovingAI ``map`` (of the
training arena's side) with its ``scen`` problems or pairs drawn from ``eval_seed``;
``trials`` pairs, ``planner`` (:data:`~cml_edge.grid.planning.PLANNERS`), ``max_steps``
(None: :func:`~cml_edge.grid.maps.step_budget` of the arena). In three dimensions the
arena is a cube and a map a MovingAI voxel map (:mod:`cml_edge.grid.voxels`). The CML never sees it
while training. Every grid command that evaluates takes its conditions in this form:
``emulate`` (:meth:`cml_edge.grid.protocol.Protocol.condition`), the experiments
(:func:`cml_edge.experiments.common.eval_spec`), the scenarios' parts
(:func:`cml_edge.scenarios.registry.part`) and ``lava run``; its JSON is
:meth:`Condition.to_dict`, the fields in order, which results repeat.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any

from cml_edge.core.records import Record, integer
from cml_edge.errors import InputError
from cml_edge.grid.arena import GridArena
from cml_edge.grid.maps import load_map, load_scen, resolve_map, scenario_pairs, step_budget
from cml_edge.grid.metrics import Pairs, draw_pairs
from cml_edge.grid.planning import PLANNERS
from cml_edge.grid.seed_run import Evaluation
from cml_edge.grid.sensors import Sensors
from cml_edge.grid.voxels import load_voxel_map, load_voxel_scen, resolve_voxel_map, voxel_pairs
from cml_edge.protocol import EVAL_SEED


@dataclass(frozen=True)
class Condition(Record):
    """One evaluation condition (module docstring); checked when made."""

    what = "evaluation condition"

    name: str = "eval"
    size: int | None = None
    obstacles: int = 0
    map: str | None = None
    scen: str | None = None
    planner: str = "paper"
    max_steps: int | None = None
    trials: int = 100
    eval_seed: int = EVAL_SEED

    def __post_init__(self) -> None:
        def put(name: str, value: Any) -> None:
            object.__setattr__(self, name, value)

        if not isinstance(self.name, str):
            raise InputError(f"condition name {self.name!r} is not a text")
        if self.size is not None:
            put("size", integer("size", self.size, 2))
        for name, least in (("obstacles", 0), ("trials", 1), ("eval_seed", 0)):
            put(name, integer(name, getattr(self, name), least))
        if self.max_steps is not None:
            put("max_steps", integer("max_steps", self.max_steps, 1))
        if self.planner not in PLANNERS:
            raise InputError(f"unknown planner {self.planner!r}; allowed: "
                             f"{', '.join(PLANNERS)}")
        for name in ("map", "scen"):
            value = getattr(self, name)
            if value is not None and not (isinstance(value, str) and value):
                raise InputError(f"{name} {value!r} is not a file name")
        if self.scen is not None and self.map is None:
            raise InputError("a scen file needs a map")
        if self.map is not None and self.size is not None:
            raise InputError("give size or map, not both")
        if self.map is not None and self.obstacles:
            raise InputError("obstacles are placed on an empty arena, not on a map")

    @classmethod
    def within(cls, record: Mapping[str, Any]) -> Condition:
        """The condition a larger record holds (a scenario's part, a result's record):
        its fields, the rest left out."""
        return cls.from_dict({f.name: record[f.name] for f in fields(cls) if f.name in record})

    def map_arena(self, dims: int = 2, moves: str = "king") -> tuple[GridArena, Pairs | None]:
        """The map's arena with the ``moves`` set and its ``scen`` problems (None without a
        scen file): a MovingAI ``.map`` on the plane, a voxel map (``.3dmap``,
        :mod:`cml_edge.grid.voxels`) in space. Reads and checks the files, nothing more."""
        if dims == 3:
            vmap = load_voxel_map(resolve_voxel_map(self.map))
            arena = vmap.arena(moves)
            return arena, (voxel_pairs(vmap, load_voxel_scen(self.scen)[1],
                                       Path(self.scen).name, moves) if self.scen else None)
        grid = load_map(resolve_map(self.map))
        return grid.arena(moves), (scenario_pairs(grid, load_scen(self.scen),
                                                  Path(self.scen).name, moves)
                                   if self.scen else None)

    def evaluation(self, train_size: int, dims: int = 2, moves: str = "king",
                   sensors: Sensors | None = None) -> Evaluation:
        """The arena, pairs, step budget and planner, for models trained on the arena of
        side ``train_size`` in ``dims`` dimensions with the ``moves`` set (a map:
        :meth:`map_arena`, its problems or pairs drawn on it), read by the models' range
        ``sensors`` (:mod:`cml_edge.grid.sensors`; None: none)."""
        pairs = None
        if self.map:
            arena, pairs = self.map_arena(dims, moves)
        else:
            size = self.size or train_size
            arena = (GridArena.with_obstacles(size, self.obstacles, self.eval_seed, dims, moves)
                     if self.obstacles else GridArena.empty(size, dims, moves))
        if pairs is None:
            pairs = draw_pairs(arena, self.trials, self.eval_seed)
        if sensors is not None:
            arena = arena.sensing(sensors)
        return Evaluation(arena, pairs, self.max_steps or step_budget(arena.size), self.planner)
