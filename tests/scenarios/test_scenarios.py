"""Scenarios and break points: every scenario on a tiny budget, the JSON, seeds,
the sweep engine (pool, resume), bad input, and the bisection."""

import json
import re

import pytest

from cml_edge.errors import InputError
from cml_edge.scenarios import SCENARIOS, run_scenario
from cml_edge.scenarios.breakpoint import (
    GRID_POINTS,
    NotBracketedError,
    bisect,
    find_breakpoint,
    get_knob,
    knob_grid,
    knob_setting,
    knobs_of,
)
from cml_edge.scenarios.registry import AGES, RECOVERY_WALKS

PART_KEYS = {"part", "success_rate", "overhead_mean", "weight_error", "decision_agreement",
             "read_snr", "success_rate_seeds", "overhead_mean_seeds", "seeds", "per_seed"}
PARTS = {"paper": ["paper"], "in-situ": ["in-situ"], "retention": [n for n, _ in AGES],
         "clutter": ["obst300", "obst400"], "maps": ["maze", "rooms", "utrap"],
         "large": ["60x60", "120x120"], "robot": ["robot"], "drone": ["drone"],
         "recovery": [f"K{k}" for k in RECOVERY_WALKS]}


def _numbers(result):
    """The result without what may vary between runs of the same tasks."""
    return {k: v for k, v in result.items() if k not in ("wall_time_s", "out", "command")}


def test_the_nine_scenarios_are_registered():
    assert list(SCENARIOS) == list(PARTS)
    for s in SCENARIOS.values():
        assert len(s.doc) > 100


@pytest.mark.parametrize("name", [pytest.param(n, marks=pytest.mark.slow) if n == "maps" else n
                                  for n in PARTS])
def test_each_scenario_runs_on_a_tiny_budget(name):
    r = run_scenario(name, "int8", {}, seeds=1, budget="tiny", workers=1)
    assert [p["part"] for p in r["parts"]] == PARTS[name]
    assert r["backend"] == "int8" and r["seeds"] == 1 and r["budget"] == "tiny"
    for p in r["parts"]:
        assert set(p) >= PART_KEYS, name
        assert 0 <= p["success_rate"] <= 1
        assert 0 < p["weight_error"]["matrix_mean"]["mean"] < 2  # int8 is not its twin
        assert 0 <= p["decision_agreement"]["mean"] <= 1
    if name == "recovery":
        costs = [p["pulses"]["mean"] + p["writes"]["mean"] for p in r["parts"]]
        assert costs[0] == 0 and all(a < b for a, b in zip(costs, costs[1:]))  # cumulative
        assert r["dqn_retrain"]["available"] and "estimate" in r["dqn_retrain"]["method"]
    json.dumps(r, allow_nan=False)


def test_float64_does_not_drift_and_relearning_matches_its_twin():
    ret = run_scenario("retention", "float", {}, seeds=1, budget="tiny", workers=1)
    first = ret["parts"][0]
    for p in ret["parts"]:
        assert p["success_rate"] == first["success_rate"]
        assert p["weight_error"]["matrix_mean"]["mean"] < 1e-12
        assert p["decision_agreement"]["mean"] == 1.0
    rec = run_scenario("recovery", "float", {}, seeds=1, budget="tiny", workers=1)
    for p in rec["parts"]:
        assert p["weight_error"]["matrix_mean"]["mean"] < 1e-12
        assert p["energy_uJ"]["mean"] is None or p["relearn_walks"] == 0  # fp64: not costed


def test_drift_moves_the_pcm_weights_with_age():
    r = run_scenario("retention", "crossbar", {"preset": "pcm"}, seeds=1, budget="tiny",
                     workers=1)
    errors = [p["weight_error"]["matrix_mean"]["mean"] for p in r["parts"]]
    assert errors[-1] > errors[0]


@pytest.mark.slow
def test_same_seeds_same_numbers_in_process_pool_and_resumed(tmp_path):
    kw = dict(seeds=2, budget="tiny")
    one = run_scenario("clutter", "crossbar", {"preset": "reram"}, workers=1, **kw)
    two = run_scenario("clutter", "crossbar", {"preset": "reram"}, workers=2,
                       out=tmp_path / "a", **kw)
    assert _numbers(one) == _numbers(two)
    tasks = sorted((tmp_path / "a" / "tasks").iterdir())
    assert [t.name for t in tasks] == ["clutter-s0.json", "clutter-s1.json"]
    assert json.loads((tmp_path / "a" / "results.json").read_text())["parts"] == two["parts"]
    tasks[1].unlink()  # an interrupted sweep: one task lost
    kept = tasks[0].stat().st_mtime_ns
    again = run_scenario("clutter", "crossbar", {"preset": "reram"}, workers=1,
                         out=tmp_path / "a", **kw)
    assert tasks[0].stat().st_mtime_ns == kept and tasks[1].exists()
    assert _numbers(again) == _numbers(two)
    assert not [p for p in (tmp_path / "a").rglob("*") if p.name.startswith(".")]


@pytest.mark.parametrize("call,message", [
    (lambda: run_scenario("nope", "float", {}, 1, "tiny"), "unknown scenario"),
    (lambda: run_scenario("paper", "nope", {}, 1, "tiny"), "nope"),
    (lambda: run_scenario("paper", "crossbar", {"levels": 1}, 1, "tiny"), "levels"),
    (lambda: run_scenario("paper", "float", {}, 0, "tiny"), "seeds"),
    (lambda: run_scenario("paper", "float", {}, 1, "huge"), "unknown budget"),
])
def test_bad_input(call, message):
    with pytest.raises(InputError, match=message):
        call()


def test_the_cli(cli, tmp_path):
    code, out, _ = cli("scenario", "paper", "--backend", "crossbar", "--preset", "ideal",
                       "--set", "read_noise=0.01", "--seeds", 1, "--budget", "tiny",
                       "--workers", 1, "--json", "--out", tmp_path / "s")
    data = json.loads(out)
    assert code == 0 and data["backend_options"] == {"preset": "ideal", "read_noise": 0.01}
    assert data["command"].startswith("cml-edge")
    assert (tmp_path / "s" / "results.json").is_file()
    for argv in (["scenario", "nope"], ["scenario", "paper", "--backend", "nope"],
                 ["scenario", "paper", "--quick", "--budget", "tiny"],
                 ["breakpoint", "--knob", "nope", "--scenario", "paper"],
                 ["breakpoint", "--knob", "levels", "--scenario", "nope"],
                 ["breakpoint", "--knob", "levels", "--scenario", "paper", "--seeds", 1],
                 ["breakpoint", "--knob", "levels", "--scenario", "paper", "--backend", "int8"],
                 ["breakpoint", "--knob", "bits", "--scenario", "paper", "--backend", "int8"]):
        code, out, err = cli(*argv)
        assert code == 2 and out == "" and len(err.strip().splitlines()) == 1, argv


def test_bisection_on_a_monotone_function():
    grid = list(range(GRID_POINTS))
    for threshold in range(1, GRID_POINTS):  # passes while the value is below threshold
        i, j, seen = bisect(grid, lambda v, t=threshold: v < t)
        assert (grid[i], grid[j]) == (threshold - 1, threshold)
        assert len(seen) <= 2 + 4 and seen[:2] == [(0, True), (GRID_POINTS - 1, False)]
    for passes in (lambda v: False, lambda v: True):
        with pytest.raises(NotBracketedError) as err:
            bisect(grid, passes)
        assert len(err.value.seen) == 2


def test_knob_grids_run_from_the_good_end():
    assert knob_grid(get_knob("read_noise", "crossbar"), 0, 0.5)[0] == 0
    levels = knob_grid(get_knob("levels", "crossbar"), 2, 1001)
    assert levels[0] == 1001 and levels[-1] == 2 and len(set(levels)) == len(levels)
    assert knob_grid(get_knob("drift_time", "float"), 1, 1e9)[-1] == pytest.approx(1e9)


def test_knobs_are_read_from_the_devices_and_set_their_fields():
    """Each device's own knobs (declared in its folder), then the generic idle time."""
    assert list(knobs_of("crossbar")) == ["read_noise", "prog_noise", "levels", "stuck",
                                          "adc_bits", "drift_time"]
    assert list(knobs_of("float")) == ["drift_time"]
    fixed, loihi2 = get_knob("bits", "fixed"), get_knob("bits", "loihi2")
    assert (fixed.field, fixed.lo, fixed.hi) == ("bits", 2, 16)
    assert (loihi2.field, loihi2.lo, loihi2.hi) == ("num_weight_bits", 1, 8)
    assert knob_setting(get_knob("stuck", "crossbar"), 0.5) == (
        {"stuck_low": 0.25, "stuck_high": 0.25}, 0.0)
    assert knob_setting(loihi2, 6) == ({"num_weight_bits": 6}, 0.0)
    assert knob_setting(get_knob("drift_time", "crossbar"), 60) == ({}, 60.0)
    with pytest.raises(InputError,
                       match="unknown knob 'nope'; allowed: bits, read_noise, .*drift_time"):
        get_knob("nope", "crossbar")
    with pytest.raises(InputError, match="knob 'levels' does not apply to the fixed device; "
                                         "its knobs: bits, drift_time"):
        get_knob("levels", "fixed")


@pytest.mark.slow
def test_a_real_break_point_and_a_range_that_does_not_bracket():
    kw = dict(options={"preset": "ideal"}, target=0.9, seeds=2, budget="quick", workers=1)
    r = find_breakpoint("paper", "crossbar", "read_noise", **kw)
    lo, hi = r["bracket"]
    assert r["value"] == lo < hi and r["good"] == "low"
    values = {e["value"]: e["success_rate"] for e in r["evaluations"]}
    assert values[lo] >= 0.9 > values[hi]
    assert r["evaluations"][0]["value"] == 0.0 and r["n_evaluations"] <= 6
    none = find_breakpoint("paper", "crossbar", "read_noise", value_range=(0.0, 0.001), **kw)
    assert none["value"] is None and not none["found"]
    assert re.search(r"no break point within the range.*0: success.*0\.001: success",
                     none["note"])
    with pytest.raises(InputError, match="at least 2 seeds"):
        find_breakpoint("paper", "crossbar", "read_noise", **{**kw, "seeds": 1})

