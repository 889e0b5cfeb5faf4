"""The sweep engine: atomic per-task results, resume without recomputation, pool == Dask."""

import json
import os
import time
from pathlib import Path

import pytest

from cml_edge.engine.sweep import Task, Workers, load_done, run_sweep, task_path
from cml_edge.errors import InputError
from cml_edge.experiments.common import TASK_FN, eval_spec, make_tasks
from cml_edge.grid.metrics import pool_records

TINY = {"arena": 10, "walks": 3, "steps": 60,
        "evals": [eval_spec("e", trials=6, max_steps=30),
                  eval_spec("o", obstacles=20, trials=6, max_steps=30, planner="escape")]}


def tiny_tasks(seeds=3):
    return make_tasks([("tiny", TINY), ("mixed", {**TINY, "explore": "mixed"})], seeds)


def numbers(results):
    """Everything but the wall time."""
    return {k: {kk: vv for kk, vv in r.items() if kk != "wall_time_s"}
            for k, r in results.items()}


@pytest.fixture(scope="module")
def reference_results(tmp_path_factory):
    out = tmp_path_factory.mktemp("ref")
    return numbers(run_sweep(tiny_tasks(), out, workers=1)), out


def test_each_task_is_written_and_a_rerun_recomputes_nothing(reference_results, tmp_path):
    results, _ = reference_results
    tasks = tiny_tasks()
    seen = []
    first = run_sweep(tasks, tmp_path, workers=1, progress=lambda d, t: seen.append((d, t)))
    assert numbers(first) == results and seen[-1] == (6, 6)
    mtimes = {t.key: task_path(tmp_path, t.key).stat().st_mtime_ns for t in tasks}
    doc = json.loads(task_path(tmp_path, tasks[0].key).read_text())
    assert doc["params"]["seed"] == 0 and doc["result"]["evals"][0]["trials"] == 6
    # interrupted sweep: one task lost, one half-written; a rerun redoes exactly those two
    task_path(tmp_path, tasks[1].key).unlink()
    task_path(tmp_path, tasks[2].key).write_text('{"format": "cml-edge-sweep-ta')
    seen.clear()
    again = run_sweep(tasks, tmp_path, workers=1, progress=lambda d, t: seen.append((d, t)))
    assert numbers(again) == results
    assert seen[0] == (4, 6) and seen[-1] == (6, 6)
    for t in tasks:
        now = task_path(tmp_path, t.key).stat().st_mtime_ns
        assert (now == mtimes[t.key]) == (t.key not in (tasks[1].key, tasks[2].key)), t.key
    assert not [p for p in (tmp_path / "tasks").iterdir() if p.suffix != ".json"]


def test_changed_parameters_are_not_taken_as_done(tmp_path):
    task = Task("a", TASK_FN, {**TINY, "seed": 0})
    run_sweep([task], tmp_path, workers=1)
    assert load_done(tmp_path, task) is not None
    assert load_done(tmp_path, Task("a", TASK_FN, {**TINY, "seed": 1})) is None


def test_process_pool_gives_the_same_numbers(reference_results, tmp_path):
    results, _ = reference_results
    assert numbers(run_sweep(tiny_tasks(), tmp_path, workers=2)) == results


def test_dask_gives_the_same_numbers(reference_results, tmp_path):
    pytest.importorskip("distributed")
    from distributed import LocalCluster

    results, _ = reference_results
    with LocalCluster(n_workers=1, threads_per_worker=2, processes=False,
                      dashboard_address=None) as cluster:
        got = run_sweep(tiny_tasks(), tmp_path, scheduler=cluster.scheduler_address)
    assert numbers(got) == results


def test_pooled_metrics_are_over_all_trials(reference_results):
    results, _ = reference_results
    recs = [r["evals"][0] for k, r in results.items() if k.startswith("tiny-")]
    pooled = pool_records(recs)
    assert pooled["trials"] == 18
    assert pooled["success_rate"] == pytest.approx(sum(r["success_rate"] for r in recs) / 3)


def test_bad_sweeps(tmp_path):
    with pytest.raises(ValueError, match="not unique"):
        run_sweep([Task("a", TASK_FN), Task("a", TASK_FN)], tmp_path)
    with pytest.raises(ValueError, match="file-safe"):
        Task("../a", TASK_FN)
    with pytest.raises(ValueError, match="module:function"):
        Task("a", "nofunction")
    with pytest.raises(ValueError, match="seeds"):
        make_tasks([("x", {})], 0)


def test_unreachable_scheduler(tmp_path, monkeypatch):
    pytest.importorskip("distributed")
    monkeypatch.setattr("cml_edge.engine.sweep.CONNECT_TIMEOUT", "1s")
    with pytest.raises(ValueError, match="cannot reach the Dask scheduler"):
        run_sweep(tiny_tasks(1), tmp_path, scheduler="tcp://127.0.0.1:9")


def whoami(i: int) -> dict:
    return {"i": i, "pid": os.getpid()}


def meet(i: int, folder: str, workers: int) -> dict:
    """``whoami`` once ``workers`` processes have each taken a task of the sweep whose
    ``folder`` this is (so that every worker of the pool runs one; at most a minute)."""
    Path(folder, str(os.getpid())).touch()
    deadline = time.monotonic() + 60
    while len(os.listdir(folder)) < workers and time.monotonic() < deadline:
        time.sleep(0.01)
    return whoami(i)


def test_workers_kept_for_several_sweeps_are_the_same_processes(tmp_path):
    """Each sweep's tasks wait until both workers have taken one, so each sweep names
    every worker of the pool: the second sweep's are the first's."""
    def tasks(sweep, numbers):
        (tmp_path / sweep).mkdir()
        return [Task(f"t{i}", f"{__name__}:meet",
                     {"i": i, "folder": str(tmp_path / sweep), "workers": 2}) for i in numbers]

    with Workers(2) as pool:
        first = run_sweep(tasks("a", range(3)), tmp_path / "a-out", pool=pool,
                          group=lambda t: t.params["i"] % 2)
        second = run_sweep(tasks("b", range(3, 6)), tmp_path / "b-out", pool=pool)
    pids = {r["pid"] for r in first.values()}
    assert os.getpid() not in pids and len(pids) == 2
    assert {r["pid"] for r in second.values()} == pids
    assert [r["i"] for r in (*first.values(), *second.values())] == list(range(6))
    with pytest.raises(InputError):
        Workers(0)


def test_a_group_waits_for_its_first_task_level_by_level():
    """The first task of each group is queued; the rest of a group once it has ended, then
    each waits for the first task of its finer group (no two workers compile alike)."""
    from cml_edge.engine.sweep import _Gates

    paths = {"a": ("b1", "robot"), "b": ("b1", "robot"), "c": ("b1", "grid"),
             "c2": ("b1", "grid"), "d": ("b2", "grid"), "e": None, "f": "b2"}
    tasks = {k: Task(k, f"{__name__}:whoami", {"i": 0}) for k in paths}
    gates = _Gates(lambda t: paths[t.key])
    keys = lambda batch: [t.key for t in batch]  # noqa: E731
    assert keys(gates.ready(list(tasks.values()))) == ["a", "d", "e"]
    assert keys(gates.ended(tasks["e"])) == []
    assert keys(gates.ended(tasks["a"])) == ["b", "c"]  # b: its robot group is open
    assert keys(gates.ended(tasks["b"])) == []
    assert keys(gates.ended(tasks["c"])) == ["c2"]
    assert keys(gates.ended(tasks["d"])) == ["f"]
    assert keys(_Gates(None).ready(list(tasks.values()))) == list(paths)


def test_held_tasks_go_to_workers_that_would_idle():
    """``spare(n)``: up to n held tasks, oldest group first, each once; a task handed out
    so is not queued again when its group opens."""
    from cml_edge.engine.sweep import _Gates

    paths = {"a": "g1", "b": "g1", "c": "g1", "d": "g2", "e": "g2"}
    tasks = {k: Task(k, f"{__name__}:whoami", {"i": 0}) for k in paths}
    gates = _Gates(lambda t: paths[t.key])
    keys = lambda batch: [t.key for t in batch]  # noqa: E731
    assert keys(gates.ready(list(tasks.values()))) == ["a", "d"]
    assert keys(gates.spare(0)) == []
    assert keys(gates.spare(1)) == ["b"]
    assert keys(gates.spare(2)) == ["c", "e"]
    assert keys(gates.spare(2)) == []
    assert keys(gates.ended(tasks["a"])) == keys(gates.ended(tasks["d"])) == []
