"""Each file kind's reader refuses what it cannot use in one line, before any work: DQN
results, scenario files and model records (the readers of cml_edge.baselines,
cml_edge.grid.maps and cml_edge.core.model_file)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from cml_edge.baselines import RESULTS_FORMAT, load_results
from cml_edge.errors import InputError
from cml_edge.grid.maps import MapFormatError, load_map, parse_scen, scenario_pairs

GOOD_EVALUATION = {"reward": "tailored", "goal_conditioned": False, "train_steps": 200,
                   "success_rate": 1.0, "convergence": {"step": 100}}


def _results(tmp_path, evaluation=None, **top):
    doc = {"format": RESULTS_FORMAT, "network": {"layers": [2, 64, 64, 8]},
           "hyperparameters": {"learning_starts": 100}, "runs": {},
           "evaluations": {"e": {**GOOD_EVALUATION, **(evaluation or {})}}, **top}
    path = tmp_path / "dqn.json"
    path.write_text(json.dumps(doc))
    return path


def test_a_good_results_file_reads(tmp_path):
    assert load_results(_results(tmp_path))["evaluations"]["e"]["reward"] == "tailored"
    assert load_results(tmp_path / "none.json") is None


@pytest.mark.parametrize("evaluation, top, message", [
    ({"reward": None}, {}, "evaluation 'e' has no reward name"),
    ({"success_rate": 1.5}, {}, r"success_rate 1.5 is not in 0..1"),
    ({"train_steps": 0}, {}, "train_steps 0"),
    ({"convergence": {"step": -3}}, {}, "its convergence has no step count"),
    ({"goal_conditioned": True}, {}, "no goal-conditioned layer sizes"),
    ({}, {"network": {"layers": [2]}}, "its network has no list of layer sizes"),
    ({}, {"hyperparameters": {}}, "no learning_starts"),
    ({}, {"runs": []}, "its 'runs' is not a table"),
])
def test_a_results_file_the_report_cannot_use_is_refused(tmp_path, evaluation, top, message):
    with pytest.raises(InputError, match=message) as err:
        load_results(_results(tmp_path, evaluation, **top))
    assert "corrupted DQN results file" in str(err.value) and "\n" not in str(err.value)


def test_a_results_file_with_nan_is_refused(tmp_path):
    path = _results(tmp_path)
    path.write_text(path.read_text().replace('"success_rate": 1.0', '"success_rate": NaN'))
    with pytest.raises(InputError, match="holds NaN, which is no number"):
        load_results(path)


def test_a_scenario_file_is_held_to_its_limits(tmp_path, monkeypatch):
    from cml_edge import sizes

    head = "version 1\n"
    row = "0\tm.map\t4\t4\t0\t0\t3\t3\t3\n"
    monkeypatch.setitem(sizes.SIZES, "trials", sizes.Size(1, 3, "a test's limit"))
    assert len(parse_scen(head + row * 3)) == 3
    with pytest.raises(MapFormatError, match="more than 3 problems"):
        parse_scen(head + row * 4)
    (tmp_path / "m.map").write_text("type octile\nheight 4\nwidth 4\nmap\n" + "....\n" * 4)
    grid = load_map(tmp_path / "m.map")
    with pytest.raises(MapFormatError, match="problem 1 starts at its goal 2 2"):
        scenario_pairs(grid, parse_scen(head + "0\tm.map\t4\t4\t2\t2\t2\t2\t0\n"))


def test_a_model_record_beyond_the_options_ranges_is_refused(tmp_path, cli):
    model = tmp_path / "m.npz"
    assert cli("train", "--arena", 8, "--walks", 1, "--steps", 10, "--out", model)[0] == 0
    data = dict(np.load(model))
    meta = json.loads(str(data["meta"]))
    for key, value, message in (("arena", 100_000, "arena 100000 is not an integer in "
                                                   "2..1024"),
                                ("seed", -1, "seed -1 is not an integer"),
                                ("walks", 10**9, "walks 1000000000 is not an integer in "
                                                 "1..100000"),
                                ("arena", "30", "arena '30' is not an integer")):
        bad = {**meta, "training": {**meta["training"], key: value}}
        np.savez(tmp_path / "bad.npz", **{**data, "meta": np.array(json.dumps(bad))})
        code, _, err = cli("evaluate", tmp_path / "bad.npz", "--trials", 2)
        assert code == 2 and message in err and err.count("\n") == 1, err
    for version in ("1", [1, 1]):
        np.savez(tmp_path / "bad.npz", **{**data, "format_version": np.array(version)})
        code, _, err = cli("evaluate", tmp_path / "bad.npz")
        assert code == 2 and "format version" in err and err.count("\n") == 1, err
