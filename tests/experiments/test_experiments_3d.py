"""The experiments in space (``cml-edge sweep NAME --dims 3``): the task in the volume, the
plane's tasks unchanged, and the experiments of the plane refused."""

import json

import pytest

from cml_edge import experiments
from cml_edge.errors import InputError
from cml_edge.experiments import EXPERIMENTS
from cml_edge.experiments.common import eval_spec, space_tasks, train_eval


def test_the_task_in_space_and_on_the_plane():
    evals = [eval_spec("e", trials=5), eval_spec("o", obstacles=40, planner="escape",
                                                 trials=5)]
    plane = train_eval(0, evals, arena=8, walks=2, steps=50)
    space = train_eval(0, evals, arena=8, walks=2, steps=50, dims=3)
    assert "dims" not in plane and (space["dims"], space["moves"]) == (3, "king")
    for p, s in zip(plane["evals"], space["evals"]):
        assert len(p["final"][0]) == 2 and len(s["final"][0]) == 3
        assert p["eval_arena"] == s["eval_arena"] == 8
    assert plane["train_error"] != space["train_error"]


def test_which_experiments_run_in_space():
    for name in EXPERIMENTS:
        module = experiments.get(name)
        tasks = module.tasks(seeds=1) if name != "sensors" else []
        if name == "maps":
            with pytest.raises(InputError, match="runs on the plane only, not in 3-D"):
                space_tasks(module, tasks, 3)
            continue
        if 3 not in getattr(module, "DIMS", (2,)):
            continue
        assert space_tasks(module, tasks) == tasks  # the plane: as they were
        for t in space_tasks(module, tasks, 3, "face"):
            assert (t.params["dims"], t.params["moves"]) == (3, "face")


def test_the_cli(cli, tmp_path):
    code, out, err = cli("sweep", "maps", "--dims", 3, "--out", tmp_path / "m")
    assert code == 2 and out == "" and "plane only" in err
    code, out, err = cli("sweep", "exploration", "--dims", 3, "--map", "rooms",
                         "--out", tmp_path / "e")
    assert code == 2 and out == "" and "MovingAI plane maps" in err


@pytest.mark.slow
def test_a_sweep_in_space(cli, tmp_path):
    code, out, _ = cli("sweep", "obstacles", "--dims", 3, "--seeds", 1, "--planner", "paper",
                       "--workers", 1, "--out", tmp_path / "o", "--json")
    data = json.loads(out)
    assert code == 0 and data["options"]["dims"] == 3 and len(data["rows"]) == 5
    assert json.loads((tmp_path / "o" / "results.json").read_text())["options"]["dims"] == 3
    assert (tmp_path / "o" / "figure.png").read_bytes()[:4] == b"\x89PNG"


@pytest.mark.parametrize("space, arena", [({}, "30 x 30"),
                                          ({"dims": 3, "moves": "king"}, "30 x 30 x 30"),
                                          ({"dims": 3, "moves": "face"},
                                           "30 x 30 x 30, face moves")])
def test_a_figure_names_the_arena_its_results_ran_in(monkeypatch, tmp_path, space, arena):
    from cml_edge.experiments import backends

    titles = []
    monkeypatch.setattr(backends, "save_png",
                        lambda fig, path: titles.append(fig.axes[0].get_title()))
    rows = [{"config": "float", "eval": "arena30", "success_rate_connected": 1.0, "seeds": 2}]
    backends.plot(rows, {"float-s0": {"seed": 0, **space}}, tmp_path / "figure.png")
    assert titles == [f"Synaptic arrays, {arena}, 2 seeds x 100 pairs"]
