"""The contract every registered synaptic array keeps (cml_edge/backends/README.md).

:func:`cml_edge.backends.check_device` holds each registered device to it (parametrised
over the registry, so a newly registered device is held to it with no edit here), and
``counting``, a tiny device defined in this file that declares a knob, a cost model and
report entries, is registered with one call and shown to be picked up everywhere: the
contract, the break-point finder, the report's systems and break points, the ledger, and
``cml-edge`` itself (train and evaluate). The rules (:mod:`cml_edge.backends.contract`):

- an update changes the weights by lr post pre^T (in expectation: noisy and quantised
  devices must correlate strongly with it and match its size; an update that does
  nothing fails), in place or deferred to ``commit``;
- a zero factor changes nothing in its row or column, and all-zero factors nothing at all;
- ``state_dict`` round trips exactly (also through a ``.npz``), and the restored array
  continues bit for bit;
- the Python-level methods and the compiled seam (an ``@njit`` loop calling ``sa_*``) give
  the same bits, states and counters for the same seed;
- counters are non-negative, never decrease, and count one per call of ``matvec``,
  ``rmatvec``, ``outer_update`` and ``commit``;
- the config refuses bad values naming the field; the declared knobs set fields and their
  ranges are valid; the cost model reads counters the array keeps.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, replace
from types import SimpleNamespace
from typing import Any, NamedTuple

import numpy as np
import pytest
from numba import njit

from cml_edge.backends import (
    BACKENDS,
    DEVICES,
    Backend,
    CostModel,
    DeviceContractError,
    DeviceSpec,
    Knob,
    Report,
    array_from_state_dict,
    check_device,
    make_array,
    register_device,
    report_systems,
    unregister_device,
)
from cml_edge.backends.base import SynapticArray
from cml_edge.backends.dispatch import Kernels
from cml_edge.backends.fields import check_types, option, resolve
from cml_edge.backends.params import build_record, kernel_record
from cml_edge.core.cml import CML, CMLConfig
from cml_edge.core.model_file import load_model
from cml_edge.costs import ledger
from cml_edge.errors import InputError


# the test device: a float64 array that counts the weights it reads ------------------------
@dataclass(frozen=True)
class CountingConfig:
    """The test device's one field."""

    lr_scale: float = option(1.0, flag="--lr-scale", metavar="F",
                             help="factor on every learning rate (the counting test device)")
    """Factor on every learning rate; the kernels read it from the parameter record."""

    def __post_init__(self) -> None:
        check_types(self, "counting ")
        if self.lr_scale < 0:
            raise InputError(f"counting lr_scale {self.lr_scale!r} is negative (allowed: >= 0)")


CountingParams = kernel_record(CountingConfig, "CountingParams", __name__, derived={})


class CountingState(NamedTuple):
    W: np.ndarray  # (rows, cols) float64 weights
    acc: np.ndarray  # (rows, cols) update accumulated until commit
    params: CountingParams
    counters: np.ndarray  # int64[5]: CountingArray.counter_names


@njit
def counting_matvec(state, x, out):
    W = state.W
    for i in range(W.shape[0]):
        s = 0.0
        for j in range(W.shape[1]):
            s += W[i, j] * x[j]
        out[i] = s
    state.counters[0] += 1
    state.counters[4] += W.size


@njit
def counting_rmatvec(state, y, out):
    W = state.W
    for j in range(W.shape[1]):
        s = 0.0
        for i in range(W.shape[0]):
            s += W[i, j] * y[i]
        out[j] = s
    state.counters[1] += 1
    state.counters[4] += W.size


@njit
def counting_outer_update(state, post, pre, lr, defer):
    target = state.acc if defer else state.W
    rate = lr * state.params.lr_scale
    for i in range(target.shape[0]):
        for j in range(target.shape[1]):
            target[i, j] += rate * post[i] * pre[j]
    state.counters[2] += 1


@njit
def counting_commit(state):
    for i in range(state.W.shape[0]):
        for j in range(state.W.shape[1]):
            state.W[i, j] += state.acc[i, j]
            state.acc[i, j] = 0.0
    state.counters[3] += 1


@njit
def counting_sigmoid(state, z, out):
    for i in range(z.shape[0]):
        out[i] = 1.0 / (1.0 + math.exp(-z[i]))


class CountingArray(SynapticArray):
    name = "counting"
    State = CountingState
    counter_names = ("matvecs", "rmatvecs", "outer_updates", "commits", "weight_reads")

    @classmethod
    def from_float(cls, W: np.ndarray, *, seed: int = 0, index: int = 0,
                   **options: Any) -> CountingArray:
        config = resolve(CountingConfig, {}, options, "counting")
        W = np.array(W, dtype=np.float64)
        return cls(cls.State(W, np.zeros_like(W), build_record(CountingParams, config),
                             np.zeros(len(cls.counter_names), np.int64)))

    def options(self) -> dict[str, Any]:
        return {"lr_scale": self.state.params.lr_scale}

    @property
    def config(self) -> CountingConfig:
        return CountingConfig(self.state.params.lr_scale)

    def to_float(self) -> np.ndarray:
        return self.state.W.copy()


def _returning(kernel, rows):
    def read(state, v):
        out = np.zeros(state.W.shape[0 if rows else 1])
        kernel.py_func(state, v, out)
        return out

    return read


COUNTING_REFERENCE = SimpleNamespace(  # the readable reference: the kernels as plain Python
    matvec=_returning(counting_matvec, True), rmatvec=_returning(counting_rmatvec, False),
    outer_update=counting_outer_update.py_func, commit=counting_commit.py_func,
    sigmoid=lambda state, z: np.array([1.0 / (1.0 + math.exp(-v)) for v in z]), SCRATCH=())


COUNTING = DeviceSpec(
    array_class=CountingArray,
    kernels=Kernels(counting_matvec, counting_rmatvec, counting_outer_update, counting_commit,
                    counting_sigmoid),
    config_class=CountingConfig,
    backends={"counting": Backend("test device: float64 weights that count their reads")},
    knobs=(Knob("lr_scale", "lr_scale", 0.0, 1.0, "high",
                doc="factor on every learning rate (0: no learning)"),),
    # each weight read a float MAC; no bytes or pulses counted
    cost=CostModel("counting", "fp32_mac", ("weight_reads",)),
    report=Report(systems=("counting",), breakpoints=(("counting", ("lr_scale",)),)),
    plain=COUNTING_REFERENCE,
)


@pytest.fixture
def counting():
    """The test device, registered (one call) for the test and removed after it."""
    register_device(COUNTING)
    try:
        yield COUNTING
    finally:
        unregister_device(COUNTING)


# the contract, on every registered device ----------------------------------------------------
@pytest.mark.parametrize("name", list(DEVICES))
def test_every_registered_device_keeps_the_contract(name):
    check_device(name)


def test_a_device_declared_in_one_folder_is_picked_up_with_one_registry_line(counting,
                                                                             monkeypatch):
    """Registered with one call and nothing else: the contract holds, the break-point
    finder finds and sweeps its knob, the report runs it and its break point, the ledger
    prices its counters."""
    from cml_edge.report.scorecard import Breakpoint, ScorecardPlan
    from cml_edge.scenarios import breakpoint

    check_device(counting)
    knob = breakpoint.get_knob("lr_scale", "counting")
    assert knob is counting.knobs[0] and "lr_scale" in breakpoint.knob_names()
    assert list(breakpoint.knobs_of("counting")) == ["lr_scale", "drift_time"]
    grid = breakpoint.knob_grid(knob, knob.lo, knob.hi)
    assert grid[0] == 1.0 and grid[-1] == 0.0 and len(grid) == breakpoint.GRID_POINTS

    def run_scenario(scenario, backend, options, *args, **kwargs):  # success = lr_scale
        assert backend == "counting"
        return {"scenario": scenario,
                "parts": [{"part": "all", "success_rate": options["lr_scale"]}]}

    monkeypatch.setattr(breakpoint, "run_scenario", run_scenario)
    found = breakpoint.find_breakpoint("paper", "counting", "lr_scale", target=0.5, seeds=2)
    assert found["value"] == 0.5 and found["bracket"] == [0.5, 0.4375]
    assert found["field"] == "lr_scale" and found["n_evaluations"] <= 6

    plan = ScorecardPlan.of(quick=False)
    assert ("counting", "counting", {}) in report_systems() and \
        ("counting", "counting", {}) in plan.devices
    assert Breakpoint("counting", "counting", {}, "lr_scale") in plan.breakpoints

    cml = CML.create(CMLConfig.for_arena(8), "counting", 0)
    cml.W_q.matvec(np.ones(cml.W_q.shape[1]))
    reads = cml.counters()["weight_reads"]
    assert reads == cml.W_q.state.W.size
    assert ledger.technology(cml) == "counting"
    energy, sources = ledger.energy_pj(ledger.cost_model(cml), cml.counters())
    assert energy == reads * ledger.COSTS["fp32_mac"].pj and sources == [
        ledger.COSTS["fp32_mac"].source]


# what check_device refuses ----------------------------------------------------------------
class BrokenState(NamedTuple):  # a state class of its own: compiled loops key on it
    W: np.ndarray
    acc: np.ndarray
    params: CountingParams
    counters: np.ndarray


@njit
def wrong_sign_outer_update(state, post, pre, lr, defer):
    target = state.acc if defer else state.W
    for i in range(target.shape[0]):
        for j in range(target.shape[1]):
            target[i, j] -= lr * post[i] * pre[j]
    state.counters[2] += 1


class BrokenArray(CountingArray):
    name = "broken"
    State = BrokenState


BROKEN = replace(COUNTING, array_class=BrokenArray, backends={"broken": Backend("broken")},
                 kernels=COUNTING.kernels._replace(outer_update=wrong_sign_outer_update),
                 report=Report())


@pytest.mark.parametrize("change, message", [
    ({}, r"device 'broken' \(broken, 24 x 12\) breaks the update rule: in place: the change "
         r"correlates -1\.000"),
    ({"kernels": COUNTING.kernels, "knobs": (Knob("gain", "gain", 0.0, 1.0, "low"),)},
     r"device 'broken' breaks the knobs rule: knob 'gain' sets 'gain', which is no field"),
    ({"kernels": COUNTING.kernels, "knobs": (Knob("lr_scale", "lr_scale", -1.0, 1.0, "low"),)},
     r"knobs rule: knob 'lr_scale' at -1\.0 .* not valid on broken: counting lr_scale -1\.0 "
     r"is negative"),
    ({"kernels": COUNTING.kernels, "cost": CostModel("fp32", "fp32_mac", ("macs",))},
     r"breaks the cost model rule: cost model 'fp32' of broken reads macs, which the array "
     r"does not count"),
])
def test_check_device_names_the_device_and_the_broken_rule(change, message):
    """A spec that is not registered is registered for the check and removed after it."""
    with pytest.raises(DeviceContractError, match=message):
        check_device(replace(BROKEN, **change))
    assert "broken" not in DEVICES and "broken" not in BACKENDS
    with pytest.raises(InputError, match="unknown device 'nope'"):
        check_device("nope")


# a new device: registered with one call, then the command line runs on it ---------------------
SMALL = ["--arena", "8", "--walks", "2", "--steps", "30"]


def test_a_device_registered_with_one_call_trains_and_evaluates(counting, cli, tmp_path):
    """The reference path: the compiled loops are cached on disk, and a cached loop must
    not name a class that only this test module defines."""
    model = tmp_path / "counting.npz"
    code, out, err = cli("train", "--backend", "counting", "--lr-scale", "0.5", *SMALL,
                         "--path", "reference", "--out", model, "--json")
    assert code == 0, err
    trained = json.loads(out)
    assert trained["backend"] == "counting"
    assert trained["counters"]["weight_reads"] > 0 and trained["counters"]["commits"] == 3 * 2
    cml, record = load_model(model)
    assert record["backend_options"] == {"lr_scale": 0.5}
    assert cml.W_q.options() == {"lr_scale": 0.5} and isinstance(cml.W_q, CountingArray)
    code, out, err = cli("evaluate", model, "--trials", 5, "--path", "reference", "--json")
    assert code == 0, err
    result = json.loads(out)
    assert result["backend"] == "counting" and result["trials"] == 5
    # its options are its own: refused for another backend, validated before training
    code, _, err = cli("train", "--backend", "float", "--lr-scale", "2", *SMALL, "--out",
                       tmp_path / "x.npz")
    assert code == 2 and "--lr-scale is an option of the counting arrays" in err
    code, _, err = cli("train", "--backend", "counting", "--set", "lr_scale=-1", *SMALL,
                       "--out", tmp_path / "x.npz")
    assert code == 2 and "counting lr_scale -1.0 is negative" in err
    assert not (tmp_path / "x.npz").exists()


def test_an_unregistered_device_is_gone(counting, cli, tmp_path):
    unregister_device(counting)
    try:
        code, _, err = cli("train", "--backend", "counting", *SMALL, "--out", tmp_path / "x.npz")
        assert code == 2 and "unknown backend 'counting'" in err
        with pytest.raises(ValueError, match="unknown array kind 'counting'"):
            array_from_state_dict(make_array("float", np.ones((2, 2)), seed=0, index=0)
                                  .state_dict() | {"__backend__": np.array("counting")})
    finally:
        register_device(counting)  # the fixture removes it again


def test_a_device_without_a_cost_model_is_not_costed(counting):
    unregister_device(counting)
    try:
        register_device(replace(counting, cost=None))
        cml = CML.create(CMLConfig.for_arena(8), "counting", 0)
        assert ledger.technology(cml) == ledger.NOT_COSTED
        assert ledger.energy_pj(ledger.cost_model(cml), cml.counters()) == (None, [])
        unregister_device("counting")
        register_device(replace(counting, cost=CostModel("pcm-like", "pcm_mac", ("matvecs",))))
        with pytest.raises(InputError, match="cost model 'pcm-like' names 'pcm_mac', which is "
                                             "no sourced constant"):
            ledger.energy_pj(ledger.cost_model(cml), cml.counters())
    finally:
        unregister_device("counting")
        register_device(counting)


def test_every_registered_device_has_a_cost_model():
    for name, spec in BACKENDS.items():
        cml = CML.create(CMLConfig.for_arena(8), name, 0)
        assert ledger.technology(cml) != ledger.NOT_COSTED, name
        assert spec.device is DEVICES[cml.W_q.name]


def test_per_matrix_options_are_declared_and_take_one_value_per_matrix():
    assert DEVICES["fixed"].per_matrix == {"weight_exp": ("weight_exp",)}
    assert DEVICES["crossbar"].per_matrix == {"w_max": ("w_max_q", "w_max_k", "w_max_v")}
    assert DEVICES["float"].per_matrix == {}
    W = np.full((4, 3), 0.01)
    for index, e in enumerate((-7, -6, -5)):
        assert make_array("int8", W, seed=0, index=index, weight_exp=[-7, -6, -5]).exponent == e
        assert make_array("int8", W, seed=0, index=index, weight_exp=-6).exponent == -6
        w_max = make_array("crossbar", W, seed=0, index=index, w_max_q=0.1, w_max_k=0.2,
                           w_max_v=0.3).w_max
        assert w_max == (0.1, 0.2, 0.3)[index]
