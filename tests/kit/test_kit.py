"""The device kit: a device from a few scalar functions (cml_edge.kit.Device), its generated
loops compiled and as plain Python, its validation, and the tutorial's devices."""

from __future__ import annotations

import importlib
import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from cml_edge.backends import (
    DeviceContractError,
    array_from_state_dict,
    check_device,
    register_device,
    unregister_device,
)
from cml_edge.errors import InputError
from cml_edge.kit import Device, KitArray, Tolerance, codegen, normal, option, uniform

EXAMPLES = ("ternary", "noisy", "ecram")


def example(name):
    return importlib.import_module(f"cml_edge.kit.examples.{name}").DEVICE


@dataclass(frozen=True)
class Gain:
    """A test device's two numbers, which differ so that a swap shows."""

    up: float = option(1.25, lo=0.0, hi=4.0, why="a gain")
    """Gain on an increase."""
    down: float = option(0.75, lo=0.0, hi=4.0, why="a gain")
    """Gain on a decrease."""


def gain_write(p, w, dw):
    return w + (p.up if dw > 0 else p.down) * dw


@pytest.fixture
def gain():
    spec = Device("gain-test", Gain, write=gain_write)
    register_device(spec)
    yield spec
    unregister_device(spec)


@pytest.mark.parametrize("name", EXAMPLES)
def test_the_tutorials_devices_keep_the_contract(name):
    check_device(example(name))


def test_a_write_of_each_sign_takes_its_own_field(gain):
    arr = gain.array_class.from_float(np.zeros((3, 2)), seed=0, index=1)
    arr.outer_update(np.array([1.0, -1.0, 0.0]), np.array([0.5, 2.0]), 0.125, defer=False)
    assert np.array_equal(arr.to_float(), [[0.078125, 0.3125], [-0.046875, -0.1875], [0, 0]])
    assert arr.counters["weight_writes"] == 4 and arr.counters["outer_updates"] == 1
    # deferred: nothing until commit, then one write per nonzero cell of the sum
    arr.outer_update(np.array([1.0, 0.0, 0.0]), np.array([1.0, 0.0]), 0.125, defer=True)
    assert arr.to_float()[0, 0] == 0.078125 and arr.counters["acc_writes"] == 1
    arr.commit()
    assert arr.to_float()[0, 0] == 0.078125 + 0.15625 and arr.counters["weight_writes"] == 5
    assert arr.state.params.matrix == 1 and arr.state.params.w_scale == 1.0
    # programming is a write from 0: each weight with its sign's gain
    assert np.array_equal(gain.array_class.from_float(np.array([[2.0, -2.0]]), seed=0,
                                                      index=0).to_float(), [[2.5, -1.5]])


def test_reads_skip_zero_lines_and_count_the_products():
    W = np.arange(6.0).reshape(3, 2) - 2.5
    arr = Device("exact-test").array_class.from_float(W, seed=0, index=0)
    assert np.array_equal(arr.matvec(np.array([0.0, 2.0])), W @ [0.0, 2.0])
    assert np.array_equal(arr.rmatvec(np.array([1.0, 0.0, -1.0])), W.T @ [1.0, 0.0, -1.0])
    assert arr.counters["macs"] == 3 + 2 * 2  # 1 line of 3, then 2 lines of 2
    assert arr.state.params.w_scale == 2.5


def test_a_seed_fixes_every_bit_and_chips_differ():
    spec = example("ecram")
    W = np.random.default_rng(0).normal(0, 0.1, (12, 5))

    def run(seed):
        arr = spec.array_class.from_float(W, seed=seed, index=2)
        for k in range(3):
            arr.outer_update(np.linspace(-1, 1, 12), np.linspace(1, -1, 5), 0.05,
                             defer=k % 2 == 0)
            arr.commit()
        arr.elapse(600.0)
        return arr.to_float()

    assert np.array_equal(run(3), run(3))
    assert not np.array_equal(run(3), run(4))
    assert spec.chips_differ(spec.make_config())
    assert not Device("exact-test").chips_differ(None)  # no function draws


def test_the_compiled_kernels_and_the_reference_run_one_text():
    module = example("ternary").plain
    compiled = [n for n in vars(module) if n.startswith("_k_")]
    plain = [n for n in vars(module) if n.startswith("_p_")]
    assert sorted(n[3:] for n in compiled) == sorted(n[3:] for n in plain)
    assert module.__file__.startswith(str(codegen.kit_folder()))
    text = Path(module.__file__).read_text()
    # update and commit, each in storage order of a tall and of a wide matrix
    assert text.count("_jwrite(p, W[i, j], dw, rng)") == 4
    assert text.count("_uwrite(p, W[i, j], dw, rng)") == 4
    assert "_jwrite(p, 0.0, Wf[i, j], rng)" in text  # programming: a write from 0


def _overflowing_write(p, w, dw):
    n = 9223372036854775807  # int64's largest: Python's ints go on, Numba's wrap
    return w + dw + (0.0 if n + 1 < 0 else 1e-3)


def test_the_reference_rule_catches_arithmetic_python_and_numba_disagree_on():
    spec = Device("wraps-test", write=_overflowing_write,
                  tolerance=Tolerance(0.0, (0.0, 10.0), why="a test of the reference rule"))
    with pytest.raises(DeviceContractError, match=r"breaks the reference rule: call 3, "
                       r"outer_update: state field 'W' differs .* compiled, .* reference"):
        check_device(spec)


def test_an_update_rule_failure_says_how_far_and_what_to_declare():
    def backwards(p, w, dw):
        return w - dw

    with pytest.raises(DeviceContractError, match=r"breaks the update rule: in place: the "
                       r"change correlates -1\.000 with lr post pre\^T, 1\.800 short of the "
                       r"0\.8 required .*tolerance=Tolerance"):
        check_device(Device("backwards-test", write=backwards))


@pytest.mark.parametrize("kwargs, message", [
    ({"name": "Bad Name"}, "device name 'Bad Name' is not a lower-case name"),
    ({"write": lambda p, w, delta: w}, r"write function <lambda> asks for 'delta'; a write "
                                       r"function takes some of: p, w, dw, cell, rng, i, j"),
    ({"read": lambda p, w, *rest: w}, "asks for 'rest'"),
    ({"cell": lambda p, rng: (1.0,)}, "a cell function and cell_fields come together"),
    ({"cell_fields": ("gain",)}, "a cell function and cell_fields come together"),
    ({"constants": {"rows": np.ones(2)}}, "constant name 'rows' is taken"),
    ({"constants": {"table": np.array([1.0, np.nan])}}, "constant 'table' holds NaN"),
    ({"weight_bits": 0}, "weight_bits 0 is not 1..64"),
    ({"config": int}, "config <class 'int'> is not a dataclass"),
    ({"presets": {"big": {"up": 9.0}}}, r"gain-x up 9\.0 is outside its range 0..4"),
])
def test_a_bad_declaration_is_one_line(kwargs, message):
    kwargs = {"name": "gain-x", "config": Gain, **kwargs}
    with pytest.raises(InputError, match=message) as err:
        Device(kwargs.pop("name"), kwargs.pop("config"), **kwargs)
    assert "\n" not in str(err.value)


def test_a_config_that_is_not_frozen_is_refused():
    @dataclass
    class Loose:
        x: float = 1.0

    with pytest.raises(InputError, match="config Loose is not frozen"):
        Device("loose", Loose)


@pytest.mark.parametrize("options, message", [
    ({"up": float("nan")}, "gain-test up nan is not a finite number"),
    ({"down": -1.0}, r"gain-test down -1\.0 is outside its range 0..4 \(a gain\)"),
    ({"sideways": 1.0}, "unknown gain-test field 'sideways'"),
])
def test_the_config_is_checked_by_type_and_range(gain, options, message):
    with pytest.raises(InputError, match=message):
        gain.array_class.from_float(np.ones((2, 2)), **options)


def test_a_kit_array_round_trips_through_its_state_dict(gain):
    arr = gain.array_class.from_float(np.eye(3, 2), seed=0, index=0, up=2.0)
    arr.outer_update(np.ones(3), np.ones(2), 0.1, defer=True)
    d = arr.state_dict()
    assert json.loads(str(d["__options__"])) == {"up": 2.0, "down": 0.75}
    twin = array_from_state_dict(d)
    assert isinstance(twin, KitArray) and twin.config == arr.config
    twin.commit()
    arr.commit()
    assert np.array_equal(twin.to_float(), arr.to_float())
    d["__options__"] = np.array(json.dumps({"up": 3.0, "down": 0.75}))
    with pytest.raises(InputError, match="saved gain-test parameters .* differ"):
        array_from_state_dict(d)


def test_the_random_streams_are_the_packages():
    from cml_edge.jit.gauss import normal_at
    from cml_edge.jit.rng import uniform as uniform_at

    rng = np.array([12345, 7], dtype=np.uint64)
    u = uniform(rng)
    assert u == uniform_at(12345, 7) and rng[1] == 8
    z = normal(rng)
    assert (z, rng[1]) == normal_at(12345, 8)


def test_the_vocabulary_table_of_the_tutorial_is_the_kits():
    page = (Path(__file__).resolve().parents[2] / "docs" / "your-device.md").read_text()
    for kind, args in codegen.ARGS.items():
        row = next(line for line in page.splitlines() if line.startswith(f"| `{kind}` |"))
        named = row.split("|")[3]
        assert [a.strip(" `") for a in named.split(",")] == list(args), kind


def test_presets_are_named_configurations_with_their_own_tolerance(cli, tmp_path):
    from cml_edge.backends import configurations, make_array

    spec = Device("gain-presets", Gain, write=gain_write,
                  presets={"even": {"up": 1.0, "down": 1.0}, "skewed": {"up": 2.0}},
                  tolerance={"skewed": Tolerance(0.8, (0.6, 2.2), why="its up steps are "
                                                 "twice as large as asked")})
    register_device(spec)
    try:
        assert configurations(["gain-presets"]) == [
            ("gain-presets-even", "gain-presets", {"preset": "even"}),
            ("gain-presets-skewed", "gain-presets", {"preset": "skewed"})]
        arr = make_array("gain-presets", np.zeros((2, 2)), seed=0, index=0, preset="skewed")
        assert arr.config.up == 2.0 and arr.config.down == 0.75
        assert spec.tolerance_of({"preset": "skewed"}).why.startswith("its up steps")
        assert spec.tolerance_of({"preset": "even"}).correlation == 0.8
        check_device(spec)
        code, _, err = cli("train", "--backend", "gain-presets", "--preset", "nope",
                           "--arena", 8, "--walks", 1, "--steps", 10, "--out",
                           tmp_path / "m.npz")
        assert code == 2 and "unknown gain-presets preset 'nope'" in err
    finally:
        unregister_device(spec)
