"""benchmarks/dask_scaling.py: the chips on a LocalCluster of 1 and 2 worker processes give
the pool's results, its JSON and every chip's task file."""

import sys

import pytest

SCRIPT = "benchmarks/dask_scaling.py"
TINY = ["--walks", "2", "--steps", "50", "--trials", "5"]



def test_run_dependent_keys_are_left_out_at_any_depth(script):
    dask_scaling = script(SCRIPT)
    doc = {"wall_time_s": 1.0, "out": "x", "a": [{"timings": {}, "timings.walk": 2, "b": 3}]}
    assert dask_scaling.comparable(doc) == {"a": [{"b": 3}]}


@pytest.mark.slow
def test_dask_workers_give_the_pools_results(tmp_path, script):
    pytest.importorskip("distributed")
    rows = script(SCRIPT).measure(3, [1, 2], tmp_path, TINY)
    assert [(r["run"], r["workers"], r["chips"]) for r in rows] == [
        ("pool", 2, 3), ("dask", 1, 3), ("dask", 2, 3)]
    assert all(r["identical"] for r in rows), rows
    assert sorted(p.name for p in (tmp_path / "dask-2" / "tasks").iterdir()) == [
        "chip-000000.json", "chip-000001.json", "chip-000002.json"]


def test_options_after_the_separator_go_to_every_run(script, monkeypatch, capsys):
    dask_scaling = script(SCRIPT)
    seen = []
    monkeypatch.setattr(dask_scaling, "measure",
                        lambda chips, workers, folder, options: seen.append(
                            (chips, workers, options)) or [])
    monkeypatch.setattr(sys, "argv", [SCRIPT, "--chips", "7", "--workers", "2", "--json",
                                      "--", "--walks", "30", "--trials", "25"])
    dask_scaling.main()
    assert seen == [(7, [2], ["--walks", "30", "--trials", "25"])]
