"""The memristive crossbar array: device model, statistics, paths, presets, command line.

Statistical tests are seeded (the device stream is counter-based) and compare sample
statistics with the model within a few standard errors.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from cml_edge.backends import array_from_state_dict, make_array
from cml_edge.backends.crossbar.array import CrossbarArray
from cml_edge.backends.crossbar.conductance import prog_sigma
from cml_edge.backends.crossbar.config import PRESETS, DeviceConfig, make_config
from cml_edge.backends.fields import parse_setting
from cml_edge.cli import main
from cml_edge.core.cml import CML, CMLConfig
from cml_edge.grid.arena import GridArena
from cml_edge.grid.metrics import draw_pairs
from cml_edge.grid.planning import plan
from cml_edge.grid.protocol import Protocol, run_protocol
from cml_edge.grid.training import TrainConfig, train

SHAPES = [(256, 2), (8, 256), (256, 8), (3, 5)]
# a device without noise, variation or periphery effects: pulses are exact level steps
CLEAN = dict(update="pulsed", commit="pulse", levels=1001, bounds="hard", dw_min_dtod=0.0,
             dw_min_std=0.0, up_down_dtod=0.0, prog_noise=0.0, out_noise=0.0, read_noise=0.0,
             dac_bits=0, adc_bits=0, drift_nu=0.0, drift_nu_std=0.0, w_max_v=0.0)


def xbar(W, seed=0, index=0, preset="ideal", **fields):
    return make_array("crossbar", np.asarray(W, dtype=np.float64), seed=seed, index=index,
                      preset=preset, **fields)


def in_range(arr):
    c = arr.config
    return all(((g >= c.g_min) & (g <= c.g_max)).all() for g in arr.conductances())


# weights <-> conductances ----------------------------------------------------------------
@pytest.mark.parametrize("shape", SHAPES)
def test_ideal_round_trip_and_exact_reads(shape):
    rng = np.random.default_rng(0)
    W = rng.normal(0, 0.1, shape)
    arr = xbar(W)
    assert arr.w_max == 4 * np.abs(W).max()  # the ideal preset's headroom
    np.testing.assert_allclose(arr.to_float(), W, rtol=0, atol=1e-15)
    assert in_range(arr)
    x, y = rng.normal(size=shape[1]), rng.normal(size=shape[0])
    np.testing.assert_allclose(arr.matvec(x), W @ x, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(arr.rmatvec(y), W.T @ y, rtol=1e-12, atol=1e-14)


@pytest.mark.parametrize("levels", [2, 5, 64, 201])
def test_programming_to_levels_is_within_half_a_step(levels):
    rng = np.random.default_rng(1)
    W = rng.uniform(-0.3, 0.3, (40, 30))
    arr = xbar(W, preset="ideal", levels=levels)
    c = arr.config
    dG = (c.g_max - c.g_min) / (levels - 1)
    for G in arr.conductances():
        k = (G - c.g_min) / dG
        np.testing.assert_allclose(k, np.round(k), atol=1e-9)  # on the grid
    assert np.abs(arr.to_float() - W).max() <= arr.dw_min / 2 + 1e-12
    assert arr.dw_min == pytest.approx(2 * arr.w_max / (levels - 1))


def test_configured_scale_clips_at_programming():
    W = np.array([[0.5, -0.5], [0.01, -0.003]])
    arr = xbar(W, index=2, w_max_v=0.02)
    assert arr.w_max == 0.02 and xbar(W, index=1, w_headroom=1.0).w_max == 0.5
    np.testing.assert_allclose(arr.to_float(), np.clip(W, -0.02, 0.02), atol=1e-16)


def test_state_round_trip_is_exact_and_continues_identically():
    W = np.random.default_rng(2).normal(0, 0.1, (16, 8))
    arr = xbar(W, preset="pcm", index=2, stuck_low=0.05)
    post, pre = np.linspace(-0.1, 0.1, 16), np.linspace(-1, 1, 8)
    arr.outer_update(post, pre, 0.01, defer=True)
    d = arr.state_dict()
    twin = array_from_state_dict(d)
    assert isinstance(twin, CrossbarArray) and twin.options() == arr.options()
    for a, b in zip(map(np.asarray, arr.state), map(np.asarray, twin.state)):
        assert a.dtype == b.dtype and np.array_equal(a, b)
    for a in (arr, twin):
        a.commit()
        a.outer_update(post, pre, 0.01, defer=False)
    assert np.array_equal(arr.matvec(pre), twin.matvec(pre))
    assert np.array_equal(arr.to_float(), twin.to_float())
    d["params"] = d["params"][:-1]
    with pytest.raises(ValueError, match="params"):
        array_from_state_dict(d)


# noise ----------------------------------------------------------------------------------
@pytest.mark.parametrize("preset,w", [("pcm-symmetric", 0.0), ("pcm-symmetric", 0.6),
                                      ("reram-symmetric", -0.4)])
def test_programming_noise_std_matches_the_model(preset, w):
    n = 200
    arr = xbar(np.full((n, n), w), preset=preset, index=0, w_max_q=1.0, levels=0,
               update="analog", commit="program")
    c = make_config(preset)
    g_c, half = 0.5 * (c.g_min + c.g_max), 0.5 * (c.g_max - c.g_min)
    for G, target in zip(arr.conductances(), (g_c + w * half, g_c - w * half)):
        sigma = prog_sigma(target, 1.0, c.prog_c0, c.prog_c1, c.prog_c2, c.prog_gref, c.g_max)
        err = (G - target).ravel()
        se = sigma / math.sqrt(2 * err.size)  # standard error of a sample std
        assert abs(err.std() - sigma) < 4 * se
        assert abs(err.mean()) < 4 * sigma / math.sqrt(err.size)


@pytest.mark.parametrize("kind", ["read_noise", "out_noise"])
def test_read_noise_is_fresh_and_matches_the_model(kind):
    rng = np.random.default_rng(3)
    W = rng.normal(0, 0.1, (64, 16))
    arr = xbar(W, **{kind: 0.05})
    x, y = rng.normal(size=16), rng.normal(size=64)
    reads = np.array([arr.matvec(x) for _ in range(400)])
    treads = np.array([arr.rmatvec(y) for _ in range(400)])
    for samples, v, exact in ((reads, x, W @ x), (treads, y, W.T @ y)):
        xn = v / np.abs(v).max()
        if kind == "read_noise":  # each device N(0, (0.05 range)^2): sqrt(2) 0.05 |x| w_max
            sigma = math.sqrt(2) * 0.05 * np.linalg.norm(xn) * arr.w_max * np.abs(v).max()
        else:
            sigma = 0.05 * arr.w_max * np.abs(v).max()
        dev = samples - exact
        n = dev.size
        assert abs(dev.std() - sigma) < 4 * sigma / math.sqrt(2 * n)
        assert abs(dev.mean()) < 4 * sigma / math.sqrt(n)
        assert not np.array_equal(samples[0], samples[1])  # fresh on every read
    assert arr.counters["matvecs"] == 400 and arr.counters["rmatvecs"] == 400


def test_converters_quantise_inputs_and_outputs():
    W = np.eye(4) * 0.5
    arr = xbar(W, dac_bits=3, adc_bits=4, adc_bound=1.0, w_headroom=1.0)
    # inputs / max|x| on a 3-bit grid (step 1/3), outputs on a 4-bit grid (step 1/7)
    out = arr.matvec(np.array([1.0, 0.5, 0.2, 0.0]))
    xq = np.array([1.0, 2 / 3, 1 / 3, 0.0])
    expected = np.sign(xq) * np.floor(np.abs(xq) * 7 + 0.5) / 7 * 0.5
    np.testing.assert_allclose(out, expected, atol=1e-15)
    big = xbar(np.ones((2, 40)), adc_bits=8, adc_bound=12.0, w_headroom=1.0)
    big.matvec(np.ones(40))
    assert big.counters["adc_saturations"] == 2 and big.counters["adc_conversions"] == 2



@pytest.mark.parametrize("read", ["matvec", "rmatvec"])
def test_adc_clips_both_signs_at_its_bound(read):
    """Outputs of +-20 (normalised) on an ADC of bound 12: both clip, both are counted."""
    W = np.vstack([np.full(40, 0.5), np.full(40, -0.5)])  # rows: +20 and -20 at x = 1
    arr = xbar(W if read == "matvec" else W.T, adc_bits=9, adc_bound=12.0, w_max_q=1.0)
    out = getattr(arr, read)(np.ones(40))
    assert out == pytest.approx([12.0, -12.0])
    assert arr.counters["adc_saturations"] == 2
    inside = xbar(W / 4 if read == "matvec" else W.T / 4, adc_bits=9, adc_bound=12.0,
                  w_max_q=1.0)
    assert getattr(inside, read)(np.ones(40)) == pytest.approx([5.0, -5.0], abs=12 / 255)
    assert inside.counters["adc_saturations"] == 0


@pytest.mark.parametrize("read", ["matvec", "rmatvec"])
def test_read_noise_of_an_output_does_not_depend_on_the_read_length(read):
    """Output o's noise is the o-th normal from the stream's counter, however many
    outputs the read has: short reads draw in order, long ones in one vectorised pass,
    and a read of every length in between gives the first outputs of a long one."""
    def noise(n, counter):  # zero weights: the output is the noise alone (w_max 1, max|x| 1)
        shape = (n, 4) if read == "matvec" else (4, n)
        arr = xbar(np.zeros(shape), out_noise=0.3, w_max_q=1.0)
        arr.state.rng[1] = counter  # the same counter for every shape
        return getattr(arr, read)(np.ones(4))

    for counter in range(0, 12000, 1000):  # ~1.5 % of the words take the slow path
        longest = noise(400, counter)
        assert np.all(longest != 0) and 0.2 < longest.std() < 0.4
        for n in (1, 2, 17, 63, 64, 65, 100, 255, 256, 399):
            np.testing.assert_array_equal(noise(n, counter), longest[:n],
                                          err_msg=f"{n} outputs from counter {counter}")


# the pulsed coincidence update ------------------------------------------------------------
def test_pulsed_update_is_unbiased_with_binomial_counts():
    n, K, lr, z = 48, 300, 0.005, []
    total = 0
    for seed in range(6):
        rng = np.random.default_rng(seed)
        # factors away from zero, so that every count has a mean >= 30 (near-Gaussian z)
        x = rng.choice([-1, 1], n) * rng.uniform(0.5, 1.0, n)
        d = rng.choice([-1, 1], n) * rng.uniform(0.1, 0.2, n)
        arr = xbar(np.zeros((n, n)), seed=seed, w_max_q=1.0, **CLEAN)
        G0 = arr.state.Gp.copy()
        for _ in range(K):
            arr.outer_update(d, x, lr, defer=False)
        dG = (arr.config.g_max - arr.config.g_min) / 1000
        counts = np.rint(np.abs(arr.state.Gp - G0) / dG)  # each coincidence: one level
        dw = arr.to_float()
        total += arr.counters["coincidences"] - counts.sum()
        # E[dw] = K lr x d, and the count of device (i, j) is Binomial(K BL, p_i q_j)
        bl = math.ceil(lr * np.abs(x).max() * np.abs(d).max() / arr.dw_min)
        pq = lr * np.abs(np.outer(d, x)) / (arr.dw_min * bl)
        mean, var = K * bl * pq, K * bl * pq * (1 - pq)
        diag = np.arange(n)  # devices sharing no line are independent
        z.extend((counts[diag, diag] - mean[diag, diag]) / np.sqrt(var[diag, diag]))
        expected_dw = K * lr * np.outer(d, x)
        rel = (dw - expected_dw)[diag, diag] / (arr.dw_min * np.sqrt(var[diag, diag]))
        assert abs(rel.mean()) < 4 / math.sqrt(n)
    assert total == 0  # the counter counts every coincidence
    z = np.array(z)
    assert abs(z.mean()) < 4 / math.sqrt(z.size)
    assert abs(z.var() - 1) < 4 * math.sqrt(2 / z.size)


def test_pulse_trains_are_at_most_bl_max_slots():
    arr = xbar(np.zeros((4, 4)), w_max_q=1.0, **{**CLEAN, "bl_max": 3})
    arr.outer_update(np.ones(4), np.ones(4), 10.0, defer=False)  # wants far more than 3 slots
    assert arr.counters["line_pulses"] == 3 * 8  # every line fires in all 3 slots
    assert arr.counters["coincidences"] == 3 * 16
    np.testing.assert_allclose(arr.to_float(), 3 * arr.dw_min, rtol=1e-9)


def test_accumulate_then_pulse_keeps_the_remainder():
    arr = xbar(np.zeros((3, 2)), w_max_q=1.0, **CLEAN)
    step = arr.dw_min
    post, pre = np.array([1.0, -1.0, 0.1]), np.array([1.0, 0.0])
    arr.outer_update(post, pre, 2.5 * step, defer=True)
    assert np.array_equal(arr.to_float(), np.zeros((3, 2)))  # nothing before commit
    arr.commit()
    np.testing.assert_allclose(arr.to_float()[:, 0], [2 * step, -2 * step, 0.0], atol=1e-12)
    np.testing.assert_allclose(arr.state.acc[:, 0], [0.5 * step, -0.5 * step, 0.25 * step],
                               atol=1e-15)
    assert arr.counters["device_pulses"] == 8 and arr.counters["devices_written"] == 4
    arr.outer_update(post, pre, 2.7 * step, defer=True)
    arr.commit()  # 0.5 + 2.7 = 3.2: three whole steps now
    np.testing.assert_allclose(arr.to_float()[:, 0], [5 * step, -5 * step, 0.0], atol=1e-12)


def test_a_commit_sends_a_pair_at_most_four_sweeps_of_pulses():
    """levels 11: 40 pulses at most; the rest is dropped and counted, the same on the
    reference path."""
    import copy

    from cml_edge.backends.crossbar import reference

    arr = xbar(np.zeros((3, 2)), w_max_q=1.0, **{**CLEAN, "levels": 11})
    post, pre = np.array([1.0, -1.0, 0.02]), np.array([1.0, 0.0])
    arr.outer_update(post, pre, 100.25 * arr.dw_min, defer=True)
    twin = copy.deepcopy(arr.state)
    arr.commit()
    reference.commit(twin)
    np.testing.assert_allclose(arr.to_float()[:, 0], [1.0, -1.0, 2 * arr.dw_min], atol=1e-12)
    assert arr.counters["pulses_capped"] == 2 * (100 - 40)
    assert arr.counters["device_pulses"] == 2 * (40 + 40 + 2)
    np.testing.assert_allclose(arr.state.acc[:, 0], np.array([0.25, -0.25, 0.005]) * arr.dw_min,
                               atol=1e-12)
    for f, g in zip(arr.state, twin):
        assert np.array_equal(f, g)


@pytest.mark.parametrize("grid,moved", [("device", 1.0), ("pair", 1.5)])
def test_program_commit_writes_only_devices_whose_level_moved(grid, moved):
    """1.5 dw_min asked: one step of both devices (``device`` grid), or three levels of
    the pair's difference, dw_min / 2 each (``pair``)."""
    arr = xbar(np.zeros((2, 2)), w_max_q=1.0, pair_grid=grid, **{**CLEAN, "commit": "program"})
    arr.outer_update(np.array([1.0, 0.0]), np.array([1.0, 0.3]), 1.5 * arr.dw_min,
                     defer=True)
    arr.commit()
    assert arr.counters["devices_written"] == 2  # only (0, 0); (0, 1) is below one level
    np.testing.assert_allclose(arr.to_float(), [[moved * arr.dw_min, 0], [0, 0]], atol=1e-12)


finite = st.floats(-2, 2, allow_nan=False, width=64)


@settings(max_examples=30, deadline=None)
@given(st.sampled_from(SHAPES), st.sampled_from(["pcm-symmetric", "reram-symmetric", "ideal",
                                                 "grid"]),
       st.booleans(), st.floats(0.0, 0.3), st.floats(1e-4, 1.0), st.data())
def test_in_place_update_properties(shape, preset, soft, stuck, lr, data):
    """Same buffers, conductances in range, zero factors leave their rows / columns alone."""
    fields = {"stuck_low": stuck / 2, "stuck_high": stuck / 2}
    if preset == "grid":
        preset, fields = "ideal", {**fields, "levels": 17}
    if preset != "ideal":
        fields["bounds"] = "soft" if soft else "hard"
    W = data.draw(arrays(np.float64, shape, elements=finite))
    post = data.draw(arrays(np.float64, shape[0], elements=finite))
    pre = data.draw(arrays(np.float64, shape[1], elements=finite))
    zero_rows, zero_cols = data.draw(arrays(bool, shape[0])), data.draw(arrays(bool, shape[1]))
    post[zero_rows], pre[zero_cols] = 0.0, 0.0
    arr = xbar(W, seed=3, preset=preset, **fields)
    Gp, Gm = arr.state.Gp, arr.state.Gm
    before = [G.copy() for G in (Gp, Gm)]
    stuck_before = arr.state.stuck.copy()
    for _ in range(3):
        arr.outer_update(post, pre, lr, defer=False)
    assert arr.state.Gp is Gp and arr.state.Gm is Gm  # in place
    assert in_range(arr)
    for d, (G, G0) in enumerate(zip((Gp, Gm), before)):
        assert np.array_equal(G[zero_rows], G0[zero_rows])
        assert np.array_equal(G[:, zero_cols], G0[:, zero_cols])
        stuck_mask = stuck_before[d] != 0
        assert np.array_equal(G[stuck_mask], G0[stuck_mask])  # stuck devices never move
    arr.outer_update(post * 50, pre, 1.0, defer=True)  # far past the bounds
    arr.commit()
    arr.elapse(1e4)
    assert in_range(arr)


# faults and drift ------------------------------------------------------------------------
def test_stuck_fraction_is_binomial_and_nested():
    n, lo, hi = 150, 0.07, 0.03
    arr = xbar(np.zeros((n, n)), stuck_low=lo, stuck_high=hi)
    codes = arr.state.stuck
    N = codes.size
    for code, f in ((1, lo), (2, hi)):
        k = int((codes == code).sum())
        assert abs(k - N * f) < 4 * math.sqrt(N * f * (1 - f))
    Gp, Gm = arr.conductances()
    assert (Gp[codes[0] == 1] == 0.0).all() and (Gm[codes[1] == 2] == 25.0).all()
    more = xbar(np.zeros((n, n)), stuck_low=2 * lo, stuck_high=0.0)
    assert ((codes == 1) <= (more.state.stuck == 1)).all()  # same seed: nested fault sets
    other = xbar(np.zeros((n, n)), seed=1, stuck_low=lo, stuck_high=hi)
    assert not np.array_equal(other.state.stuck, codes)


def test_drift_has_log_log_slope_minus_nu_and_compensation_undoes_it():
    W = np.random.default_rng(4).normal(0, 0.1, (20, 10))
    arr = xbar(W, drift_nu=0.06, drift_t0=20.0, w_max_q=1.0)  # no device at g_min = 0
    G0 = arr.state.Gp.copy()
    t, times, ratios = 0.0, [], []
    for dt in (10.0, 90.0, 900.0, 9e3, 9e4, 9e5):
        arr.elapse(dt)
        t += dt
        times.append(math.log((t + 20.0) / 20.0))
        ratios.append(np.log(arr.state.Gp / G0).mean())
    slope = np.polyfit(times, ratios, 1)[0]
    assert slope == pytest.approx(-0.06, abs=1e-9)
    spread = xbar(W, drift_nu=0.06, drift_nu_std=0.02, w_max_q=1.0)
    spread.elapse(1e6)
    per_device = np.log(spread.state.Gp / G0) / math.log((1e6 + 20) / 20)
    nu = spread.state.nu[0]
    np.testing.assert_allclose(per_device, -nu, atol=1e-12)
    assert abs(nu.mean() - 0.06) < 4 * 0.02 / math.sqrt(nu.size)
    comp = xbar(W, drift_nu=0.06, drift_compensation=True, w_max_q=1.0)
    comp.elapse(1e6)
    np.testing.assert_allclose(comp.to_float(), W, atol=1e-14)
    x = np.linspace(-1, 1, 10)
    np.testing.assert_allclose(comp.matvec(x), W @ x, atol=1e-12)


# the two paths and the presets ------------------------------------------------------------
@pytest.mark.parametrize("preset,schedule", [("pcm", "walk"), ("pcm", "step"),
                                             ("reram", "walk"), ("reram", "step")])
def test_reference_and_compiled_paths_are_bit_identical(preset, schedule):
    arena, config = GridArena.empty(8), CMLConfig.for_arena(8)
    pairs = draw_pairs(arena, 8, 5)
    runs = []
    for path in ("reference", "direct"):
        cml = CML.create(config, "crossbar", 3, preset=preset, drift_nu=0.05,
                         stuck_low=0.02, read_noise=0.02)
        errors = train(cml, arena, TrainConfig(walks=3, steps=40, schedule=schedule), 3,
                       path=path)
        for a in cml.arrays:
            a.elapse(100.0)
        res = plan(cml, arena, pairs.starts, pairs.goals, path=path)
        runs.append((errors, [a.state for a in cml.arrays], res, cml.counters()))
    (e1, s1, r1, c1), (e2, s2, r2, c2) = runs
    assert np.array_equal(e1, e2)
    for a, b in zip(s1, s2):
        for f, g in zip(a, b):
            assert np.array_equal(f, g)
    assert np.array_equal(r1.paths, r2.paths) and np.array_equal(r1.steps, r2.steps)
    assert c1 == c2 and c1["rng_draws"] > 0


def test_same_seed_same_run_other_seed_other_devices():
    W = np.random.default_rng(5).normal(0, 0.1, (32, 4))
    a, b, c = xbar(W, preset="pcm"), xbar(W, preset="pcm"), xbar(W, seed=1, preset="pcm")
    x = np.ones(4)
    assert np.array_equal(a.matvec(x), b.matvec(x))
    assert not np.array_equal(a.to_float(), c.to_float())
    d = xbar(W, preset="pcm", index=1)  # another array of the same model: another stream
    assert not np.array_equal(a.to_float(), d.to_float())


@pytest.mark.slow
def test_ideal_trains_to_the_float_metrics():
    kw = dict(seeds=range(2), trials=40, arena_size=12,
              train=TrainConfig(walks=12, steps=300), path="reference", epoch=6)
    ref = run_protocol(Protocol("float", **kw))
    ideal = run_protocol(Protocol("crossbar", backend_options={"preset": "ideal"}, **kw))
    for k in ("success_rate", "e_pos_mean", "overhead_mean"):
        assert ideal[k] == pytest.approx(ref[k], abs=1e-9)
    # the fidelity metrics agree to rounding: weight error ~1e-15, not 0
    fidelity = ("weight_error", "read_snr")
    assert [{k: v for k, v in s.items() if k not in fidelity} for s in ideal["per_seed"]] == \
        [{k: v for k, v in s.items() if k not in fidelity} for s in ref["per_seed"]]
    assert max(s["weight_error"]["matrix_mean"] for s in ideal["per_seed"]) < 1e-12
    np.testing.assert_allclose(ideal["train_error"], ref["train_error"], rtol=1e-9)


def test_presets_are_valid_and_documented():
    for name in PRESETS:
        c = make_config(name)
        assert c == make_config(name, **{})
    pcm = make_config("pcm")
    assert (pcm.g_min, pcm.g_max, pcm.levels, pcm.drift_t0) == (0.0, 25.0, 201, 20.0)
    ideal = make_config("ideal")
    assert ideal.levels == 0 and ideal.prog_noise == 0 and ideal.out_noise == 0


@pytest.mark.parametrize("fields,match", [
    ({"read_noise": -0.1}, "read_noise"), ({"out_noise": -1.0}, "out_noise"),
    ({"prog_noise": -2.0}, "prog_noise"), ({"g_min": 30.0}, "g_min"),
    ({"levels": 1}, "levels"), ({"levels": -4}, "levels"), ({"stuck_low": 1.5}, "stuck_low"),
    ({"stuck_high": -0.1}, "stuck_high"), ({"bogus": 1.0}, "bogus"), ({"bounds": "x"}, "bounds"),
    ({"update": "pulsed", "commit": "program", "levels": 0}, "levels"),
])
def test_bad_configuration_is_a_one_line_value_error(fields, match):
    with pytest.raises(ValueError, match=match) as info:
        make_config("pcm", **fields)
    assert "\n" not in str(info.value)


def test_settings_parse_to_the_field_type():
    def parse(text):
        return parse_setting(DeviceConfig, text, "crossbar")

    assert parse("levels=64") == ("levels", 64)
    assert parse("read_noise = 0.02") == ("read_noise", 0.02)
    assert parse("drift_compensation=on") == ("drift_compensation", True)
    for bad in ("levels=x", "nofield=1", "read_noise"):
        with pytest.raises(ValueError):
            parse(bad)


@pytest.mark.parametrize("argv", [
    ["--set", "read_noise=-0.1"], ["--set", "g_min=30"], ["--levels", "1"],
    ["--set", "stuck_low=2"], ["--preset", "nope"], ["--set", "nofield=3"],
    ["--set", "levels=abc"], ["--levels", "x"],
])
def test_bad_cli_input_exits_2(argv, capsys):
    code = main(["emulate", "--backend", "crossbar", "--seeds", "1", "--walks", "1",
                 "--steps", "5", "--trials", "1", "--json", *argv])
    assert code == 2
    out, err = capsys.readouterr()
    assert out == "" and err.count("\n") == 1 and err.startswith("cml-edge: error:")
