"""Monte Carlo over chips (cml_edge.grid.chips): deterministic per chip seed, chips differ,
the pool and in-process agree, the yield's arithmetic, bad input."""

import json

import pytest

from cml_edge.errors import InputError
from cml_edge.grid.chips import (
    check_chips,
    chip_means,
    chip_task,
    chip_yield,
    pool_chips,
    run_chips,
)
from cml_edge.grid.protocol import Protocol, run_protocol
from cml_edge.grid.training import TrainConfig

SMALL = {"backend": "crossbar", "seeds": [0], "trials": 8, "arena_size": 10, "obstacles": 0,
         "train": {"walks": 3, "steps": 60, "explore": "random", "schedule": "walk"},
         "utility": "normalized", "eval_seed": 5, "path": None, "idle_s": 0.0,
         "planner": "paper", "max_steps": 30, "epoch": 3,
         "backend_options": {"preset": "pcm"}}


def _strip(r):
    return {k: v for k, v in r.items() if k != "wall_time_s"}


def test_same_chip_seed_same_result_and_chips_differ():
    a, b, c = chip_task(4, SMALL), chip_task(4, SMALL), chip_task(5, SMALL)
    assert _strip(a) == _strip(b)
    assert a["per_seed"] != c["per_seed"]


def test_a_chip_of_the_model_seed_is_the_single_chip_run():
    single = run_protocol(Protocol("crossbar", [0], 8, 10, train=TrainConfig(3, 60),
                                   eval_seed=5, max_steps=30, epoch=3,
                                   backend_options={"preset": "pcm"}))
    chip = chip_task(0, SMALL)
    assert chip["per_seed"] == single["per_seed"]


def test_pool_and_in_process_agree(tmp_path):
    protocol = Protocol.from_dict(SMALL)
    pooled = run_chips(3, protocol, 0.5, first=2, out=tmp_path / "pool", workers=2)
    local = run_chips(3, protocol, 0.5, first=2, out=tmp_path / "local", workers=1)
    assert pooled["chips"] == local["chips"] and pooled["yield"] == local["yield"]
    assert pooled["chips"]["chip_seeds"] == [2, 3, 4]
    assert len(list((tmp_path / "pool" / "tasks").glob("chip-*.json"))) == 3
    again = run_chips(3, protocol, 0.5, first=2, out=tmp_path / "pool", workers=1)  # resumes
    assert again["chips"] == pooled["chips"]


def test_yield_arithmetic():
    assert chip_yield([1.0, 0.95, 0.94, 0.5], 0.95) == 0.5
    assert chip_yield([0.2], 0.0) == 1.0 and chip_yield([0.99], 1.0) == 0.0
    results = [{"chip": c, "success_rate": s, "per_seed": [
        {"seed": 0, "success_rate": s, "e_pos_mean": e, "new_metric": 2.0 * c}]}
        for c, s, e in ((0, 1.0, 0.0), (1, 0.9, 1.0), (2, 0.96, 3.0), (3, 0.5, None))]
    pooled = pool_chips(results, 0.95)
    assert pooled["yield"] == 0.5 and pooled["yield_target"] == 0.95
    dist = pooled["chips"]["distribution"]
    assert dist["new_metric"]["max"] == 6.0  # any per-seed key is pooled
    assert dist["e_pos_mean"]["mean"] == pytest.approx(4.0 / 3)  # None left out
    assert pooled["chips"]["success_rate"]["min"] == 0.5
    assert chip_means([{"seed": 0, "x": 1.0}, {"seed": 1, "x": 3.0}]) == {"x": 2.0}
    nested = [{"seed": s, "weight_error": {"matrix_mean": w, "W_q": None}}
              for s, w in ((0, 0.2), (1, 0.4))]
    assert chip_means(nested) == {"weight_error.matrix_mean": pytest.approx(0.3)}


def test_chips_carry_the_weight_error_distribution():
    pooled = pool_chips([chip_task(c, SMALL) for c in (0, 1)], 0.5)
    dist = pooled["chips"]["distribution"]["weight_error.matrix_mean"]
    assert 0 < dist["min"] <= dist["max"] and dist["min"] != dist["max"]


@pytest.mark.parametrize("n, target", [(0, 0.9), (-1, 0.9), (2, 1.5), (2, -0.1),
                                       (2, float("nan")), (1.5, 0.9)])
def test_bad_input(n, target):
    with pytest.raises(InputError):
        check_chips(n, target)


def test_cli_chips(cli, tmp_path):
    args = ["emulate", "--backend", "crossbar", "--arena", 10, "--walks", 3, "--steps", 60,
            "--trials", 8, "--seeds", 1, "--eval-seed", 5, "--max-steps", 30, "--chips", 2,
            "--workers", 1, "--chips-out", tmp_path / "c", "--json"]
    code, out, err = cli(*args)
    assert code == 0, err
    result = json.loads(out)
    assert result["chips"]["n"] == 2 and 0.0 <= result["yield"] <= 1.0
    assert result["chips"]["per_chip"][0]["success_rate"] == chip_task(0, SMALL)["success_rate"]
    for bad in (["--chips", 0], ["--chips", 2, "--yield-target", 2], ["--workers", 2],
                ["--first-chip", 3], ["--yield-target", 0.9]):
        code, _, err = cli("emulate", "--walks", 1, "--steps", 10, *bad)
        assert code == 2 and err.count("\n") == 1, bad
    assert "--yield-target needs --chips" in err  # the last case: not silently ignored
