"""The grid CML against its float64 twin: weight error, decision agreement, read SNR.

The metrics are defined in :mod:`cml_edge.core.fidelity`. What is the grid's:

- the twin (:func:`float_twin`): ``CML.create(config, "float", seed)`` trained on the
  training arena with the same :class:`~cml_edge.grid.training.TrainConfig` and seed, on
  the factored path for the per-walk schedule (exact, fast) and the direct float64 path
  for the per-step schedule (the factored form needs the per-walk schedule);
- decision agreement (:func:`decision_agreement`): after the device has planned, each
  state it decided in (its cell, with its goal) is replayed with the twin's scores (the
  factored scorer) and the same available moves, through the planner the device used,
  and counted where the twin's move equals the device's. For the paper's planner that
  is the twin's WTA winner. For the escape planner it is the twin's full chooser (WTA
  plus the escape), whose memory (cells visited, their LRTA* values, its mode) is fed
  the device's own path, one decision after another: where the two disagree, the
  twin's memory follows the device's moves, not its own. The compiled planning loop is
  not touched: the replay is a loop of its own over the device's recorded paths;
- read SNR (:func:`plan_states`): the sampled states are decisions of the device's plan
  (cell and goal), ``SNR_SAMPLES`` of them from the generator keyed [seed,
  ``STREAM_FIDELITY``]; None (not applicable) for a device that reads as its twin does,
  to float64 rounding (the float64 array against its own twin: ``READ_ROUNDING``).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numba import njit

from cml_edge.core.cml import CML, CMLConfig
from cml_edge.core.fidelity import read_snr, sample_indices, weight_error
from cml_edge.core.step import FactoredScorer, prepare, scores
from cml_edge.engine.timings import stage
from cml_edge.grid.arena import GridArena, cell_at, unpack_moves
from cml_edge.grid.escape import Escape
from cml_edge.grid.paths import factored_supported
from cml_edge.grid.planning import (
    WTA,
    PlanResult,
    choose,
    decision_buffers,
    decision_inputs,
    reset,
)
from cml_edge.grid.training import TrainConfig, train
from cml_edge.protocol import STREAM_FIDELITY


def float_twin(seed: int, arena: GridArena, config: TrainConfig, cml_config: CMLConfig,
               first_walk: int = 0, twin: CML | None = None) -> CML:
    """The float64 twin of the model of ``seed`` (module docstring), trained on ``arena``;
    with ``twin``, that CML trained further, on walks ``first_walk`` onward."""
    with stage("twin"):
        if twin is None:
            twin = CML.create(cml_config, "float", seed)
        path = "factored" if factored_supported(twin, config.schedule, arena) else "direct"
        train(twin, arena, config, seed, path=path, epoch=config.walks, first_walk=first_walk)
    return twin


@njit(cache=True)
def replay_loop(scorer, chooser, cells, origin, scale, normalize, gram, goals, paths, steps,
                agree, work):
    """For each trial, the number of the device's decisions (``paths``, ``steps``) that
    ``scorer`` and ``chooser`` make alike (module docstring), in ``agree``; ``work``: the
    decision's work arrays (:func:`~cml_edge.grid.planning.decision_buffers`)."""
    prepare(scorer, normalize, gram)  # W_v's columns, read once per batch
    norms, K = scorer.norms, scorer.gram
    o, dgo, u, score, mask, p, g = work
    table = cells.table
    dims = p.shape[0]
    for trial in range(goals.shape[0]):
        reset(chooser)
        for k in range(dims):
            g[k] = goals[trial, k]
        same = 0
        for t in range(steps[trial]):
            for k in range(dims):
                p[k] = paths[trial, t, k]
            c = cell_at(p, cells.n)
            decision_inputs(cells, c, p, g, origin, scale, o, dgo)
            scores(scorer, o, dgo, u, score)
            if unpack_moves(cells.masks[c], mask) == 0:
                break
            a = choose(chooser, cells, c, p, u, score, norms, K, mask)
            if a >= 0:
                alike = True
                for k in range(dims):
                    alike = alike and p[k] + table[a, k] == paths[trial, t + 1, k]
                if alike:
                    same += 1
        agree[trial] = same


def decision_agreement(twin: CML, arena: GridArena, goals: np.ndarray, result: PlanResult,
                       planner: str, max_steps: int) -> tuple[int, int]:
    """(decisions the twin makes alike, decisions) over the device's plan ``result``."""
    n = len(goals)
    agree = np.zeros(n, np.int64)
    chooser = Escape.of(arena, max_steps) if planner == "escape" else WTA()
    c = twin.config
    replay_loop(FactoredScorer.of(twin), chooser, arena.cells(), c.obs_origin, c.obs_scale,
                c.utility == "normalized", planner == "escape",
                np.ascontiguousarray(goals, dtype=np.int64), result.paths,
                np.ascontiguousarray(result.steps, dtype=np.int64), agree,
                decision_buffers(arena))
    return int(agree.sum()), int(result.steps.sum())


def plan_states(cml: CML, arena: GridArena, goals: np.ndarray, result: PlanResult, seed: int
                ) -> list[tuple[np.ndarray, np.ndarray]]:
    """(o, o* - o) of a seeded sample of the states the device decided in on ``arena``
    (as :func:`~cml_edge.grid.planning.decision_inputs` forms them)."""
    states = [(trial, t) for trial in range(len(goals)) for t in range(int(result.steps[trial]))]
    c = cml.config
    cells = arena.cells()
    readings = cells.readings.reshape(arena.blocked.shape + (-1,))
    out = []
    for i in sample_indices(len(states), seed, STREAM_FIDELITY):
        trial, t = states[i]
        p = result.paths[trial, t]
        o = (p.astype(float) - c.obs_origin) / c.obs_scale
        goal = (np.asarray(goals[trial], float) - c.obs_origin) / c.obs_scale
        sensed = readings[tuple(p)]
        out.append((np.concatenate([o, sensed]),
                    np.concatenate([goal - o, -sensed * cells.open_goal])))
    return out


def seed_fidelity(seed: int, cml: CML, twin: CML, arena: GridArena, goals: np.ndarray,
                  result: PlanResult, planner: str, max_steps: int) -> dict[str, Any]:
    """One seed's weight error, decision agreement and read SNR (and the decision counts)."""
    with stage("replay"):
        same, total = decision_agreement(twin, arena, goals, result, planner, max_steps)
        return {"weight_error": weight_error(cml, twin),
                "decision_agreement": same / total if total else None,
                "decisions": total, "decisions_agreed": same,
                "read_snr": read_snr(cml, plan_states(cml, arena, goals, result, seed))}
