"""The DQN baseline: counts, pairs, convergence, lazy imports (always); the SB3 network,
hyperparameters, batched evaluation, train/resume/evaluate (with the ``dqn`` extra, on a
budget of a few hundred steps)."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from cml_edge.baselines import load_results, mlp_inference_flops, mlp_parameter_count
from cml_edge.baselines.dqn import (
    DEFAULT_STEPS,
    GOAL_CONDITIONED_LAYERS,
    HYPERPARAMS,
    PAPER_LAYERS,
    DQNRun,
    convergence_index,
    curve_convergence,
    fixed_goal,
    fixed_goal_pairs,
    read_results,
    run_pairs,
    updating_results,
)
from cml_edge.cli import main as cli_main
from cml_edge.cli.dqn import add_parsers as add_dqn_parser
from cml_edge.grid.arena import GridArena
from cml_edge.grid.metrics import draw_pairs

HEAVY = ("torch", "stable_baselines3", "gymnasium")


# without the extra -------------------------------------------------------------------
def test_paper_counts():
    assert mlp_parameter_count(PAPER_LAYERS) == 4872  # the paper prints 4,874
    assert mlp_inference_flops(PAPER_LAYERS) == 9472
    assert mlp_parameter_count(GOAL_CONDITIONED_LAYERS) == 5000
    assert mlp_inference_flops(GOAL_CONDITIONED_LAYERS) == 9728


@pytest.mark.slow
def test_core_and_cli_never_import_the_extra():
    code = ("import sys, cml_edge, cml_edge.cli, cml_edge.baselines, cml_edge.baselines.dqn; "
            f"print([m for m in {HEAVY!r} if m in sys.modules])")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout
    assert out.strip() == "[]"


def test_evaluate_without_a_trained_dqn_exits_2(cli, tmp_path):
    code, out, err = cli("dqn", "evaluate", "--results", tmp_path / "none.json", "--no-cml")
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and "no trained DQN" in err


def test_fixed_goal_pairs():
    arena = GridArena.empty(30)
    protocol = draw_pairs(arena, 10, 123)
    for seed in range(10):
        goal = fixed_goal(arena, seed)
        assert goal.tolist() == protocol.goals[seed].tolist()
        pairs = fixed_goal_pairs(arena, 100, seed)
        assert (pairs.goals == goal).all()
        assert not (pairs.starts == goal).all(axis=1).any()
        assert (pairs.chebyshev == np.abs(pairs.starts - goal).max(axis=1)).all()
        again = fixed_goal_pairs(arena, 100, seed)
        assert (again.starts == pairs.starts).all()
    assert len({tuple(fixed_goal(arena, s)) for s in range(10)}) > 1
    goal, pairs = run_pairs(DQNRun(goal_conditioned=True), arena, 3)
    standard = draw_pairs(arena, 100, 123)
    assert goal is None
    assert (pairs.starts == standard.starts).all() and (pairs.goals == standard.goals).all()


def test_convergence_index():
    assert convergence_index([9.0, 5.0, 0.4, 1.0, 0.2, 0.0]) == 4
    assert convergence_index([0.0, 0.0]) == 0
    assert convergence_index([3.0, 3.2, 2.9]) == 0
    conv = curve_convergence([0, 10, 20], [[4, 1, 0], [6, 0, 0]], [[0, 1, 2], [0, 3, 4]],
                             [[0, 1, 1], [0, 1, 1]])
    assert conv["step"] == 10 and conv["wall_s"] == 2.0 and conv["e_pos_mean_final"] == 0.0


def test_run_validation_and_keys():
    with pytest.raises(ValueError, match="reward"):
        DQNRun(reward="sparse")
    with pytest.raises(ValueError, match="steps"):
        DQNRun(steps=0)
    assert DQNRun().key != DQNRun(steps=300).key
    assert DQNRun(goal_conditioned=True).name == "goal_conditioned_simplified"
    assert DEFAULT_STEPS == {"simplified": 100_000, "tailored": 200_000}


def test_parser_and_one_line_errors(tmp_path, capsys):
    import argparse

    parser = argparse.ArgumentParser()
    add_dqn_parser(parser.add_subparsers(dest="command"))
    args = parser.parse_args(["dqn", "train", "--reward", "tailored", "--goal-conditioned",
                              "--models", "m"])
    assert args.dqn_command == "train" and args.goal_conditioned and args.steps is None
    code = cli_main(["dqn", "evaluate", "--results", str(tmp_path / "none.json"), "--no-cml"])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "no trained DQN" in err
    assert not (tmp_path / "none.json").exists()


# with the extra ----------------------------------------------------------------------
@pytest.fixture(scope="module")
def sb3():
    for name in HEAVY:
        pytest.importorskip(name)
    from cml_edge.baselines import dqn_sb3

    return dqn_sb3


@pytest.mark.slow
def test_the_torch_side_does_not_import_the_driver(sb3):
    code = ("import sys, cml_edge.baselines.dqn_sb3; "
            "print('cml_edge.baselines.dqn' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout
    assert out.strip() == "False"


def test_network_and_hyperparameters(sb3):
    import torch

    from cml_edge.grid.env import GridNavEnv

    assert torch.get_num_threads() == 1
    model = sb3.make_model(GridNavEnv(), seed=0)
    assert sb3.q_network_layers(model) == [2, 64, 64, 8]
    assert sb3.q_network_parameters(model) == 4872
    relus = [m for m in model.q_net.q_net if isinstance(m, torch.nn.ReLU)]
    assert len(relus) == 2
    for k, v in HYPERPARAMS.items():
        got = getattr(model, k)
        if k == "train_freq":
            got = got.frequency
        assert got == v, k
    gc = sb3.make_model(GridNavEnv(goal_conditioned=True), seed=0)
    assert sb3.q_network_layers(gc) == [4, 64, 64, 8]
    assert sb3.q_network_parameters(gc) == 5000


def test_batched_rollout_matches_env_steps(sb3):
    from cml_edge.grid.env import GridNavEnv

    arena = GridArena.empty(30)
    for goal_conditioned in (False, True):
        run = DQNRun(goal_conditioned=goal_conditioned, trials=8)
        goal, pairs = run_pairs(run, arena, 2)
        env = sb3.make_env(run, goal)
        model = sb3.make_model(env, seed=1)
        model.learn(300)  # an arbitrary (untrained) policy is as good a test
        final, steps = sb3.rollout(model, arena, pairs, goal_conditioned)
        env = GridNavEnv(goal=None if goal is None else tuple(goal),
                         goal_conditioned=goal_conditioned)
        for i in range(len(pairs.starts)):
            opts = {"start": tuple(pairs.starts[i])}
            if goal_conditioned:
                opts["goal"] = tuple(pairs.goals[i])
            obs, _ = env.reset(options=opts)
            n, done = 0, False
            while not done:
                action, _ = model.predict(obs, deterministic=True)
                obs, _, term, trunc, info = env.step(int(action))
                n += 1
                done = term or trunc
            assert list(info["position"]) == final[i].tolist() and n == steps[i]


@pytest.mark.slow
def test_train_resume_evaluate(sb3, tmp_path):
    results = tmp_path / "hw" / "dqn_results.json"
    models = tmp_path / "models"
    common = ["--steps", "300", "--eval-every", "100", "--trials", "6",
              "--results", str(results), "--json"]
    assert cli_main(["dqn", "train", "--seeds", "1", "--models", str(models), *common]) == 0
    data = load_results(results)
    (entry,) = data["runs"].values()
    rec = entry["seeds"]["0"]
    assert rec["steps"] == 300 and rec["parameters"] == 4872
    assert [p["step"] for p in rec["curve"]] == [0, 100, 200, 300]
    assert rec["train_wall_s"] > 0 and len(rec["final"]) == 6
    prov = entry["provenance"][0]
    for key in ("date", "command", "torch", "stable_baselines3", "gymnasium", "numpy"):
        assert prov[key]
    assert data["network"]["parameters"] == 4872 and data["hyperparameters"] == HYPERPARAMS
    assert (results.parent / "dqn_curves.png").stat().st_size > 0
    # resume: seed 0 is skipped, seed 1 trained
    assert cli_main(["dqn", "train", "--seeds", "2", "--models", str(models), *common]) == 0
    data = load_results(results)
    (entry,) = data["runs"].values()
    assert sorted(entry["seeds"]) == ["0", "1"]
    assert entry["seeds"]["0"] == rec
    # evaluate from the saved models reproduces the evaluation recorded at training
    assert cli_main(["dqn", "evaluate", "--seeds", "2", "--no-cml", *common]) == 0
    ev = load_results(results)["evaluations"][DQNRun(steps=300, trials=6,
                                                     eval_every=100).key]
    assert ev["evaluated_from"] == ["model"] and ev["seeds"] == 2
    finals = np.concatenate([entry["seeds"][s]["final"] for s in ("0", "1")])
    from cml_edge.grid.metrics import e_pos

    goals = np.concatenate([fixed_goal_pairs(GridArena.empty(30), 6, s).goals for s in (0, 1)])
    assert ev["e_pos_mean"] == pytest.approx(e_pos(finals, goals).mean())
    assert set(ev["convergence"]) >= {"step", "wall_s", "cpu_s", "tolerance_cells"}
    json.dumps(ev, allow_nan=False)


def test_cml_on_same_pairs(sb3):
    from cml_edge.baselines.dqn import cml_on_pairs

    arena = GridArena.empty(10)
    out = cml_on_pairs([0, 1], lambda s: fixed_goal_pairs(arena, 5, s), arena, "factored",
                       walks=3, steps=50)
    assert out["seeds"] == 2 and out["trials"] == 10
    assert out["curve_steps"] == [0, 50, 100, 150] and len(out["curve_e_pos_mean"]) == 4
    assert out["convergence"]["cpu_s"] >= 0
    direct = cml_on_pairs([0, 1], lambda s: fixed_goal_pairs(arena, 5, s), arena, "direct",
                          walks=3, steps=50, curves_from=out)
    assert direct["curve_e_pos_mean"] == out["curve_e_pos_mean"]
    assert direct["e_pos_mean"] == pytest.approx(out["e_pos_mean"])
    assert direct["curve_planned_with"] == "factored"


def _add_keys(path, name):
    for i in range(15):
        with updating_results(path) as data:
            data["runs"][f"{name}{i}"] = {"seeds": {}}


def test_concurrent_trainers_keep_each_others_results(tmp_path):
    import multiprocessing as mp

    path = tmp_path / "results.json"
    ctx = mp.get_context("fork")
    procs = [ctx.Process(target=_add_keys, args=(path, name)) for name in "ab"]
    for p in procs:
        p.start()
    for p in procs:
        p.join()
    assert all(p.exitcode == 0 for p in procs)
    assert sorted(read_results(path)["runs"]) == sorted(f"{n}{i}" for n in "ab" for i in range(15))


@pytest.mark.parametrize("text,needle", [
    ("{not json", "not a readable DQN results file"),
    ("[1, 2]", "not a cml-edge DQN results file"),
    ('{"format": "cml-edge-dqn-results", "format_version": 1, "runs": {"a": 1}}',
     "corrupted DQN results file"),
])
def test_bad_results_files_exit_2(tmp_path, capsys, text, needle):
    results = tmp_path / "results.json"
    results.write_text(text)
    for argv in (["dqn", "evaluate", "--results", str(results), "--no-cml"],
                 ["dqn", "train", "--results", str(results), "--steps", "10", "--models",
                  str(tmp_path / "m")],
                 ["report", "--quick", "--dqn-results", str(results), "--out",
                  str(tmp_path / "r")]):
        assert cli_main(argv) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and needle in err, err
    assert cli_main(["dqn", "evaluate", "--results", str(tmp_path), "--no-cml"]) == 2
    assert "is a folder" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["results.json"]
