"""``cml-edge scenario NAME --chips N``: chips differ on a crossbar, the chip of
the model seed is the one-chip run, resume, the JSON without chips, bad input."""

import json
import re

import pytest

from cml_edge.errors import InputError
from cml_edge.scenarios import run_scenario
from cml_edge.scenarios.runner import scenario_tasks

PCM = {"preset": "pcm"}
CHIP_KEYS = {"chips", "yield", "yield_target"}
TOP_KEYS = {"scenario", "description", "world", "backend", "backend_options", "technology",
            "seeds", "seed_list", "budget", "walks", "steps", "trials", "idle_s",
            "compute_path", "fidelity_twin", "tasks", "parts", "wall_time_s", "command",
            "cml_edge_version"}
"""The keys of a scenario's JSON before --chips (main at b0b12fc)."""


def _numbers(result):
    return {k: v for k, v in result.items() if k not in ("wall_time_s", "out", "command")}


@pytest.fixture(scope="module")
def pcm_runs(tmp_path_factory):
    """The paper scenario on pcm, one model seed: on its own chip, and on chips 0 and 1."""
    out = tmp_path_factory.mktemp("chips")
    single = run_scenario("paper", "crossbar", PCM, seeds=1, budget="tiny", workers=1)
    chips = run_scenario("paper", "crossbar", PCM, seeds=1, budget="tiny", workers=1,
                         out=out, chips=2, first_chip=0, yield_target=0.3)
    return single, chips, out


def test_the_chip_of_the_model_seed_is_the_one_chip_run_and_chips_differ(pcm_runs):
    single, chips, _ = pcm_runs
    (one,), (part,) = single["parts"], chips["parts"]
    c0, c1 = (dict(s) for s in part["per_seed"])  # the fixture stays as it was
    assert (c0.pop("chip"), c1.pop("chip")) == (0, 1)
    assert c0 == one["per_seed"][0]  # chip seed 0 = model seed 0: the same run
    assert c1 != c0  # another chip, another result
    assert part["chips"]["chip_seeds"] == [0, 1] and chips["chip_seeds"] == [0, 1]
    per_chip = part["chips"]["per_chip"]
    assert per_chip[0]["success_rate"] == one["success_rate"]
    assert per_chip[0]["weight_error.matrix_mean"] == one["weight_error"]["matrix_mean"]["mean"]
    success = [c["success_rate"] for c in per_chip]
    assert part["yield"] == sum(s >= 0.3 for s in success) / 2 and part["yield_target"] == 0.3
    error = part["chips"]["distribution"]["weight_error.matrix_mean"]
    assert error["min"] < error["max"]
    assert part["seeds"] == 1 and chips["tasks"] == 2  # pooled over the 2 chips x 1 seed


def test_a_rerun_resumes(pcm_runs):
    _, chips, out = pcm_runs
    tasks = sorted((out / "tasks").iterdir())
    assert [t.name for t in tasks] == ["paper-c0-s0.json", "paper-c1-s0.json"]
    stamps = [t.stat().st_mtime_ns for t in tasks]
    again = run_scenario("paper", "crossbar", PCM, seeds=1, budget="tiny", workers=1,
                         out=out, chips=2, first_chip=0, yield_target=0.3)
    assert [t.stat().st_mtime_ns for t in tasks] == stamps  # nothing computed again
    assert _numbers(again) == _numbers(chips)


def test_without_chips_the_tasks_and_the_json_are_as_before(pcm_runs):
    single, _, _ = pcm_runs
    assert set(single) == TOP_KEYS
    assert not CHIP_KEYS & set(single["parts"][0])
    assert all("chip" not in s for s in single["parts"][0]["per_seed"])
    (task,) = scenario_tasks("paper", "float", {}, 1, "tiny")
    assert task.key == "paper-s0" and "chip" not in task.params
    keys = [t.key for t in scenario_tasks("retention", "float", {}, 2, "tiny", chips=[3, 4])]
    assert keys == ["retention-c3-s0", "retention-c3-s1", "retention-c4-s0", "retention-c4-s1"]


def test_the_robot_takes_a_chip():
    r = run_scenario("robot", "float", {}, seeds=1, budget="tiny", workers=1, chips=2,
                     first_chip=5)
    a, b = r["parts"][0]["chips"]["per_chip"]
    assert (a.pop("chip"), b.pop("chip")) == (5, 6) and a == b  # a float chip draws nothing
    single = run_scenario("robot", "crossbar", PCM, seeds=1, budget="tiny", workers=1)
    chips = run_scenario("robot", "crossbar", PCM, seeds=1, budget="tiny", workers=1,
                         chips=2)
    c0, c1 = chips["parts"][0]["per_seed"]
    assert {**single["parts"][0]["per_seed"][0], "chip": 0} == c0 and c1 != c0


@pytest.mark.parametrize("kw, message", [
    ({"chips": 0}, "chips 0"), ({"chips": 2, "yield_target": 1.5}, "yield target"),
    ({"chips": 2, "first_chip": -1}, "first chip"),
])
def test_bad_input(kw, message):
    with pytest.raises(InputError, match=message):
        run_scenario("paper", "float", {}, 1, "tiny", **kw)


def test_the_cli(cli, tmp_path):
    code, out, err = cli("scenario", "paper", "--seeds", 1, "--budget", "tiny", "--workers", 1,
                         "--chips", 2, "--first-chip", 3, "--out", tmp_path / "f")
    assert code == 2 and "no device-to-device variation" in err  # float chips are one chip
    code, out, err = cli("scenario", "paper", "--backend", "int8", "--seeds", 1, "--budget",
                         "tiny", "--workers", 1, "--chips", 2, "--first-chip", 3, "--out",
                         tmp_path / "s")
    assert code == 0, err
    assert out.startswith("paper on int8: 1 seed x 2 chips, tiny budget\n")
    assert re.search(r"^paper: yield [01]\.\d{3} \(success >= 0\.95\) over 2 chips; success "
                     r"mean [\d.]+, p05 [\d.]+, median [\d.]+, p95 [\d.]+$", out, re.M), out
    data = json.loads((tmp_path / "s" / "results.json").read_text())
    assert data["chip_seeds"] == [3, 4] and data["parts"][0]["chips"]["n"] == 2
    for bad in (["--chips", 0], ["--chips", 2, "--yield-target", 1.5],
                ["--chips", 2, "--first-chip", -1], ["--first-chip", 3], ["--yield-target", 0.9]):
        code, out, err = cli("scenario", "paper", "--budget", "tiny", *bad)
        assert code == 2 and out == "" and len(err.strip().splitlines()) == 1, bad
