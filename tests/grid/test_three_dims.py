"""The grid's loops in three dimensions: the same code as on the plane, on every path."""

import numpy as np
import pytest

from cml_edge.core.cml import CML, CMLConfig
from cml_edge.grid.arena import GridArena
from cml_edge.grid.fidelity import decision_agreement
from cml_edge.grid.metrics import draw_pairs, summarize
from cml_edge.grid.planning import plan
from cml_edge.grid.training import TrainConfig, train


def _config(arena: GridArena) -> CMLConfig:
    return CMLConfig.for_arena(arena.size, n_i=arena.dims, n_a=arena.n_actions)


def _trained(arena, path, explore="random", schedule="walk", seed=2, walks=4, steps=60):
    cml = CML.create(_config(arena), "float", seed)
    errors = train(cml, arena, TrainConfig(walks, steps, explore, schedule), seed, path=path,
                   epoch=2)
    return cml, errors


@pytest.mark.parametrize("moves", ["king", "face"])
@pytest.mark.parametrize("explore", ["random", "mixed"])
def test_the_three_paths_agree_in_space(moves, explore):
    arena = GridArena.empty(5, 3, moves)
    ref, e_ref = _trained(arena, "reference", explore)
    direct, e_direct = _trained(arena, "direct", explore)
    fact, e_fact = _trained(arena, "factored", explore)
    for k, w in ref.weights().items():
        assert np.array_equal(w, direct.weights()[k]), k
        np.testing.assert_allclose(fact.weights()[k], w, rtol=1e-12, atol=1e-14 * abs(w).max())
    assert np.array_equal(e_ref, e_direct)
    np.testing.assert_allclose(e_fact, e_direct, rtol=1e-9)
    assert ref.W_q.shape == (256, 3) and ref.W_k.shape == (arena.n_actions, 256)


@pytest.mark.parametrize("planner", ["paper", "escape"])
def test_plans_in_space_agree_on_every_path_and_reach_the_goals(planner):
    arena = GridArena.empty(8, 3)
    cml = CML.create(_config(arena), "float", 0)
    train(cml, arena, TrainConfig(100, 900), 0, path="factored")
    cluttered = GridArena.with_obstacles(8, 60, 5, dims=3)
    pairs = draw_pairs(cluttered, 20, 6)
    runs = {p: plan(cml, cluttered, pairs.starts, pairs.goals, path=p, planner=planner)
            for p in ("reference", "direct", "factored")}
    for field in ("final", "steps", "paths"):
        assert np.array_equal(getattr(runs["reference"], field), getattr(runs["direct"], field))
        assert np.array_equal(getattr(runs["direct"], field), getattr(runs["factored"], field))
    res = runs["direct"]
    assert res.paths.shape == (20, 101, 3)
    steps = np.abs(np.diff(res.paths[0, : res.steps[0] + 1], axis=0))
    assert steps.max() == 1 and (steps.sum(axis=1) >= 1).all()  # one king move at a time
    assert not cluttered.blocked[tuple(res.final.T)].any()
    assert summarize(res.final, res.steps, pairs)["success_rate"] == 1.0
    assert decision_agreement(cml, cluttered, pairs.goals, res, planner, 100) == (
        int(res.steps.sum()), int(res.steps.sum()))
