"""aihwkit's presets by name (``--preset aihwkit:NAME``) without aihwkit: the committed
snapshot, the mapping onto crossbar fields, the physics those fields switch on (each
held to aihwkit's formula and to the readable reference bit for bit), and the refusals."""

from __future__ import annotations

import importlib.util
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from cml_edge.backends.crossbar.aihwkit import snapshot
from cml_edge.backends.crossbar.aihwkit.presets import PREFIX, describe, offered
from cml_edge.backends.crossbar.array import CrossbarArray
from cml_edge.backends.crossbar.codes import AUX_DECAY, AUX_GAMMA_UP, AUX_PLANES, AUX_REF
from cml_edge.backends.crossbar.config import make_config
from cml_edge.errors import InputError


def _references():
    """tests/backends/test_references.py's helpers (loaded by path: tests are no package)."""
    path = Path(__file__).resolve().parents[1] / "test_references.py"
    spec = importlib.util.spec_from_file_location("_crossbar_references", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


REF = _references()
PRESETS = list(snapshot.load()["presets"])

CASES = {
    **{name: {"preset": PREFIX + name} for name in PRESETS},
    # the paths the presets leave off: decay with write noise, a soft device with every
    # extra, the aihwkit refresh with write noise, programming commits (a pulse's step
    # beside a grid of levels)
    "decay-write-noise": {"preset": PREFIX + "CapacitorPresetDevice", "lifetime": 3.0,
                          "lifetime_dtod": 0.5, "write_noise": 2.0, "c2c": "mult"},
    "soft-extras": {"preset": PREFIX + "ReRamArrayOMPresetDevice", "reference_mean": 0.1,
                    "lifetime": 50.0, "up_down": -0.3, "stuck_low": 0.1},
    "refresh-often": {"preset": PREFIX + "PCMPresetUnitCell", "refresh_upper": 0.05,
                      "refresh_lower": 0.01, "write_noise": 3.0, "stuck_high": 0.05},
    "program-commit": {"preset": PREFIX + "EcRamPresetDevice", "commit": "program",
                       "update": "analog"},
    "levels-and-step": {"preset": PREFIX + "EcRamPresetDevice", "commit": "program",
                        "levels": 33, "mapping": "two-sided"},
    "levels-and-step-one-sided": {"preset": PREFIX + "GokmenVlasovPresetDevice",
                                  "commit": "program", "levels": 17},
}
KERNELS = REF.SEAM + REF.CROSSBAR_ONLY
PAIRS = [(case, kernel) for case in CASES for kernel in KERNELS]


@pytest.mark.parametrize(("case", "kernel"), PAIRS, ids=[f"{c}:{k}" for c, k in PAIRS])
@settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.too_slow,
                                                                 HealthCheck.data_too_large])
@given(data=st.data())
def test_kernel_agrees_with_its_reference(case, kernel, data):
    """test_references.py's check on every preset and the paths above."""
    rows, cols = data.draw(REF.shapes(24), "shape")
    seed = data.draw(st.integers(0, 2**20), "seed")
    W = np.random.default_rng(seed).normal(0.0, 0.1, (rows, cols))
    arr = CrossbarArray.from_float(W, seed=seed, index=data.draw(st.integers(0, 2)),
                                   **CASES[case])
    for step in data.draw(st.lists(st.sampled_from(["update", "accumulate", "commit"]),
                                   max_size=3), "history"):
        if step == "commit":
            arr.commit()
        else:
            arr.outer_update(data.draw(REF.vectors(rows)), data.draw(REF.vectors(cols)),
                             data.draw(st.sampled_from(REF.LRS)), step == "accumulate")
    if kernel in ("matvec", "rmatvec"):
        args = (data.draw(REF.vectors(cols if kernel == "matvec" else rows)),)
    elif kernel in ("update", "accumulate"):
        args = (data.draw(REF.vectors(rows), "post"), data.draw(REF.vectors(cols), "pre"),
                data.draw(st.sampled_from(REF.LRS), "lr"), kernel == "accumulate")
    elif kernel == "sigmoid":
        args = (data.draw(REF.vectors(5)),)
    elif kernel == "elapse":
        args = (100.0,)
    elif kernel == "program":
        arr.state.rng[1] = 0
        args = (W,)
    else:
        arr.outer_update(data.draw(REF.vectors(rows)), data.draw(REF.vectors(cols)),
                         data.draw(st.sampled_from(REF.LRS)), True)
        args = ()
    fast, slow = REF.copied(arr.state), REF.copied(arr.state)
    got = REF.fast_kernel(kernel, fast, args)
    want = REF.slow_kernel(REF.reference_of(arr), kernel, slow, args)
    if kernel in ("matvec", "rmatvec", "sigmoid"):
        assert REF.same_bits(got, want), f"{case} {kernel}: outputs"
    REF.assert_agree(fast, slow, REF.reference_of(arr).SCRATCH, f"{case} {kernel}")


# the snapshot and the names ---------------------------------------------------------------
def test_every_preset_of_the_snapshot_runs_and_is_offered_once():
    assert snapshot.load()["aihwkit"] == "1.1.0" and snapshot.load()["command"] == \
        snapshot.COMMAND
    assert len(PRESETS) == 11 and "PCMPresetUnitCell" in PRESETS
    assert offered() == [PREFIX + n for n in PRESETS]  # each once, all of them
    rng = np.random.default_rng(0)
    for name in PRESETS:
        arr = CrossbarArray.from_float(rng.normal(0, 0.1, (6, 3)), seed=1, index=0,
                                       preset=PREFIX + name)
        before = arr.to_float().copy()
        arr.outer_update(np.full(6, 0.5), np.ones(3), 0.5, False)
        assert not np.array_equal(arr.to_float(), before), name
        assert np.isfinite(arr.to_float()).all(), name


def test_a_refused_parameter_is_named_and_its_preset_not_offered(monkeypatch):
    snap = snapshot.load()
    odd = dict(snap["presets"]["GokmenVlasovPresetDevice"])
    odd["fields"] = dict(odd["fields"], diffusion=0.01)
    monkeypatch.setattr(snapshot, "load", lambda: {
        **snap, "presets": {**snap["presets"], "DiffusingPresetDevice": odd}})
    assert PREFIX + "DiffusingPresetDevice" not in offered()
    with pytest.raises(InputError, match=r"diffusion 0\.01 \(the project has no per-mini-"):
        make_config(PREFIX + "DiffusingPresetDevice")


@pytest.mark.parametrize(("name", "words"), [
    ("OneSidedUnitCell", "unit-cell class OneSidedUnitCell, not a preset: it holds 0 devices"),
    ("ConstantStepDevice", "device class ConstantStepDevice with its defaults, not a preset"),
    ("NoSuchDevice", "aihwkit 1.1.0 has no preset 'NoSuchDevice'")])
def test_a_name_that_is_no_preset_is_refused_in_one_line(cli, name, words):
    code, out, err = cli("device", "characterize", "--preset", PREFIX + name, "--devices", "2")
    assert code == 2 and out == "" and err.count("\n") == 1, err
    assert words in err and f"allowed: {', '.join(offered())})" in err


def test_a_preset_runs_by_name_without_aihwkit(cli, monkeypatch, tmp_path):
    from cml_edge.backends.crossbar.aihwkit import runner

    monkeypatch.setenv(runner.VENV_VARIABLE, str(tmp_path / "none"))
    code, out, err = cli("device", "characterize", "--preset",
                         PREFIX + "ReRamArrayHfO2PresetDevice", "--devices", "20", "--json")
    assert code == 0, err
    import json

    r = json.loads(out)
    assert r["config"]["pulse_step"] == pytest.approx(0.4622 / 2) and r["pulses"]


# the mapping --------------------------------------------------------------------------------
def test_every_parameter_is_mapped_or_inert():
    for name in PRESETS:
        d = describe(PREFIX + name)
        params = snapshot.load()["presets"][name]["fields"]
        assert set(d["mapped"]) | set(d["inert"]) >= set(params), name
        assert not set(d["mapped"]) & set(d["inert"]), name


def test_the_mapping_reads_aihwkit_s_own_parameters():
    hfo2 = make_config(PREFIX + "ReRamArrayHfO2PresetDevice")
    assert (hfo2.levels, hfo2.step_model, hfo2.c2c, hfo2.scale_spread, hfo2.bound_spread) == \
        (0, "soft", "add", "lognormal", "aihwkit")
    assert hfo2.pulse_step == pytest.approx(0.2311) and hfo2.write_noise == 0.5841
    assert hfo2.reference_std == pytest.approx(0.025) and hfo2.subtract_symmetry_point
    assert hfo2.apply_write_noise_on_set and not hfo2.write_noise_clip
    ecram = make_config(PREFIX + "EcRamPresetDevice")
    assert (ecram.step_model, ecram.gamma_up, ecram.gamma_down, ecram.gamma_up_dtod,
            ecram.mean_bound_reference, ecram.c2c) == ("linear", 0.1153, 0.5085, 0.05, True,
                                                        "mult")
    assert ecram.step_center == pytest.approx(0.8276 / 2)
    es = make_config(PREFIX + "ReRamESPresetDevice")
    assert (es.up_down, es.exp_a, es.exp_b, es.c2c, es.scale_spread) == (0.259359, -0.5, -0.5,
                                                                         "mult", "add")
    assert es.pulse_gain == pytest.approx(0.0019914355554687332 / 0.00135)
    cap = make_config(PREFIX + "CapacitorPresetDevice")
    assert (cap.lifetime, cap.lifetime_dtod, cap.c2c) == (1e6, 0.3, "add")
    cell = make_config(PREFIX + "PCMPresetUnitCell")
    assert (cell.set_only, cell.refresh, cell.refresh_write, cell.set_noise) == \
        (True, True, "aihwkit", "gauss")
    assert cell.refresh_read_noise == pytest.approx(0.1 / 2)  # out_noise 0.1 of 0..2
    assert cell.refresh_read_step == pytest.approx(2 * 20 / 510 / 2)
    assert (cell.reset, cell.reset_dtod, cell.reset_std) == pytest.approx((0.005, 0.01, 0.005))
    assert describe(PREFIX + "PCMPresetUnitCell")["map"] == {"w_min": 0.0, "w_max": 2.0}


# the physics the mapping switches on, against aihwkit's formulas --------------------------
def _column(name: str, g: float, n: int = 20_000, **fields) -> CrossbarArray:
    config = make_config(PREFIX + name, **fields)
    w = (g - config.g_min) / (config.g_max - config.g_min)
    return CrossbarArray.from_float(np.full((n, 1), w), seed=3, index=0, preset=PREFIX + name,
                                    w_max_q=1.0, **fields)


def test_bounds_spread_as_populate_draws_them_without_a_floor():
    arr = _column("ReRamArrayHfO2PresetDevice", 12.5)  # w in -1..1 onto 0..25 uS: G0 12.5
    lo, hi = arr.state.bnd[0, :, 0], arr.state.bnd[1, :, 0]
    z = np.random.default_rng(0).normal(size=1_000_000)
    for got, d in ((hi - 12.5, 0.4295), (12.5 - lo, 0.599)):  # 12.5 |1 + d z| either way
        assert got.mean() == pytest.approx(12.5 * np.abs(1 + d * z).mean(), rel=0.01)
    assert (lo < 0).mean() == pytest.approx(np.mean(np.abs(1 + 0.599 * z) > 1), abs=0.01)


@pytest.mark.parametrize(("spread", "gain_mean"), [("add", 1.0), ("lognormal", None)])
def test_step_scales_spread_as_populate_draws_them(spread, gain_mean):
    arr = _column("ReRamESPresetDevice", 12.5, scale_spread=spread)  # up_down 0.259
    up, down = arr.state.step[0, :, 0], arr.state.step[1, :, 0]
    mean = gain_mean if gain_mean is not None else math.exp(0.2 ** 2 / 2)
    assert up.mean() == pytest.approx(mean, rel=0.01)  # up_down > 0: the up scale intact
    assert down.mean() == pytest.approx(mean - 0.259359, rel=0.01)  # the down one shrunk
    assert (up - down).std() == pytest.approx(2 * 0.05, rel=0.03)  # 2 up_down_dtod


def test_a_step_that_does_not_divide_the_range_and_exact_programming():
    arr = _column("ReRamArrayHfO2PresetDevice", 12.5, dw_min_dtod=0.0, dw_min_std=0.0,
                  up_down_dtod=0.0, reference_std=0.0, subtract_symmetry_point=False,
                  write_noise=0.0, bound_dtod_up=0.0, bound_dtod_down=0.0)
    assert (arr.state.Gp == 12.5).all()  # no grid: programmed exactly
    arr.state.acc[:] = arr.dw_min * (1 + 1e-9)
    arr.commit()  # one pulse at G0: the full step, 0.4622 of w's 2 onto 25 uS
    assert arr.state.Gp[:, 0] == pytest.approx(12.5 + 0.4622 / 2 * 25)


def test_linear_slopes_per_device_on_the_nominal_bounds():
    arr = _column("EcRamPresetDevice", 12.5)
    k = AUX_PLANES * 0
    gu = arr.state.aux[k + AUX_GAMMA_UP, :, 0]
    z = np.random.default_rng(0).normal(size=1_000_000)
    assert gu.mean() == pytest.approx(np.abs(0.1153 + 0.05 * z).mean(), rel=0.01)
    assert gu.std() == pytest.approx(np.abs(0.1153 + 0.05 * z).std(), rel=0.03)
    # mean_bound_reference: at g_max the up step is 1 - gamma of the scale, own bound or not
    quiet = dict(dw_min_std=0.0, dw_min_dtod=0.0, up_down_dtod=0.0, gamma_up_dtod=0.0,
                 bound_dtod_up=0.0, bound_dtod_down=0.0)
    top = _column("EcRamPresetDevice", 25.0, n=50, **quiet)
    top.state.bnd[1] = 30.0  # a device whose own upper bound lies past g_max
    top.state.acc[:] = top.dw_min * (1 + 1e-9)
    top.commit()
    assert top.state.Gp[:, 0] == pytest.approx(25.0 + 0.002 / 2 * 25 * (1 - 0.1153))


def test_a_reference_device_past_its_bound_steps_back():
    arr = _column("ReRamArrayOMPresetDevice", 25.0, reference_std=0.0,
                  subtract_symmetry_point=False, reference_mean=0.1, dw_min_std=0.0,
                  write_noise=0.0)
    k = AUX_PLANES * 0
    assert (arr.state.aux[k + AUX_REF] == 0.1 * 25).all()
    hi = arr.state.bnd[1, :, 0]
    at_bound = arr.state.Gp[:, 0] == hi  # programmed at its bound: internal state past it
    arr.state.acc[:] = arr.dw_min * (1 + 1e-9)
    arr.commit()
    moved = arr.state.Gp[:, 0] - hi
    assert at_bound.mean() > 0.4 and (moved[at_bound] < 0).all()  # an up pulse, down


def test_reference_and_symmetry_point_as_populate_draws_them():
    arr = _column("ReRamArrayOMPresetDevice", 12.5, up_down_dtod=0.0)
    ref = arr.state.aux[AUX_REF, :, 0]  # equal scales: no symmetry point, the reference
    assert ref.mean() == pytest.approx(0.0, abs=0.01) and ref.std() == pytest.approx(
        0.05 / 2 * 25, rel=0.03)


def test_decay_each_mini_batch_toward_the_weight_zero():
    arr = _column("CapacitorPresetDevice", 20.0, n=10, lifetime=10.0, lifetime_dtod=0.0)
    assert (arr.state.aux[AUX_DECAY] == 0.9).all()
    for _ in range(3):
        arr.commit()  # a mini-batch with nothing to write still decays
    assert arr.state.Gp[:, 0] == pytest.approx(12.5 + 7.5 * 0.9 ** 3)


def test_write_noise_on_programming_is_an_offset_on_the_target():
    arr = _column("ReRamESPresetDevice", 12.5)
    G, wn = arr.state.Gp[:, 0], arr.state.wn[0, :, 0]
    assert (G - wn == pytest.approx(12.5)) and wn.std() == pytest.approx(
        75.0 * 0.00135 / 2 * 25, rel=0.03)


def test_aihwkit_refresh_resets_to_the_bias_and_writes_the_read_difference():
    n = 4000
    W = np.full((n, 1), 0.9)
    arr = CrossbarArray.from_float(W, seed=2, index=0, preset=PREFIX + "PCMPresetUnitCell",
                                   w_max_q=1.0, refresh_read_noise=0.0, reset_dtod=0.0,
                                   reset_std=0.0, bound_dtod_up=0.0)
    arr.state.Gm[:] = 0.5 * 25.0  # a saturated pair: G+ 0.9, G- 0.5 of the range
    arr.commit()  # a mini-batch (nothing to write), then the refresh
    assert arr.counters["refreshes"] == n
    assert (arr.state.Gm == 0.005 * 25.0).all()  # the reset bias, 0.01 of w's 2
    step = 2 * 20 / 510 / 2 * 25.0  # the refresh read's ADC step, uS
    D = round(0.4 * 25.0 / step) * step
    gran = make_config(PREFIX + "PCMPresetUnitCell").pulse_gain * 0.005 * 25.0
    pulses = arr.counters["refresh_pulses"] / n - 2  # SET pulses a pair, on average
    assert pulses == pytest.approx(D / gran, rel=0.03)  # aihwkit's update management


def test_a_saved_aihwkit_preset_restores_bit_for_bit():
    arr = _column("PCMPresetUnitCell", 20.0, n=12)
    arr.outer_update(np.full(12, 0.3), np.ones(1), 0.5, False)
    back = CrossbarArray.from_state_dict(arr.state_dict())
    assert REF.same_bits(back.to_float(), arr.to_float())
    assert REF.same_bits(back.state.aux, arr.state.aux)
