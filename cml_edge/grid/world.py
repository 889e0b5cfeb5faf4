"""The grid as a world of the scenarios (:class:`cml_edge.core.world.World`).

A run (``run``: ``arena``, ``walks``, ``steps``, ``schedule``, and off the plane's king
moves ``dims`` and ``moves``) trains on the empty arena of side ``arena`` (a cube with
``dims`` 3; 2 and ``king`` when the run does not say) with random exploration
(:func:`cml_edge.grid.seed_run.train_seed`);
the float64 twin is :func:`cml_edge.grid.fidelity.float_twin`. A part is an evaluation
condition (:class:`cml_edge.grid.condition.Condition`: an arena, obstacles or a map,
pairs from the evaluation seed, a planner, a step budget); its record is the part's
settings, :func:`cml_edge.grid.metrics.summarize` (Eqs. 8, 9), the per-trial finals and
steps with the pairs, and :func:`cml_edge.grid.fidelity.seed_fidelity`. In-situ
relearning continues the seed's walks with every update applied at its step
(:data:`RELEARN_SCHEDULE`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any, NamedTuple

from cml_edge.core.cml import CML, CMLConfig
from cml_edge.core.world import PATH, Trained
from cml_edge.grid.arena import GridArena
from cml_edge.grid.condition import Condition
from cml_edge.grid.fidelity import float_twin, seed_fidelity
from cml_edge.grid.metrics import pool_records, summarize
from cml_edge.grid.planning import PlanResult
from cml_edge.grid.seed_run import Evaluation, Training, cml_config_for, train_seed
from cml_edge.grid.training import TrainConfig, train

RELEARN_SCHEDULE = "step"
"""In-situ relearning applies every update on the device at the step it is computed."""
POOLED_KEYS = ("success_rate", "success_rate_connected", "overhead_mean", "overhead_median",
               "overhead_geodesic_mean", "e_pos_mean", "e_pos_median", "connected_pairs",
               "trials")
"""The keys of :func:`~cml_edge.grid.metrics.summarize` a part pools over seeds."""


class GridPlan(NamedTuple):
    """What :meth:`GridWorld.plan` planned: the evaluation and its result."""

    evaluation: Evaluation
    result: PlanResult


def space(run: Mapping[str, Any]) -> tuple[int, str]:
    """(dims, moves) of ``run``: the plane's king moves when it does not say."""
    return int(run.get("dims", 2)), str(run.get("moves", "king"))


def _training(run: Mapping[str, Any]) -> tuple[GridArena, TrainConfig, CMLConfig]:
    """The empty training arena, the training config and the CML config of ``run``."""
    arena = GridArena.empty(run["arena"], *space(run))
    return (arena, TrainConfig(run["walks"], run["steps"], "random", run["schedule"]),
            cml_config_for(arena))


class GridWorld:
    """The grid world (module docstring)."""

    name = "grid"

    def train(self, seed: int, run: Mapping[str, Any], backend: str,
              backend_options: Mapping[str, Any], chip: int | None) -> Trained:
        arena, config, cml_config = _training(run)
        done = train_seed(seed, Training(arena, config, cml_config, backend,
                                         backend_options, PATH, chip=chip))
        return Trained(done.cml, done.train_error)

    def twin(self, seed: int, run: Mapping[str, Any]) -> CML:
        return float_twin(seed, *_training(run))

    def relearn(self, cml: CML, twin: CML, seed: int, run: Mapping[str, Any], walks: int,
                done: int) -> None:
        arena, _, cml_config = _training(run)
        more = TrainConfig(walks, run["steps"], "random", RELEARN_SCHEDULE)
        first = run["walks"] + done
        train(cml, arena, more, seed, path=PATH, epoch=walks, first_walk=first)
        float_twin(seed, arena, more, cml_config, first_walk=first, twin=twin)

    def plan(self, cml: CML, part: Mapping[str, Any], run: Mapping[str, Any]) -> GridPlan:
        evaluation = Condition.within(part).evaluation(run["arena"], *space(run))
        return GridPlan(evaluation, evaluation.plan(cml, PATH))

    def summarise(self, seed: int, cml: CML, twin: CML, part: Mapping[str, Any],
                  planned: GridPlan) -> dict[str, Any]:
        ev, res = planned
        pairs = ev.pairs
        return {**part, "max_steps": ev.max_steps, "eval_arena": ev.arena.size,
                **summarize(res.final, res.steps, pairs),
                "final": res.final.tolist(), "steps": res.steps.tolist(),
                "starts": pairs.starts.tolist(), "goals": pairs.goals.tolist(),
                "chebyshev": pairs.chebyshev.tolist(), "geodesic": pairs.geodesic.tolist(),
                **seed_fidelity(seed, cml, twin, ev.arena, pairs.goals, res, ev.planner,
                                ev.max_steps)}

    def pool(self, records: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
        pooled = pool_records(records)
        return {k: pooled[k] for k in POOLED_KEYS}


GRID = GridWorld()
