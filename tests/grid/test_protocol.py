"""The protocol's settings as one record: JSON both ways, checked when made, and the same
result as the keyword arguments it replaced (tests/data/golden, generate.py there), as a
seed promises it on any machine (:mod:`cml_edge.core.machines`)."""

import json
from dataclasses import replace
from pathlib import Path

import pytest

from cml_edge.core.machines import differences
from cml_edge.errors import InputError
from cml_edge.grid.maps import shipped_path
from cml_edge.grid.protocol import Protocol, run_protocol
from cml_edge.grid.training import TrainConfig

GOLDEN = json.loads((Path(__file__).resolve().parents[1] / "data" / "golden" /
                     "protocol.json").read_text())


def test_json_both_ways():
    p = Protocol("crossbar", range(3), 7, 12, 4, TrainConfig(5, 60, "mixed", "step"), "raw",
                 9, "direct", 10.0, "escape", 40, 2, {"preset": "pcm", "levels": 16},
                 chip=3, fidelity=False)
    d = p.to_dict()
    assert d["seeds"] == [0, 1, 2] and d["train"] == {"walks": 5, "steps": 60,
                                                      "explore": "mixed", "schedule": "step"}
    assert Protocol.from_dict(json.loads(json.dumps(d))) == p
    assert Protocol.from_dict({}) == Protocol()
    assert p.cml_config().utility == "raw" and p.cml_config().obs_scale == 12.0


@pytest.mark.parametrize("fields, message", [
    ({"backend": "nope"}, "unknown backend 'nope'"),
    ({"seeds": []}, "no seeds"),
    ({"seeds": [0, -1]}, "seed -1"),
    ({"seeds": [1.5]}, "seed 1.5"),
    ({"trials": 0}, "trials 0"),
    ({"arena_size": 1}, "arena_size 1"),
    ({"obstacles": True}, "obstacles True"),
    ({"utility": "best"}, "unknown utility 'best'"),
    ({"path": "fast"}, "unknown path 'fast'"),
    ({"idle_s": -1.0}, "idle_s -1.0"),
    ({"idle_s": float("nan")}, "idle_s nan"),
    ({"planner": "astar"}, "unknown planner 'astar'"),
    ({"max_steps": 0}, "max_steps 0"),
    ({"epoch": 0}, "epoch 0"),
    ({"eval_size": 1}, "eval_size 1"),
    ({"scen": "x.scen"}, "a scen file needs a map"),
    ({"map": ""}, "map '' is not a file name"),
    ({"map": "rooms", "eval_size": 40}, "eval_size or map"),
    ({"map": "rooms", "obstacles": 3}, "not on a map"),
    ({"chip": -2}, "chip -2"),
    ({"fidelity": "yes"}, "fidelity 'yes'"),
    ({"backend_options": ["pcm"]}, "backend_options"),
])
def test_bad_settings_are_one_line_errors(fields, message):
    with pytest.raises(InputError, match=message) as err:
        Protocol(**fields)
    assert "\n" not in str(err.value)


@pytest.mark.parametrize("d, message", [
    ({"trails": 5}, "unknown protocol keys: trails"),
    ({"train": {"walk": 5}}, "train"),
    ({"train": {"walks": 0}}, "walks 0"),
])
def test_from_dict_names_a_bad_key(d, message):
    with pytest.raises(InputError, match=message):
        Protocol.from_dict(d)


@pytest.mark.parametrize("name", sorted(GOLDEN))
def test_the_same_json_as_the_keyword_call(name):
    case = GOLDEN[name]
    protocol = Protocol.from_dict(case["protocol"])
    want = dict(case["result"])
    if protocol.scen is not None:  # a shipped file, wherever the package is
        protocol = replace(protocol, scen=str(shipped_path(protocol.map, ".map.scen")))
        want["scen"] = protocol.scen
    result = run_protocol(protocol)
    result.pop("wall_time_s")
    # keys, order and values: integers exact, floats as a seed promises across machines
    assert differences(json.loads(json.dumps(result)), want) == []

