"""The bench's yardstick (cml_edge.bench.fused) does the direct path's arithmetic, bit for
bit, and the bench's names and presets."""

import numpy as np
import pytest

from cml_edge.bench.timing import (
    LEARNERS,
    SCORERS,
    bench_names,
    label,
    parse_name,
    ratios,
    time_plan,
    time_train,
)
from cml_edge.core.cml import CML, CMLConfig
from cml_edge.errors import InputError
from cml_edge.grid.arena import GridArena
from cml_edge.grid.exploration import GridExplorer
from cml_edge.grid.metrics import draw_pairs
from cml_edge.grid.planning import WTA, PlanResult, plan, plan_loop
from cml_edge.grid.training import TrainConfig, train, train_loop


def _trained(arena, learner, config, seed=3):
    cml = CML.create(CMLConfig.for_arena(arena.size), "float", seed)
    plug = LEARNERS[learner](cml, arena)
    errors = np.zeros(config.walks)
    c = cml.config
    train_loop(plug, GridExplorer.of(arena, config, seed), c.obs_origin, c.obs_scale, 0,
               config.walks, config.steps, errors)
    return cml, errors


@pytest.mark.parametrize("explore", ["random", "mixed"])
def test_fused_learner_is_bit_identical_to_the_direct_path(explore):
    arena = GridArena.empty(12)
    config = TrainConfig(6, 150, explore)
    cml, errors = _trained(arena, "fused", config)
    ref = CML.create(CMLConfig.for_arena(arena.size), "float", 3)
    ref_errors = train(ref, arena, config, 3, path="direct")
    for a, b in zip(cml.arrays, ref.arrays):
        assert np.array_equal(a.state.W, b.state.W)
    assert np.array_equal(errors, ref_errors)
    assert not np.array_equal(cml.W_q.state.W, CML.create(
        CMLConfig.for_arena(arena.size), "float", 3).W_q.state.W)  # it did learn


def test_fused_factored_learner_is_bit_identical_to_the_factored_learner():
    arena = GridArena.empty(12)
    config = TrainConfig(6, 150)
    fused, e1 = _trained(arena, "fused_factored", config)
    factored, e2 = _trained(arena, "factored", config)
    for a, b in zip(fused.arrays, factored.arrays):
        assert np.array_equal(a.state.W, b.state.W)
    assert np.array_equal(e1, e2)


@pytest.mark.parametrize("utility", ["normalized", "raw"])
def test_fused_scorer_plans_as_the_direct_path(utility):
    arena = GridArena.empty(12)
    cml = CML.create(CMLConfig.for_arena(arena.size, utility=utility), "float", 1)
    train(cml, arena, TrainConfig(10, 200), 1)
    pairs = draw_pairs(arena, 20, 5)
    ref = plan(cml, arena, pairs.starts, pairs.goals)
    n = len(pairs.starts)
    res = PlanResult.empty(n, 100, arena)
    c = cml.config
    plan_loop(SCORERS["fused"](cml), WTA(), arena.cells(), c.obs_origin, c.obs_scale,
              utility == "normalized", False, np.ascontiguousarray(pairs.starts, np.int64),
              np.ascontiguousarray(pairs.goals, np.int64), 0, n, 100, res)
    for field in ("final", "steps", "paths"):
        assert np.array_equal(getattr(res, field), getattr(ref, field))
    assert ref.steps.sum() > 0


def test_timings_are_positive_per_step():
    arena = GridArena.empty(8)
    assert time_train(arena, TrainConfig(1, 20), 0, "float", {}, "fused") > 0
    cml = CML.create(CMLConfig.for_arena(8), "float", 0)
    pairs = draw_pairs(arena, 3, 0)
    assert time_plan(cml, arena, np.ascontiguousarray(pairs.starts, np.int64),
                     np.ascontiguousarray(pairs.goals, np.int64), "direct") > 0


def test_names_with_presets():
    assert parse_name("crossbar:reram") == ("crossbar", {"preset": "reram"})
    assert parse_name("int8") == ("int8", {})
    for bad in ("crossbar:nope", "int8:pcm", "nope"):
        with pytest.raises(InputError):
            parse_name(bad)
    names = bench_names(["float", "crossbar", "crossbar:pcm"], presets=True)
    assert names[0] == "float" and names[-1] == "crossbar:pcm"
    assert {"crossbar:ideal", "crossbar:pcm", "crossbar:reram", "crossbar:pcm-symmetric",
            "crossbar:reram-symmetric"} <= set(names[1:-1])
    assert bench_names(["float", "crossbar", "int8"]) == ["float", "crossbar", "int8"]
    with pytest.raises(InputError, match="unknown preset 'pcm' for 'int8'"):
        bench_names(["int8:pcm"])


def test_settings_change_the_named_backends_only_when_valid():
    assert parse_name("crossbar:pcm", ["out_noise=0"]) == (
        "crossbar", {"preset": "pcm", "out_noise": 0.0})
    assert parse_name("int8", ["rounding=floor"])[1] == {"rounding": "floor"}
    for name, setting in (("float", "out_noise=0"), ("int8", "bits=6"),
                          ("crossbar", "out_noise=-1"), ("crossbar", "out_noise")):
        with pytest.raises(InputError):
            parse_name(name, [setting])
    assert label("crossbar:pcm", [" out_noise=0", "adc_bits=0"]) == \
        "crossbar:pcm (out_noise=0, adc_bits=0)"
    assert label("crossbar:pcm") == "crossbar:pcm"


def test_bench_refuses_a_setting_before_timing(capsys):
    from cml_edge.cli import main

    assert main(["bench", "--backends", "float", "--set", "out_noise=0"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "out_noise" in err


def test_ratios_divide_figures_of_one_run():
    f = {"train_step_us_random": 2.0, "plan_step_us": 4.0, "train_step_us_factored": 0.2}
    y = {"train_step_us_fused": 1.0, "plan_step_us_fused": 2.0,
         "train_step_us_fused_factored": 0.1}
    r = ratios(f, y, {"int8": {"train_step_us_random": 6.0, "plan_step_us": 4.0}})
    assert r["float64 direct / fused"] == {"train": 2.0, "plan": 2.0, "goal": 1.3}
    assert r["factored / fused factored"] == {"train": 2.0, "goal": 1.1}
    assert r["int8 / float64 direct"] == {"train": 3.0, "plan": 1.0, "goal": 2.0}


def test_the_step_per_synapse_in_space():
    from cml_edge.bench.timing import GOALS, per_synapse, synapse_counts

    assert synapse_counts(3, "king") == (4608, 14080)
    assert synapse_counts(3, "face") == (4608, (3 + 12) * 256)
    r = per_synapse({"train_step_us_random": 2.0}, {"train_step_us_random": 9.0},
                    (4608, 14080))
    assert r["train_step_ns_per_synapse_2d"] == pytest.approx(2000 / 4608)
    assert r["train_step_ns_per_synapse_3d"] == pytest.approx(9000 / 14080)
    assert r["ratio"] == pytest.approx((9000 / 14080) / (2000 / 4608))
    assert r["goal"] == GOALS["space"] == 2.0


def test_a_training_step_in_space_is_timed():
    arena = GridArena.empty(10, 3)
    assert time_train(arena, TrainConfig(1, 50), 0, "int8", {}, "direct") > 0
