"""The robot commands on the MuJoCo simulator, end to end through the command line."""

import json

import pytest

pytest.importorskip("mujoco", reason="the MuJoCo simulator needs the robot extra "
                    "(pip install 'cml-edge[robot]')")

CORNER = ["--base", "0.4", "0.4", "1.57"]  # in a corner, along a wall: the walls mask actions


@pytest.fixture(scope="module")
def kinematic_model(tmp_path_factory):
    """A tiny float model trained on the kinematic simulator (it has a float64 twin)."""
    from cml_edge.cli import main

    path = tmp_path_factory.mktemp("robot") / "robot.npz"
    assert main(["robot", "train", "--walks", "2", "--steps", "30", "--out", str(path)]) == 0
    return path


def test_evaluate_on_mujoco_replays_the_decisions_against_the_twin(cli, kinematic_model):
    """The fidelity replay runs with the MuJoCo simulator's Python plug-in; a float64
    model is its own twin, so at every pose MuJoCo drove it to (the actions the walls
    leave there) the twin decides as it did."""
    code, out, err = cli("robot", "evaluate", kinematic_model, "--sim", "mujoco", "--trials",
                         "3", "--max-actions", "6", *CORNER, "--json")
    assert code == 0, err
    data = json.loads(out)
    assert (data["sim"], data["trained_on"], data["trials"]) == ("mujoco", "kinematic", 3)
    seed = data["per_seed"][0]
    assert seed["decisions"] == data["actions"] > 0
    assert seed["decisions_agreed"] == seed["decisions"]
    assert data["decision_agreement"]["mean"] == 1.0
    assert data["weight_error"]["matrix_mean"]["mean"] == 0.0


def test_navigate_on_mujoco_plots_its_runs(cli, kinematic_model, tmp_path):
    plot = tmp_path / "runs.png"
    code, out, err = cli("robot", "navigate", kinematic_model, "--sim", "mujoco", "--goals", "2",
                         "--max-actions", "4", *CORNER, "--plot", plot, "--json")
    assert code == 0, err
    data = json.loads(out)
    assert data["sim"] == "mujoco" and len(data["runs"]["final"]) == 2
    assert plot.stat().st_size > 0


def test_train_on_mujoco_then_evaluate_without_a_twin(cli, tmp_path):
    """A model trained on MuJoCo evaluates (on either simulator); its twin would be
    retrained on the kinematic one, so the fidelity figures say why they are missing."""
    model = tmp_path / "mj.npz"
    code, out, err = cli("robot", "train", "--sim", "mujoco", "--walks", "1", "--steps", "8",
                         "--out", model, "--json")
    assert code == 0, err
    assert json.loads(out)["sim"] == "mujoco"
    code, out, err = cli("robot", "evaluate", model, "--trials", "2", "--max-actions", "3",
                         "--json")
    assert code == 0, err
    data = json.loads(out)
    assert data["sim"] == "mujoco" and data["decision_agreement"] is None
    assert data["fidelity_twin"].startswith("unavailable: the models were trained on mujoco")
