"""The device against its float64 twin: weight error, decision agreement, read SNR."""

import json
from dataclasses import replace

import numpy as np
import pytest

from cml_edge.core.cml import CML, CMLConfig
from cml_edge.core.fidelity import read_snr, seed_stats, weight_error
from cml_edge.grid.arena import GridArena
from cml_edge.grid.fidelity import decision_agreement, float_twin
from cml_edge.grid.metrics import draw_pairs
from cml_edge.grid.protocol import Protocol, run_protocol
from cml_edge.grid.seed_run import Evaluation, Training, run_fidelity, train_and_evaluate
from cml_edge.grid.training import TrainConfig, train

CONFIG = TrainConfig(walks=6, steps=120)


def _run(backend="float", planner="paper", obstacles=0, schedule="walk", **options):
    arena = GridArena.empty(12)
    config = TrainConfig(CONFIG.walks, CONFIG.steps, schedule=schedule)
    training = Training(arena, config, CMLConfig.for_arena(12), backend, options, "direct")
    ev_arena = GridArena.with_obstacles(12, obstacles, 5) if obstacles else arena
    ev = Evaluation(ev_arena, draw_pairs(ev_arena, 20, 5), 40, planner)
    run = train_and_evaluate(3, training, [ev])
    return run, training, ev


@pytest.mark.parametrize("planner,obstacles,schedule",
                         [("paper", 0, "walk"), ("escape", 40, "walk"), ("paper", 0, "step")])
def test_a_float64_device_is_its_own_twin(planner, obstacles, schedule):
    run, training, ev = _run(planner=planner, obstacles=obstacles, schedule=schedule)
    (fid,) = run_fidelity(run, training, [ev])
    assert max(fid["weight_error"].values()) < 1e-12
    # the replay reproduces every decision of the device's own planner, escape included
    assert fid["decision_agreement"] == 1.0 and fid["decisions"] == int(run.results[0].steps.sum())
    # the same arithmetic as the twin's: no read SNR to give (not a ratio to rounding)
    assert all(v is None for k, v in fid["read_snr"].items() if k != "reads")


def test_a_different_twin_disagrees():
    run, training, ev = _run()
    other = float_twin(4, training.arena, training.config, training.cml_config)
    same, total = decision_agreement(other, ev.arena, ev.pairs.goals, run.results[0], "paper",
                                     ev.max_steps)
    assert total > 0 and same < total
    assert weight_error(run.cml, other)["W_q"] > 0.1


def test_weight_error_by_hand():
    a, b = CML.create(seed=0), CML.create(seed=1)
    err = weight_error(a, b)
    Wa, Wb = a.W_k.to_float(), b.W_k.to_float()
    assert err["W_k"] == pytest.approx(np.linalg.norm(Wa - Wb) / np.linalg.norm(Wb))
    assert err["matrix_mean"] == pytest.approx(np.mean([err[m] for m in ("W_q", "W_k", "W_v")]))


def test_read_snr_falls_as_read_noise_grows_and_leaves_the_device_untouched():
    states = [(np.array([0.1 * i - 0.3, 0.2]), np.array([0.25, -0.1 * i])) for i in range(8)]
    snr = {}
    for noise in (0.02, 0.2):
        cml = CML.create(CMLConfig(), "crossbar", 0, preset="ideal", read_noise=noise)
        before = (cml.counters(), [a.state.rng.copy() for a in cml.arrays])
        snr[noise] = read_snr(cml, states)
        assert cml.counters() == before[0]
        assert all((a.state.rng == r).all() for a, r in zip(cml.arrays, before[1]))
    for m in ("W_q", "W_k", "W_v"):
        assert 0 < snr[0.2][m] < snr[0.02][m] / 3
    assert snr[0.02]["reads"] == 8


def test_metrics_add_keys_and_change_no_number():
    protocol = Protocol("crossbar", range(2), 10, 10, train=CONFIG,
                        backend_options={"preset": "pcm-symmetric"})
    plain = run_protocol(replace(protocol, fidelity=False))
    full = run_protocol(protocol)
    for key, value in plain.items():
        if key == "per_seed":
            for a, b in zip(value, full["per_seed"]):
                assert {k: b[k] for k in a} == a
        elif key != "wall_time_s":
            assert full[key] == value, key
    assert set(full) - set(plain) == {"weight_error", "decision_agreement", "read_snr",
                                      "fidelity_twin"}
    da = full["decision_agreement"]
    assert da["n"] == 2 and da["mean"] == pytest.approx(
        np.mean([s["decision_agreement"] for s in full["per_seed"]]))
    assert full["weight_error"]["matrix_mean"]["mean"] > 0
    json.dumps(full, allow_nan=False)


def test_seed_stats():
    assert seed_stats([1.0, 3.0]) == {"mean": 2.0, "std": pytest.approx(2 ** 0.5), "min": 1.0,
                                      "max": 3.0, "n": 2}
    assert seed_stats([5.0])["std"] == 0.0
    assert seed_stats([2.0, None])["mean"] is None  # an infinite SNR among them


def test_more_walks_continue_the_seeds_streams():
    arena, cfg = GridArena.empty(10), CMLConfig.for_arena(10)
    one = CML.create(cfg, "float", 2)
    train(one, arena, TrainConfig(6, 80), 2, path="factored")
    two = CML.create(cfg, "float", 2)
    train(two, arena, TrainConfig(4, 80), 2, path="factored")
    errors = train(two, arena, TrainConfig(2, 80), 2, path="factored", first_walk=4)
    assert len(errors) == 2
    for a, b in zip(one.arrays, two.arrays):
        assert np.array_equal(a.to_float(), b.to_float())


def test_evaluate_reports_the_metrics(tmp_path, cli):
    model = tmp_path / "m.npz"
    assert cli("train", "--arena", 10, "--walks", 4, "--steps", 80, "--backend", "int8",
               "--out", model)[0] == 0
    code, out, _ = cli("evaluate", model, "--trials", 10, "--json")
    data = json.loads(out)
    assert code == 0 and data["decision_agreement"]["n"] == 1
    assert 0 < data["weight_error"]["W_v"]["mean"] < 2
    assert data["read_snr"]["W_q"]["mean"] > 1


@pytest.mark.parametrize("device", [[], ["--backend", "crossbar", "--preset", "pcm"]])
def test_robot_train_takes_device_options_and_evaluate_reports_the_metrics(tmp_path, cli,
                                                                         device):
    model = tmp_path / "r.npz"
    code, out, _ = cli("robot", "train", *device, "--walks", 3, "--steps", 60, "--seeds", 2,
                       "--out", model, "--json")
    assert code == 0 and json.loads(out)["backend_options"] == (
        {"preset": "pcm"} if device else {})
    code, out, _ = cli("robot", "evaluate", model, "--trials", 5, "--json")
    data = json.loads(out)
    assert code == 0 and data["decision_agreement"]["n"] == 2
    assert all("decision_agreement" in s for s in data["per_seed"])
    if device:
        assert 0.05 < data["weight_error"]["matrix_mean"]["mean"] < 2
        assert data["read_snr"]["W_q"]["mean"] < 1e4
    else:  # float64 is its own twin
        assert data["weight_error"]["matrix_mean"]["max"] == 0
        assert data["decision_agreement"]["min"] == 1.0


def test_read_snr_is_null_where_the_device_reads_as_its_twin():
    states = [(np.array([0.1 * i - 0.3, 0.2]), np.array([0.25, -0.1 * i])) for i in range(8)]
    for backend, options in (("float", {}), ("crossbar", {"preset": "ideal"})):
        snr = read_snr(CML.create(CMLConfig(), backend, 0, **options), states)
        assert [snr[m] for m in ("W_q", "W_k", "W_v")] == [None] * 3, backend
    for backend, options in (("float32", {}), ("crossbar", {"preset": "pcm"}), ("int8", {})):
        snr = read_snr(CML.create(CMLConfig(), backend, 0, **options), states)
        assert all(0 < snr[m] < 1e12 for m in ("W_q", "W_k", "W_v")), (backend, snr)
    assert seed_stats([None, 3.0]) == {"mean": None, "std": None, "min": 3.0, "max": None,
                                       "n": 2}
