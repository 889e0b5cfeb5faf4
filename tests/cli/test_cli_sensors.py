"""Range sensors from the command line: train --sensors, evaluate and navigate read them
from the model file, and the sensors experiment."""

import pytest

from cml_edge.core.model_file import load_model, save_model
from cml_edge.experiments import sensors as experiment
from cml_edge.grid.sensors import Sensors

SMALL = ["--arena", "8", "--walks", "4", "--steps", "80"]


def test_train_evaluate_navigate_with_sensors(tmp_path, cli, cli_json):
    model = tmp_path / "s.npz"
    trained = cli_json("train", *SMALL, "--sensors", 4, "--sensor-range", 3,
                    "--sensor-weight", 0.2, "--sensor-goal", "here", "--train-obstacles", 9,
                    "--out", model)
    sensors = {"k": 4, "range": 3, "weight": 0.2, "goal": "here", "train_obstacles": 9,
               "layout_seed": Sensors().layout_seed}
    assert trained["sensors"] == sensors and trained["compute_path"] == "direct"
    assert "dims" not in trained  # on the plane
    cml, record = load_model(model)
    assert cml.config.n_i == 6 and record["sensors"] == sensors
    evaluated = cli_json("evaluate", model, "--trials", 10, "--obstacles", 12)
    assert evaluated["sensors"] == sensors and evaluated["trials"] == 10
    assert evaluated["decision_agreement"]["mean"] == 1.0  # float: the twin's own decisions
    nav = cli_json("navigate", model, "--start", 0, 0, "--goal", 7, 7)
    assert nav["sensors"] == sensors and nav["trajectory"][0] == [0, 0]
    code, out, _ = cli("evaluate", model, "--trials", 5)
    assert code == 0 and "4 range sensors" in out


def test_sensors_in_space(tmp_path, cli_json):
    model = tmp_path / "s3.npz"
    trained = cli_json("train", "--arena", 5, "--walks", 3, "--steps", 40, "--dims", 3,
                    "--sensors", 26, "--out", model)
    assert trained["sensors"]["k"] == 26 and trained["dims"] == 3
    assert load_model(model)[0].config.n_i == 29
    assert cli_json("evaluate", model, "--trials", 6, "--obstacles", 10)["sensors"]["k"] == 26


@pytest.mark.parametrize("argv, needle", [
    (["--sensors", 6], "--sensors 6 is not allowed in 2 dimensions (allowed: 0, 4 face or 8 "
                       "king directions)"),
    (["--sensors", 8, "--dims", 3], "--sensors 8 is not allowed in 3 dimensions"),
    (["--train-obstacles", 3], "--train-obstacles needs --sensors"),
    (["--sensors", 8, "--train-obstacles", 63], "training obstacles 63 do not fit the 8 x 8"),
    (["--sensors", 8, "--sensor-weight", 5], "'5' is outside the range of --sensor-weight, 0..2"),
    (["--sensors", 8, "--sensor-range", 0], "--sensor-range"),
])
def test_bad_sensor_options_exit_2_with_one_line(tmp_path, argv, needle, cli_bad):
    out = tmp_path / "never.npz"
    assert needle in cli_bad("train", *SMALL, *argv, "--out", out)
    assert not out.exists()


def test_a_model_whose_sensors_and_shape_disagree_is_refused(tmp_path, cli_json, cli_bad):
    model = tmp_path / "m.npz"
    cli_json("train", *SMALL, "--out", model)
    cml, record = load_model(model)
    save_model(tmp_path / "liar.npz", cml, {**record, "sensors": Sensors(8).to_dict()})
    assert ("has 2 inputs and 8 actions; a grid model of 2 dimensions with king moves and 8 "
            "range sensors has 10 and 8") in cli_bad("evaluate", tmp_path / "liar.npz")
    save_model(tmp_path / "odd.npz", cml, {**record, "sensors": {"k": 8, "hue": 1}})
    assert "unknown sensor settings keys: hue" in cli_bad("evaluate", tmp_path / "odd.npz")
    save_model(tmp_path / "list.npz", cml, {**record, "sensors": [8]})
    assert "records sensors [8]" in cli_bad("navigate", tmp_path / "list.npz", "--start", 0,
                                         0, "--goal", 1, 1)


def test_the_sensors_experiment_lists_every_arm_on_each_device():
    tasks = experiment.tasks(seeds=2, backends=["float", "int8"])
    assert len(tasks) == 2 * len(experiment.ARMS) * 4 * 2  # arena + three maps
    by_key = {t.key: t.params for t in tasks}
    assert by_key["int8-sensors-here-arena-s1"]["sensors"]["goal"] == "here"
    assert by_key["float-paper-rooms-s0"]["sensors"] is None
    assert by_key["float-paper-rooms-s0"]["arena"] == 32
    assert by_key["float-control-arena-s0"]["sensors"]["k"] == 0
    evals = by_key["float-sensors-light-arena-s0"]["evals"]
    assert [(e["obstacles"], e["planner"]) for e in evals] == [
        (n, p) for n in (0, 300, 400) for p in ("paper", "escape")]


def test_only_the_sensors_experiment_takes_backends(tmp_path, cli_bad):
    assert "experiment 'obstacles' does not take --backends" in cli_bad(
        "sweep", "obstacles", "--backends", "float", "--out", tmp_path / "o")
    assert "unknown backend 'abacus'" in cli_bad("sweep", "sensors", "--backends", "abacus",
                                              "--out", tmp_path / "s")


@pytest.mark.slow
def test_the_sensors_sweep_writes_its_table(tmp_path, monkeypatch, cli_json):
    monkeypatch.setattr(experiment, "ARMS", {"paper": None, "sensors": Sensors()})
    out = tmp_path / "sensors"
    summary = cli_json("sweep", "sensors", "--backends", "float", "--seeds", 1,
                    "--workers", 1, "--planner", "paper", "--out", out)
    rows = {(r["arm"], r["eval"]): r for r in summary["rows"]}
    assert len(rows) == 2 * (3 + 3)
    assert rows[("paper", "obst0-paper")]["success_rate_connected"] == 1.0
    assert (rows[("sensors", "obst300-paper")]["n_i"], rows[("paper", "rooms-paper")]["n_i"]) \
        == (10, 2)
    assert rows[("sensors", "maze-paper")]["parameters"] == 256 * (10 + 16)
    assert rows[("paper", "maze-paper")]["parameters"] == 256 * (2 + 16)
    assert {r["device"] for r in summary["rows"]} == {"float"}
    assert all(r["energy_per_action_nj"] is None for r in summary["rows"])  # float64: no
    assert "backend_options" not in summary["rows"][0]  # sourced energy figure
    assert (out / "figure.png").read_bytes()[:4] == b"\x89PNG"


def test_extra_inputs_cost_energy_per_decision():
    int8 = [experiment.energy_per_action_nj("int8", {}, k) for k in (0, 4, 8)]
    assert int8[0] < int8[1] < int8[2]  # every input one more column of W_q read
    assert experiment.energy_per_action_nj("crossbar", {}, 8) < int8[2]
