"""emulate's hardware budget (cml_edge.costs.budget): the training's own counters (the
curve's plans taken out), the plane against the volume, and the command's JSON."""

import json

import pytest

from cml_edge.costs.budget import converge_steps, protocol_costs
from cml_edge.grid.protocol import Protocol, run_protocol
from cml_edge.grid.training import TrainConfig
from cml_edge.report.build import measure_operations

TRAIN = TrainConfig(3, 100)


def _costs(backend, dims=2, **kw):
    p = Protocol(backend, (0,), 5, train=TRAIN, epoch=1, dims=dims, **kw)
    records = []
    result = run_protocol(p, records=records)
    return {**result, "costs": protocol_costs(p, records, result["curve_e_pos_mean"])}


def test_the_training_s_traffic_leaves_the_curve_out():
    costs = _costs("int8")["costs"]
    ops = measure_operations("int8", {}, trials=5, walks=3, steps=100)
    tc = ops["train_counters"]
    assert costs["update_bytes_per_run_direct"] == tc["bytes_read"] + tc["bytes_written"]
    assert costs["energy_per_run_uj"] == pytest.approx(ops["energy_train_pj"] / 1e6, rel=1e-12)
    assert costs["parameters"] == ops["parameters"] == 4608


def test_the_volume_costs_more_than_the_plane_on_every_figure():
    two, three = _costs("int8")["costs"], _costs("int8", dims=3)["costs"]
    assert (two["parameters"], three["parameters"]) == (4608, 14080)
    assert three["parameter_bytes"] / two["parameter_bytes"] == 14080 / 4608
    for key in ("train_bytes_direct", "update_bytes_per_run_direct", "energy_per_run_uj",
                "energy_per_action_nj", "inference_flops_formula"):
        assert three[key] > two[key], key
    assert (two["technology"], two["weight_bits"]) == ("int8", 8)


def test_a_crossbar_moves_pulses_and_float64_is_not_costed():
    xbar = _costs("crossbar", backend_options={"preset": "pcm"})["costs"]
    assert xbar["device_pulses_per_run"] > 0 and xbar["energy_per_run_uj"] > 0
    f64 = _costs("float")["costs"]
    assert f64["device_pulses_per_run"] is None and f64["energy_per_run_uj"] is None
    assert f64["energy_per_action_nj"] is None and f64["cells_changed_per_run"] > 0


def test_steps_to_converge():
    assert converge_steps([5.0, 3.0, 0.2, 0.1], 900) == 3 * 900
    assert converge_steps([0.1, 0.1], 900) == 900
    assert converge_steps([], 900) is None


def test_emulate_prints_its_costs(cli):
    code, out, _ = cli("emulate", "--dims", 3, "--seeds", 1, "--trials", 4, "--walks", 2,
                       "--steps", 50, "--backend", "int8", "--json")
    data = json.loads(out)
    assert code == 0 and data["costs"]["parameters"] == 14080
    assert data["costs"]["steps_to_converge_resolution"] == 10 * 50
    code, out, _ = cli("emulate", "--seeds", 1, "--trials", 4, "--walks", 2, "--steps", 50,
                       "--backend", "int8")
    assert code == 0 and "parameters          4,608 (4.61 kB at 8 bits)" in out
