"""Scenarios that start from the same training share it: one model and one twin per seed
evaluate every part, and each part's numbers are those of its own scenario's run."""

import pytest

from cml_edge.engine.sweep import run_task
from cml_edge.scenarios.breakpoint import Bisection, bisect
from cml_edge.scenarios.runner import (
    scenario_result,
    scenario_tasks,
    shared_result,
    shared_training,
)

SHARED = ("paper", "retention", "clutter", "recovery")


@pytest.mark.parametrize("backend, options", [("float32", {}), ("crossbar", {"preset": "pcm"})])
def test_a_shared_model_gives_each_scenario_its_own_numbers(backend, options):
    own = {name: scenario_tasks(name, backend, options, 1, "tiny")
           for name in (*SHARED, "in-situ")}
    merged, owner = shared_training([t for ts in own.values() for t in ts])
    assert len(merged) == 2  # the paper's training, and in-situ's (schedule step)
    ran = {t.key: run_task(t)[1]["result"] for t in merged}
    for name, tasks in own.items():
        alone = scenario_result(name, backend, options, 1, "tiny", 0.0, tasks,
                                {t.key: run_task(t)[1]["result"] for t in tasks})
        shared = scenario_result(name, backend, options, 1, "tiny", 0.0, tasks,
                                 {t.key: shared_result(t, ran[owner[t.key]]) for t in tasks})
        assert shared == alone, name


def test_parts_of_one_name_are_never_merged():
    (task,) = scenario_tasks("paper", "float32", {}, 1, "tiny")
    with pytest.raises(ValueError, match="share part names"):
        shared_training([task, type(task)("other", task.fn, task.params)])


def test_a_lockstep_bisection_takes_the_evaluations_of_one_at_a_time():
    grid = list(range(17))
    for threshold in range(0, 18):
        b = Bisection(grid)
        rounds = 0
        while b.pending:
            b.record([grid[k] < threshold for k in b.pending])
            rounds += 1
        assert rounds <= 5
        if 0 < threshold < 17:
            assert b.bracketed and (b.i, b.j, b.seen) == bisect(
                grid, lambda v, t=threshold: v < t)
        else:
            assert not b.bracketed and len(b.seen) == 2
    with pytest.raises(ValueError):
        Bisection(grid).record([True])
