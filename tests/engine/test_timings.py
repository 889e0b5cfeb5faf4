"""The stage recorder: nested and repeated stages, compile time in the stage where a
function compiles, and a sweep's tasks' own stages added where they are collected. No
test asserts a duration, only the structure and its consistency."""

import time

from numba import njit

from cml_edge.engine import timings
from cml_edge.engine.sweep import Task, run_sweep
from cml_edge.engine.timings import recording, stage

EPS = 1e-3


def _by_name(recorded):
    return {s["name"]: s for s in recorded.to_dict()["stages"]}


def _consistent(d):
    """Every figure >= 0, compile within wall, the top-level stages within the total."""
    for s in d["stages"]:
        assert s["calls"] >= 1 and min(s["wall_s"], s["cpu_s"], s["compile_s"]) >= 0, s
        assert s["compile_s"] <= s["wall_s"] + EPS, s
    top = sum(s["wall_s"] for s in d["stages"] if "/" not in s["name"])
    assert top <= d["wall_s"] + EPS and d["compile_s"] <= d["wall_s"] + EPS


def test_nested_and_repeated_stages_accumulate():
    with recording() as recorded:
        with stage("a"):
            with stage("b"):
                time.sleep(0.01)
            with stage("a"):  # inside itself: the same stage
                pass
        with stage("a"):
            pass
        with stage("c"):
            sum(range(10_000))
    stages = _by_name(recorded)
    assert list(stages) == ["a", "a/b", "c"]
    assert stages["a"]["calls"] == 2 and stages["a/b"]["calls"] == 1
    assert stages["a"]["wall_s"] >= stages["a/b"]["wall_s"] >= 0.01
    d = recorded.to_dict()
    assert set(d) == {"stages", "wall_s", "cpu_s", "compile_s"}
    _consistent(d)


def test_without_a_recording_a_stage_records_nothing():
    with stage("x"):
        pass
    with recording() as outer, recording() as inner, stage("y"):
        pass
    assert list(_by_name(inner)) == ["y"] and _by_name(outer) == {}


def _fresh_kernel(k):
    @njit
    def add(x):  # a new closure: a function Numba has not compiled yet
        return x + k

    return add


def test_compile_time_goes_to_the_stage_where_the_function_compiles():
    kernel = _fresh_kernel(time.time_ns())
    with recording() as recorded:
        with stage("build"):
            kernel(1)
        with stage("run"):
            kernel(2)  # compiled: run time only
    stages = _by_name(recorded)
    assert stages["build"]["compile_s"] > 0 and stages["run"]["compile_s"] == 0
    assert recorded.to_dict()["compile_s"] >= stages["build"]["compile_s"]
    _consistent(recorded.to_dict())


def _task(name: str) -> dict:
    with stage(name):
        _fresh_kernel(time.time_ns())(1)
    return {"ok": True}


def test_a_sweeps_tasks_bring_their_stages_in_process_and_from_a_pool(tmp_path):
    tasks = [Task(f"t{i}", f"{__name__}:_task", {"name": "work"}) for i in range(2)]
    for workers in (1, 2):
        with recording() as recorded:
            run_sweep(tasks, tmp_path / str(workers), workers=workers)
        stages = _by_name(recorded)
        assert list(stages) == ["tasks", "tasks/work"], workers
        assert stages["tasks/work"]["calls"] == 2 and stages["tasks/work"]["compile_s"] > 0
        _consistent(recorded.to_dict())
    with recording() as recorded:  # done: nothing runs, nothing is timed
        run_sweep(tasks, tmp_path / "1", workers=1)
    assert _by_name(recorded) == {}


def test_merge_adds_under_the_open_stage():
    other = {"stages": [{"name": "x", "calls": 1, "wall_s": 1.0, "cpu_s": 0.5,
                         "compile_s": 0.25}]}
    with recording() as recorded, stage("tasks"):
        timings.merge(other)
        timings.merge(other)
    x = _by_name(recorded)["tasks/x"]
    assert (x["calls"], x["wall_s"], x["cpu_s"], x["compile_s"]) == (2, 2.0, 1.0, 0.5)
