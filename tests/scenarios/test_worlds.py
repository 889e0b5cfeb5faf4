"""The worlds behind the scenarios: one registry, one protocol met by the grid and the
robot, one task for both, and the same scenario JSON as before the worlds were one
protocol (tests/data/golden, generate.py there)."""

import json
from pathlib import Path

import pytest

from cml_edge.core.machines import differences
from cml_edge.core.world import WORLDS, World, get_world
from cml_edge.errors import InputError
from cml_edge.scenarios import SCENARIOS, run_scenario
from cml_edge.scenarios.runner import scenario_tasks
from cml_edge.scenarios.tasks import TASK_FN, scenario_task

GOLDEN = json.loads((Path(__file__).resolve().parents[1] / "data" / "golden" /
                     "scenarios.json").read_text())
VARIES = ("wall_time_s", "cml_edge_version")


def _numbers(result):
    """The result without what varies with the run and the checkout: its time, the version
    and where the DQN's results file is."""
    out = {k: v for k, v in result.items() if k not in VARIES}
    if "dqn_retrain" in out:
        out["dqn_retrain"] = {k: v for k, v in out["dqn_retrain"].items() if k != "source"}
    return out


def test_every_world_meets_the_protocol_and_is_named():
    methods = [m for m in vars(World) if not m.startswith("_") and callable(getattr(World, m))]
    assert set(methods) == {"train", "twin", "relearn", "plan", "summarise", "pool"}
    for name in WORLDS:
        world = get_world(name)
        assert world.name == name
        assert all(callable(getattr(world, m)) for m in methods)
    # every world has a scenario, and every scenario's world is registered
    assert {s.world for s in SCENARIOS.values()} == set(WORLDS)
    with pytest.raises(InputError, match="unknown world 'sea'; allowed: grid, robot"):
        get_world("sea")


def test_both_worlds_run_on_the_one_task():
    tasks = scenario_tasks("paper", "float", {}, 1, "tiny") + \
        scenario_tasks("robot", "float", {}, 1, "tiny")
    assert {t.fn for t in tasks} == {TASK_FN}
    assert [t.params["world"] for t in tasks] == ["grid", "robot"]


def test_the_robot_does_not_relearn():
    (task,) = scenario_tasks("robot", "float", {}, 1, "tiny")
    params = dict(task.params)
    params["parts"] = [{**params["parts"][0], "relearn_walks": 2}]
    with pytest.raises(InputError, match="does not relearn"):
        scenario_task(**params)


@pytest.mark.parametrize("name", sorted(GOLDEN))
def test_the_same_json_as_before(name):
    result = run_scenario(name, "int8", {}, seeds=1, budget="tiny", workers=1)
    # keys, order and values: integers exact, floats as a seed promises across machines
    assert differences(json.loads(json.dumps(_numbers(result))), _numbers(GOLDEN[name])) == []


def test_the_drone_scenario_flies_in_space_only(tmp_path, cli):
    (task,) = scenario_tasks("drone", "int8", {}, 1, "tiny")
    assert task.params["world"] == "drone"
    with pytest.raises(InputError, match="scenario 'drone' runs in 3-D only, not in 2-D"):
        scenario_tasks("drone", "float", {}, 1, "tiny", dims=2)
    code, out, err = cli("scenario", "drone", "--backend", "int8", "--seeds", 1, "--quick",
                         "--out", tmp_path / "drone", "--json")
    assert code == 0, err
    result = json.loads(out)
    (part,) = result["parts"]
    assert (result["world"], part["part"], part["trials"]) == ("drone", "drone", 50)
    assert 0.0 <= part["success_rate"] <= 1.0 and part["path_ratio"] >= 1.0
