"""Scenarios and break points in space (``--dims 3``): the 3-D forms of the grid's
scenarios, the plane's runs unchanged, the refusals, a run and a break point."""

import json

import pytest

from cml_edge.errors import InputError
from cml_edge.scenarios import SCENARIOS, run_scenario
from cml_edge.scenarios.breakpoint import breakpoint_search, find_breakpoint
from cml_edge.scenarios.registry import (
    BUDGETS,
    CLUTTER_3D,
    SPACE_SCENARIOS,
    VOXEL_MAPS_SIDE,
    space_tag,
)
from cml_edge.scenarios.runner import run_settings, scenario_tasks

TINY = BUDGETS["tiny"]


def test_the_plane_s_runs_say_no_dims_and_keep_their_ids():
    for name, s in SCENARIOS.items():
        if 2 not in s.dims:  # the drone flies in space only
            continue
        assert s.runs(TINY) == s.runs(TINY, 2, "king"), name
        for rid, spec in s.runs(TINY):
            assert "dims" not in spec["run"] and "3d" not in rid
    assert "dims" not in run_settings("paper", "float", {}, "tiny", 0.0)


def test_each_grid_scenario_has_a_3d_form():
    grid = [n for n, s in SCENARIOS.items() if s.world == "grid"]
    assert "robot" not in grid and set(SPACE_SCENARIOS) <= {*grid, "drone"}
    assert all(3 in SCENARIOS[n].dims for n in SPACE_SCENARIOS)  # all run in space
    for name in grid:
        runs = SCENARIOS[name].runs(TINY, 3)
        plane = SCENARIOS[name].runs(TINY)
        assert [rid for rid, _ in runs] == [f"{rid}-3d" for rid, _ in plane][:len(runs)]
        for _, spec in runs:
            assert spec["run"]["dims"] == 3 and spec["run"]["moves"] == "king"
    parts = {n: [p["name"] for _, r in SCENARIOS[n].runs(TINY, 3) for p in r["parts"]]
             for n in ("clutter", "maps", "large")}
    assert parts == {"clutter": [f"obst{n}" for n in CLUTTER_3D],
                     "maps": ["floors", "pillars", "shaft"], "large": ["60x60x60"]}
    (_, maps), = SCENARIOS["maps"].runs(TINY, 3)
    assert maps["run"]["arena"] == VOXEL_MAPS_SIDE == 16
    assert [rid for rid, _ in SCENARIOS["paper"].runs(TINY, 3, "face")] == ["paper-3d-face"]
    assert space_tag(2, "face") == "-face" and space_tag(2, "king") == ""


@pytest.mark.parametrize("call,message", [
    (lambda: SCENARIOS["robot"].runs(TINY, 3), "runs in 2-D only"),
    (lambda: SCENARIOS["robot"].runs(TINY, 2, "face"), "--moves sets the grid"),
    (lambda: SCENARIOS["paper"].runs(TINY, 4), "dims 4"),
    (lambda: SCENARIOS["paper"].runs(TINY, 3, "rook"), "unknown moves"),
    (lambda: scenario_tasks("robot", "float", {}, 1, "tiny", dims=3), "2-D only"),
    (lambda: breakpoint_search("robot", "fixed", "bits", dims=3, budget="tiny"), "2-D only"),
])
def test_bad_worlds_are_one_line_errors(call, message):
    with pytest.raises(InputError, match=message) as err:
        call()
    assert "\n" not in str(err.value)


def test_a_scenario_in_space_differs_from_the_plane():
    plane = run_scenario("paper", "int8", {}, seeds=1, budget="tiny", workers=1)
    space = run_scenario("paper", "int8", {}, seeds=1, budget="tiny", workers=1, dims=3)
    assert "dims" not in plane and (space["dims"], space["moves"]) == (3, "king")
    p2, p3 = plane["parts"][0], space["parts"][0]
    assert p2["part"] == p3["part"] == "paper"
    assert p2["weight_error"] != p3["weight_error"]  # another model, another world
    assert len(space["parts"][0]["per_seed"]) == 1
    json.dumps(space, allow_nan=False)


def test_the_cli_in_space(cli):
    code, out, _ = cli("scenario", "paper", "--dims", 3, "--seeds", 1, "--budget", "tiny",
                       "--workers", 1, "--json")
    data = json.loads(out)
    assert code == 0 and data["dims"] == 3 and data["scenario"] == "paper"
    code, out, _ = cli("scenario", "paper", "--dims", 3, "--seeds", 1, "--budget", "tiny",
                       "--workers", 1)
    assert code == 0 and out.startswith("paper (3-D, king moves) on float")
    for argv in (["scenario", "robot", "--dims", 3],
                 ["scenario", "robot", "--moves", "face"],
                 ["breakpoint", "--knob", "bits", "--scenario", "robot", "--dims", 3]):
        code, out, err = cli(*argv)
        assert code == 2 and out == "" and len(err.strip().splitlines()) == 1, argv


@pytest.mark.slow
def test_a_break_point_in_space():
    r = find_breakpoint("paper", "fixed", "bits", target=0.5, seeds=2, budget="tiny",
                        workers=1, dims=3, value_range=(2, 16))
    assert (r["dims"], r["moves"]) == (3, "king")
    assert r["evaluations"] and all(0 <= e["success_rate"] <= 1 for e in r["evaluations"])
    plane = find_breakpoint("paper", "fixed", "bits", target=0.5, seeds=2, budget="tiny",
                            workers=1, value_range=(2, 16))
    assert "dims" not in plane
    assert [e["parts"] for e in plane["evaluations"]] != [e["parts"] for e in r["evaluations"]]
