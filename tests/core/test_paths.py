"""The three compute paths agree: reference == direct bit for bit, factored to rounding."""

import numpy as np
import pytest

from cml_edge.core.cml import CML
from cml_edge.grid.metrics import draw_pairs
from cml_edge.grid.planning import plan
from cml_edge.grid.training import TrainConfig, train


def _trained(config, arena, cml_config, seed, path, schedule, explore):
    cml = CML.create(cml_config, seed=seed)
    tc = TrainConfig(config.walks, config.steps, explore, schedule)
    errors = train(cml, arena, tc, seed=seed, path=path, epoch=2)
    return cml, errors


@pytest.mark.parametrize("explore", ["random", "mixed"])
@pytest.mark.parametrize("schedule", ["walk", "step"])
def test_reference_and_direct_training_are_bit_identical(
        small_arena, small_config, short_training, explore, schedule):
    ref, e_ref = _trained(short_training, small_arena, small_config, 3, "reference", schedule,
                          explore)
    fast, e_fast = _trained(short_training, small_arena, small_config, 3, "direct", schedule,
                            explore)
    for k, w in ref.weights().items():
        assert np.array_equal(w, fast.weights()[k]), k
    assert np.array_equal(e_ref, e_fast)
    assert ref.counters() == fast.counters()


@pytest.mark.parametrize("explore", ["random", "mixed"])
def test_factored_equals_direct_to_rounding(small_arena, small_config, short_training, explore):
    direct, e_d = _trained(short_training, small_arena, small_config, 4, "direct", "walk", explore)
    fact, e_f = _trained(short_training, small_arena, small_config, 4, "factored", "walk", explore)
    for k, w in direct.weights().items():
        np.testing.assert_allclose(fact.weights()[k], w, rtol=1e-12, atol=1e-14 * abs(w).max())
    np.testing.assert_allclose(e_f, e_d, rtol=1e-9)


def test_planning_paths_agree():
    from cml_edge.grid.arena import GridArena

    arena = GridArena.empty(30)
    cml = CML.create(seed=0)
    train(cml, arena, TrainConfig(), seed=0, path="factored")
    pairs = draw_pairs(arena, 40, seed=1)
    results = {p: plan(cml, arena, pairs.starts, pairs.goals, path=p)
               for p in ("reference", "direct", "factored")}
    ref = results["reference"]
    assert np.array_equal(ref.paths, results["direct"].paths)
    assert np.array_equal(ref.steps, results["direct"].steps)
    assert np.array_equal(ref.final, results["factored"].final)
    assert (ref.final == pairs.goals).all(1).mean() > 0.9


def test_same_seed_same_result_other_seed_other(small_arena, small_config, short_training):
    a, _ = _trained(short_training, small_arena, small_config, 7, "direct", "walk", "mixed")
    b, _ = _trained(short_training, small_arena, small_config, 7, "direct", "walk", "mixed")
    c = CML.create(small_config, seed=7)  # same initial weights, other exploration seed
    train(c, small_arena, TrainConfig(short_training.walks, short_training.steps, "mixed"),
          seed=8, path="direct")
    assert all(np.array_equal(w, b.weights()[k]) for k, w in a.weights().items())
    assert not np.array_equal(a.weights()["W_v"], c.weights()["W_v"])


def test_factored_path_refuses_device_and_step_schedule(small_arena, small_config):
    cml = CML.create(small_config, backend="float32")
    with pytest.raises(ValueError, match="factored"):
        train(cml, small_arena, TrainConfig(1, 10), seed=0, path="factored")
    cml = CML.create(small_config)
    with pytest.raises(ValueError, match="factored"):
        train(cml, small_arena, TrainConfig(1, 10, schedule="step"), seed=0, path="factored")


def test_utility_normalisation_matters_and_blocked_moves_are_never_taken():
    from cml_edge.core.cml import CMLConfig
    from cml_edge.grid.arena import GridArena

    arena = GridArena.empty(30)
    success = {}
    for utility in ("normalized", "raw"):
        cml = CML.create(CMLConfig(utility=utility), seed=0)
        train(cml, arena, TrainConfig(), seed=0, path="factored")
        pairs = draw_pairs(arena, 100, seed=123)
        res = plan(cml, arena, pairs.starts, pairs.goals, path="factored")
        success[utility] = (res.final == pairs.goals).all(1).mean()
    assert success["normalized"] >= 0.99 and success["raw"] < 0.9
    obstacles = GridArena.with_obstacles(30, 300, seed=5)
    pairs = draw_pairs(obstacles, 50, seed=6)
    res = plan(cml, obstacles, pairs.starts, pairs.goals, path="direct")
    visited = res.paths[res.paths[..., 0] >= 0]
    assert not obstacles.blocked[visited[:, 0], visited[:, 1]].any()
