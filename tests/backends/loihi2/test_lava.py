"""``cml-edge lava verify``: a loihi2 model run in Intel Lava 0.10.0's own simulator.

The tests marked ``lava`` build (or find) the Lava environment with ``scripts/lava_env.sh``
and are skipped, with the reason, only where the machine has no Python 3.10.
"""

from __future__ import annotations

import json
import subprocess

import numpy as np
import pytest

from cml_edge.backends.loihi2 import conformance
from cml_edge.backends.loihi2.array import Loihi2Array
from cml_edge.cli import main

NO_PYTHON_310 = 3  # scripts/lava_env.sh's exit status where no Python 3.10 exists


@pytest.fixture(scope="module")
def lava_env():
    """The Lava environment, built on first use (the script is idempotent)."""
    script = conformance.repo_root() / "scripts" / "lava_env.sh"
    done = subprocess.run(["bash", str(script)], capture_output=True, text=True, timeout=1800)
    if done.returncode == NO_PYTHON_310:
        pytest.skip(f"no Python 3.10 for Lava 0.10.0: {done.stderr.strip()}")
    assert done.returncode == 0, done.stderr
    return conformance.venv_python()


@pytest.fixture(scope="module")
def model(tmp_path_factory):
    path = tmp_path_factory.mktemp("lava") / "m.npz"
    code = main(["train", "--backend", "loihi2", "--arena", "6", "--walks", "2", "--steps",
                 "60", "--schedule", "step", "--path", "reference", "--out", str(path)])
    assert code == 0
    return path


def test_a_missing_environment_is_one_line_naming_the_build_command(model, tmp_path,
                                                                     monkeypatch, capsys):
    monkeypatch.setenv(conformance.VENV_VARIABLE, str(tmp_path / "none"))
    assert main(["lava", "verify", str(model), "--json"]) == 2
    out, err = capsys.readouterr()
    assert out == "" and err.count("\n") == 1
    assert err.startswith("cml-edge: error: the Lava environment is missing")
    assert "bash scripts/lava_env.sh" in err


@pytest.fixture(scope="module")
def int8_model(tmp_path_factory):
    path = tmp_path_factory.mktemp("int8") / "i.npz"
    assert main(["train", "--backend", "int8", "--arena", "4", "--walks", "1", "--steps",
                 "10", "--out", str(path)]) == 0
    return path


def test_bad_counts_and_other_models_are_refused(model, int8_model, capsys):
    assert main(["lava", "verify", str(model), "--epochs", "1001"]) == 2
    assert "--epochs 1001 is beyond 1000" in capsys.readouterr().err
    assert main(["lava", "verify", str(int8_model)]) == 2
    assert "lava verify runs loihi2 models" in capsys.readouterr().err


@pytest.mark.parametrize(("options", "named"), [
    (["--schedule", "walk"], "--schedule walk"),
    (["--t-epoch", "2"], "--t-epoch 2"),
    (["--draws", "independent", "--set", "terms=exact"], "--draws independent, terms=exact"),
])
def test_a_model_whose_learning_lava_does_not_run_is_refused(tmp_path, capsys, options, named):
    """Before any work (the environment is not even looked for): one line naming them."""
    path = tmp_path / "m.npz"
    assert main(["train", "--backend", "loihi2", *options, "--arena", "4", "--walks", "1",
                 "--steps", "10", "--out", str(path)]) == 0
    capsys.readouterr()
    assert main(["lava", "verify", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"trained with {named}, which Lava does not run" in err


def replay(path, capsys, *options):
    """``lava verify PATH --epochs 6 --reads 8 --json``'s result, after checking that each
    matrix's replayed updates (6 less those not expressible) all end on the emulation's
    weights and read its traces, that negative pre entries (W_q's position, W_k's state)
    came with the offset, and that W_v's pre (a one-hot action) has none."""
    capsys.readouterr()
    assert main(["lava", "verify", str(path), "--epochs", "6", "--reads", "8", "--json",
                 *options]) == 0
    result = json.loads(capsys.readouterr().out)
    for name, x in result["learning"].items():
        assert x["replayed"] == 6 - x["not_expressible"] > 0, name
        assert x["equal"] == x["engine_equal"] == x["traces_equal"] == x["replayed"], name
        assert x["offset"] > 0 or x["negative_pre"] == 0, name  # (a tiny one may round to 0)
    assert result["learning"]["W_v"]["negative_pre"] == 0
    assert result["bit_exact"] is True
    return result


@pytest.mark.lava
def test_a_trained_model_reads_in_lava_and_its_own_updates_replay(lava_env, model, capsys):
    """Reads match Lava integer for integer, and the model's own first updates, replayed,
    end epoch for epoch on the emulation's weights: W_q's and W_k's signed pre traces
    travel offset by 64 and are read by the rule's factor (x1 - 64)."""
    result = replay(model, capsys)
    assert all(result["learning"][name]["negative_pre"] > 0 for name in ("W_q", "W_k"))
    assert all(x["negative_post"] > 0 for x in result["learning"].values())
    for name in ("W_q", "W_k", "W_v", "W_v^T"):
        r = result["reads"][name]
        assert r["a_out_equal"] == r["u_equal"] == r["read_equal"] == r["vectors"] == 8


@pytest.mark.lava
@pytest.mark.parametrize("options", [["--set", "traces=stochastic"],
                                     ["--set", "payload_scale=full"],
                                     ["--message-bits", "8"]])
def test_other_trained_models_learn_in_lava_bit_for_bit(lava_env, tmp_path, capsys, options):
    """Stochastically rounded traces, full-scale payloads and 8-bit messages: each model's
    own updates replay epoch for epoch, later in its training too (``--skip``)."""
    path = tmp_path / "s.npz"
    assert main(["train", "--backend", "loihi2", *options, "--arena", "6", "--walks", "2",
                 "--steps", "60", "--schedule", "step", "--path", "reference",
                 "--out", str(path)]) == 0
    replay(path, capsys, "--skip", "40")


@pytest.mark.lava
def test_the_pre_traces_decay_as_lava_decays_them(lava_env, model):
    """With a time constant of 100 steps for x1 and y1 (the chip's is 65535, where a trace
    v moves about once in 65535 / |v| epochs) Lava's one step of decay moves most traces
    of W_q and W_k, by one draw per epoch for each side, at the positions of Lava's
    generators the comparison names; the emulation's model of it, given those draws,
    reads Lava's pre traces and ends on Lava's weights epoch for epoch (y as the rule
    reads it, decayed, is not a variable Lava shows: the weights are its test)."""
    from cml_edge.core.model_file import load_model
    from cml_edge.grid.in_lava import training_updates

    cml, training = load_model(model)
    updates = training_updates(cml, training, 20)
    result = conformance.verify(cml, str(model), updates, reads=1, trace_tau=100)
    for name, x in result["learning"].items():
        assert x["equal"] == x["traces_equal"] == x["replayed"] > 0, name
    assert all(result["learning"][name]["decayed"] > 20 for name in ("W_q", "W_k"))


@pytest.mark.lava
def test_overflowing_reads_are_what_lava_computes(lava_env):
    """Full-scale payloads overflow the neuron's current: one 2^24 correction, int32 sums."""
    W = np.random.default_rng(1).normal(0, 0.1, (6, 5))
    arr = Loihi2Array.from_float(W, payload_scale="full")
    X = np.random.default_rng(2).uniform(-1, 1, (6, 5))
    work = conformance.read_work(arr, "W", X, False)
    work["reads"] = np.array(["W"])
    got = conformance.run_lava(work)
    r = conformance.compare_reads(arr, X, False, got["W/a_out"], got["W/u"])
    assert r["neuron_wraps"] > 0
    assert r["a_out_equal"] == r["u_equal"] == r["read_equal"] == r["vectors"] == 6


@pytest.mark.lava
def test_dense_sums_beyond_int32_wrap_as_in_lava(lava_env):
    """Full-scale 24-bit payloads on 16 inputs of one sign: the dot product passes 2^31,
    and Lava's Dense holds it in int32, wrapped; the expectation wraps it too."""
    W = np.full((3, 16), 0.5)
    W[1] = -0.5
    W[2, ::2] = 0.25
    arr = Loihi2Array.from_float(W, payload_scale="full")
    X = np.random.default_rng(3).uniform(0.5, 1.0, (4, 16))
    X[1] *= -1.0
    work = conformance.read_work(arr, "W", X, False)
    work["reads"] = np.array(["W"])
    got = conformance.run_lava(work)
    r = conformance.compare_reads(arr, X, False, got["W/a_out"], got["W/u"])
    assert r["dense_wraps"] >= 8
    assert r["a_out_equal"] == r["u_equal"] == r["read_equal"] == r["vectors"] == 4


@pytest.mark.lava
def test_a_bare_sign_mode_code_clips_negative_weights_in_lava(lava_env, tmp_path):
    """Why the export names ``SignMode``: ``Dense(sign_mode=1)`` is not MIXED there."""
    code = ("import numpy as np\n"
            "from lava.proc.dense.models import AbstractPyDenseModelBitAcc as M\n"
            "from lava.utils.weightutils import SignMode, clip_weights\n"
            "W = np.array([[-4, 6]])\n"
            "print(clip_weights(W, 1, 8).tolist(), clip_weights(W, SignMode.MIXED, 8).tolist())")
    done = subprocess.run([str(lava_env), "-I", "-c", code], capture_output=True, text=True,
                          timeout=600)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split("]] ") == ["[[0, 6", "[[-4, 6]]\n"]


@pytest.mark.lava
def test_the_navigator_plans_in_lava_with_the_emulation_s_decisions(lava_env, model, capsys):
    """``cml-edge lava run``: every read of every decision computed in Lava; each decision
    is the one the emulation takes in that cell, and the plans end where its plans do."""
    assert main(["lava", "run", str(model), "--trials", "12", "--json"]) == 0
    r = json.loads(capsys.readouterr().out)
    assert r["trials"] == 12 and r["arena"] == 6 and r["decisions"] > 12
    assert r["decisions_equal"] == r["decisions"] and r["rounds"] >= 2
    assert r["success_rate"] == r["emulation_success_rate"]


def test_lava_run_refuses_other_models_before_any_work(int8_model, tmp_path, capsys,
                                                       monkeypatch):
    monkeypatch.setenv(conformance.VENV_VARIABLE, str(tmp_path / "none"))
    capsys.readouterr()
    assert main(["lava", "run", str(int8_model)]) == 2
    assert "lava run plans with loihi2 models" in capsys.readouterr().err
    assert main(["lava", "run", str(int8_model), "--trials", "1001"]) == 2
    assert "--trials 1001 is beyond 1000" in capsys.readouterr().err


def plan_step_script() -> str:
    """The ``plan_step.py`` of docs/devices/loihi2.md, as printed there."""
    page = (conformance.repo_root() / "docs" / "devices" / "loihi2.md").read_text()
    section = page.split("### One plan step in Lava, without cml-edge", 1)[1]
    return section.split("```python\n", 1)[1].split("```", 1)[0]


@pytest.mark.lava
def test_the_docs_plan_step_runs_in_lava_alone_and_takes_the_emulation_s_action(
        lava_env, model, tmp_path):
    from cml_edge.core.model_file import load_model
    from cml_edge.grid.arena import GridArena
    from cml_edge.grid.planning import plan

    script = tmp_path / "plan_step.py"
    script.write_text(plan_step_script())
    assert main(["export", str(model), "--format", "lava", "--out", str(tmp_path / "x")]) == 0
    cml, _ = load_model(model)
    for start, goal in (((0, 0), (5, 3)), ((4, 5), (0, 1)), ((2, 2), (2, 5))):
        done = subprocess.run([str(lava_env), "-I", str(script), str(tmp_path / "x"),
                               *map(str, start + goal)], capture_output=True, text=True,
                              timeout=600, cwd=tmp_path)  # -I: no cml_edge on its path
        assert done.returncode == 0, done.stderr
        move = json.loads(done.stdout)["move"]
        one = plan(cml, GridArena.empty(6), np.array([start]), np.array([goal]), max_steps=1)
        assert tuple(one.final[0]) == (start[0] + move[0], start[1] + move[1])
