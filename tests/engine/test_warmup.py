"""The first run's warm-up (cml_edge.engine.warmup): a run's parts compiled on every core
into the kernel cache first, so that the run itself compiles nothing."""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from cml_edge.engine import warmup
from cml_edge.engine.warmup import Unit, pending, run_unit, warm

ROOT = Path(__file__).resolve().parents[2]


def fails() -> None:
    raise ValueError("a part that fails")


def succeeds(value: int) -> None:
    assert value == 3


@pytest.fixture
def cache(tmp_path, monkeypatch):
    monkeypatch.setattr(warmup.config, "CACHE_DIR", str(tmp_path))
    return tmp_path


def test_a_unit_that_ended_is_not_pending_again(cache):
    heavy = Unit("heavy", f"{__name__}:succeeds", {"value": 3}, weight=2.0)
    light = Unit("light", f"{__name__}:succeeds", {"value": 3, "x": 0}, weight=1.0)
    assert [u.what for u in pending([light, heavy, light])] == ["heavy", "light"]
    assert run_unit(Unit("bad", f"{__name__}:fails"))[1] is False
    key, ok, _ = run_unit(heavy)
    assert ok and key == heavy.key() and (cache / ".warm" / key).read_text() == "heavy\n"
    assert pending([light, heavy]) == [light]
    assert heavy.key() != light.key() != Unit("light", f"{__name__}:succeeds",
                                              {"value": 4, "x": 0}).key()


def test_one_worker_or_nothing_pending_starts_no_process(cache):
    unit = Unit("one", f"{__name__}:succeeds", {"value": 3})
    assert warm([unit], workers=1) == {"units": 1, "workers": 0, "ended": 0, "cpu_s": 0.0,
                                       "compile_s": 0.0}
    run_unit(unit)
    assert warm([unit], workers=2)["units"] == 0


def test_the_units_run_in_workers_and_a_failed_one_writes_no_marker(cache):
    units = [Unit("a", f"{__name__}:succeeds", {"value": 3}),
             Unit("b", f"{__name__}:fails", {}, weight=3.0)]
    seen = []
    out = warm(units, workers=2, progress=lambda done, total, what: seen.append((done, total)))
    assert (out["units"], out["workers"], out["ended"]) == (2, 2, 1)
    assert seen[0] == (0, 2) and seen[-1] == (2, 2)
    assert [u.what for u in pending(units)] == ["b"]


def _cli(cache: Path, *argv: str) -> subprocess.CompletedProcess:
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache), "PYTHONPATH": str(ROOT)}
    code = "import sys; from cml_edge.cli import main; sys.exit(main(sys.argv[1:]))"
    return subprocess.run([sys.executable, "-c", code, *argv], env=env, capture_output=True,
                          text=True, timeout=3000)


def _compiles(cache: Path, *argv: str) -> int:
    done = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "compile_time.py"),
                           "--cache", str(cache), "--json", "--", *argv],
                          env={**os.environ, "PYTHONPATH": str(ROOT)}, capture_output=True,
                          text=True, timeout=3000)
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout)["compiles"]


@pytest.mark.slow
def test_after_compile_the_commands_compile_nothing(tmp_path):
    cache = tmp_path / "numba"
    done = _cli(cache, "compile", "--backends", "int16", "--schedules", "walk", "step",
                "--workers", "2", "--json")
    assert done.returncode == 0, done.stderr
    out = json.loads(done.stdout)
    assert out["backends"] == ["int16"] and out["parts"] == out["compiled"] == 4
    assert out["ended"] == 4 and out["workers"] == 2
    for argv in (["emulate", "--backend", "int16", "--arena", "30", "--seeds", "2",
                  "--walks", "3", "--steps", "40", "--trials", "4", "--json"],
                 ["emulate", "--backend", "int16", "--schedule", "step", "--seeds", "1",
                  "--walks", "2", "--trials", "3", "--json"],
                 ["train", "--backend", "int16", "--walks", "2", "--out",
                  str(tmp_path / "m.npz")]):
        assert _compiles(cache, *argv) == 0, argv
    again = json.loads(_cli(cache, "compile", "--backends", "int16", "--json").stdout)
    assert again["compiled"] == 0 and again["workers"] == 0  # nothing left to compile


def test_bad_compile_options_are_one_line(tmp_path):
    for argv, says in ((["--workers", "0"], "outside the range of --workers"),
                       (["--backends", "nope"], "nope")):
        done = _cli(tmp_path / "numba", "compile", *argv)
        assert done.returncode == 2 and done.stderr.startswith("cml-edge: error: ")
        assert says in done.stderr and len(done.stderr.splitlines()) == 1


def test_tiny_shrinks_sizes_at_every_depth_and_keeps_what_chooses_kernels():
    params = {"seed": 7, "backend": "crossbar", "backend_options": {"preset": "pcm"},
              "run": {"arena": 60, "walks": 100, "steps": 900, "schedule": "step"},
              "parts": [{"name": "paper", "trials": 100, "relearn_walks": 0},
                        {"name": "K5", "trials": 1, "relearn_walks": 5, "age_s": 3600.0}],
              "protocol": {"seeds": [3, 4], "epoch": 10, "train": {"walks": 40, "steps": 9}}}
    assert warmup.tiny(params) == {
        "seed": 0, "backend": "crossbar", "backend_options": {"preset": "pcm"},
        "run": {"arena": 60, "walks": 1, "steps": 20, "schedule": "step"},
        "parts": [{"name": "paper", "trials": 2, "relearn_walks": 0},
                  {"name": "K5", "trials": 1, "relearn_walks": 1, "age_s": 3600.0}],
        "protocol": {"seeds": [0], "epoch": 1, "train": {"walks": 1, "steps": 9}}}
    assert warmup.tiny({"walks": True}) == {"walks": True}  # not a count: kept


def test_task_units_share_equal_tiny_tasks_and_let_devices_take_turns():
    from cml_edge.engine.sweep import Task

    fn = "cml_edge.scenarios.tasks:scenario_task"
    tasks = [Task(f"{b}-{k}-s{s}", fn, {"world": "grid", "backend": b, "backend_options": {},
                                        "seed": s, "run": {"walks": 9, "arena": k}})
             for b in ("float", "int8") for k in (30, 60) for s in (0, 1)]
    units = pending(warmup.task_units(tasks))
    assert [(u.what, u.kwargs["run"]["arena"]) for u in units] == [
        ("grid scenario_task on float", 30), ("grid scenario_task on int8", 30),
        ("grid scenario_task on float", 60), ("grid scenario_task on int8", 60)]
