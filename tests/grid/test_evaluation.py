"""The one train-and-evaluate driver and the one default-compute-path rule."""

from dataclasses import replace

import numpy as np
import pytest

from cml_edge.core.cml import CML, CMLConfig
from cml_edge.grid.metrics import draw_pairs, summarize
from cml_edge.grid.paths import default_path
from cml_edge.grid.planning import plan
from cml_edge.grid.protocol import Protocol, run_protocol
from cml_edge.grid.seed_run import Evaluation, Training, train_and_evaluate
from cml_edge.grid.training import TrainConfig, train


@pytest.mark.parametrize("backend,schedule,counted,expected", [
    ("float", "walk", False, "factored"),
    ("float", "step", False, "direct"),
    ("float32", "walk", False, "direct"),
    ("int8", "walk", False, "direct"),
    ("crossbar", "walk", False, "direct"),
    ("float", "walk", True, "direct"),
])
def test_default_path(backend, schedule, counted, expected):
    assert default_path(backend, schedule, counted=counted) == expected
    if not counted:
        assert default_path(CML.create(backend=backend), schedule) == expected


def test_driver_is_train_then_plan(small_arena, short_training):
    pairs = draw_pairs(small_arena, 12, 7)
    training = Training(small_arena, short_training, backend="int8", epoch=2)
    run = train_and_evaluate(5, training, [Evaluation(small_arena, pairs, 30, "escape")],
                             curve=Evaluation(small_arena, pairs), curve_at_start=True)
    cml = CML.create(CMLConfig.for_arena(small_arena.size), "int8", 5)
    curve = [summarize(*_plan(cml, small_arena, pairs), pairs)["e_pos_mean"]]

    def on_epoch(done):
        curve.append(summarize(*_plan(cml, small_arena, pairs), pairs)["e_pos_mean"])

    errors = train(cml, small_arena, short_training, 5, path="direct", epoch=2,
                   on_epoch=on_epoch)
    train_counters = cml.counters()
    final, steps = _plan(cml, small_arena, pairs, max_steps=30, planner="escape")
    assert run.path == "direct"
    assert np.array_equal(run.train_error, errors)
    assert [p["walks"] for p in run.curve] == [0, 2, 4]
    assert [p["e_pos_mean"] for p in run.curve] == curve
    assert np.array_equal(run.results[0].final, final)
    assert np.array_equal(run.results[0].steps, steps)
    assert run.summaries[0] == summarize(final, steps, pairs)
    assert run.train_counters == train_counters and run.counters == cml.counters()
    assert run.eval_counters["matvecs"] > 0
    assert {k: run.train_counters[k] + v for k, v in run.eval_counters.items()} == run.counters
    assert len(run.wall_s) == len(run.cpu_s) == 3  # the start and each epoch


def _plan(cml, arena, pairs, **kw):
    res = plan(cml, arena, pairs.starts, pairs.goals, path="direct", **kw)
    return res.final, res.steps


def test_run_protocol_names_its_compute_path():
    protocol = Protocol("float", [0], 5, 10, train=TrainConfig(2, 40))
    result = run_protocol(protocol)
    assert result["compute_path"] == result["path"] == "direct" and result["counters"]
    result = run_protocol(replace(protocol, path="factored"))
    assert result["compute_path"] == result["path"] == "factored"


def test_run_protocol_reports_progress_during_training_and_evaluation():
    calls = []
    run_protocol(Protocol("float", [0, 1], 5, 10, train=TrainConfig(25, 40), epoch=10),
                 progress=lambda done, total: calls.append((done, total)))
    # per seed: three training epochs (10, 20, 25 walks), then the evaluation
    assert calls == [(n, 8) for n in range(9)]
