"""The ``single`` mapping: one device per weight, read against a fixed reference.

The kernels against their reference for this mapping are in
tests/backends/test_references.py (cases ``crossbar-single*``).
"""

from __future__ import annotations

import numpy as np
import pytest

from cml_edge.backends import make_array
from cml_edge.backends.crossbar.codes import REFERENCE
from cml_edge.errors import InputError

CLEAN = dict(update="pulsed", commit="pulse", levels=1001, bounds="hard", dw_min_dtod=0.0,
             dw_min_std=0.0, up_down_dtod=0.0, prog_noise=0.0, out_noise=0.0, read_noise=0.0,
             dac_bits=0, adc_bits=0, drift_nu=0.0, drift_nu_std=0.0, w_max_v=0.0)
W = np.array([[0.3, -0.2, 0.0, 0.7], [0.1, 0.05, -0.4, -0.9], [-1.0, 0.25, 0.6, 0.0]])


def xbar(W, mapping, seed=0, preset="ideal", **fields):
    return make_array("crossbar", np.asarray(W, dtype=np.float64), seed=seed, index=0,
                      preset=preset, mapping=mapping, w_max_q=1.0, **fields)


def test_a_single_device_holds_the_weight_about_an_exact_reference():
    arr = xbar(W, "single", **CLEAN)
    s = arr.state
    assert (s.stuck[1] == REFERENCE).all()
    assert (s.Gm == 0.5 * (s.params.g_min + s.params.g_max)).all()
    # G = the reference + w (g_max - g_min) / 2 w_max: -w_max at g_min, +w_max at g_max
    np.testing.assert_allclose(s.Gp, s.Gm + W * 12.5, atol=1e-12)
    np.testing.assert_allclose(arr.to_float(), W, atol=1e-12)
    np.testing.assert_allclose(arr.matvec(np.array([0.5, -1.0, 0.25, 0.1])),
                               W @ [0.5, -1.0, 0.25, 0.1], atol=1e-12)
    np.testing.assert_allclose(arr.rmatvec(np.array([1.0, -0.5, 0.2])),
                               W.T @ [1.0, -0.5, 0.2], atol=1e-12)


def test_the_weight_step_is_the_pairs_and_only_one_device_moves():
    pair = xbar(np.zeros((3, 4)), "two-sided", **CLEAN)
    arr = xbar(np.zeros((3, 4)), "single", **CLEAN)
    assert arr.dw_min == pair.dw_min
    ref = arr.state.Gm.copy()
    post, pre = np.array([1.0, -1.0, 0.0]), np.array([1.0, 0.5, -1.0, 0.0])
    for a in (arr, pair):
        a.outer_update(post, pre, 0.004, defer=False)
    c, cp = arr.counters, pair.counters
    assert c["device_pulses"] == c["coincidences"] > 0  # one device a coincidence
    assert cp["device_pulses"] == 2 * cp["coincidences"]
    assert (arr.state.Gm == ref).all()
    dw = arr.to_float()
    # each coincidence moves the weight one dw_min, in the direction of post pre
    steps = np.rint(dw / arr.dw_min)
    np.testing.assert_allclose(dw, steps * arr.dw_min, atol=1e-9)
    assert (np.sign(steps) * np.sign(np.outer(post, pre)) >= 0).all()
    assert np.abs(steps).sum() == c["coincidences"]


@pytest.mark.parametrize("update,commit", [("analog", "program"), ("pulsed", "pulse")])
def test_every_write_leaves_the_reference_alone(update, commit):
    arr = xbar(W, "single", preset="reram", update=update, commit=commit, lifetime=20.0,
               drift_nu=0.05, stuck_low=0.1)
    ref = arr.state.Gm.copy()
    rng = np.random.default_rng(1)
    for _ in range(5):
        arr.outer_update(rng.normal(0, 0.3, 3), rng.normal(0, 1.0, 4), 0.05, defer=False)
        arr.outer_update(rng.normal(0, 0.3, 3), rng.normal(0, 1.0, 4), 0.05, defer=True)
        arr.commit()
        arr.elapse(3600.0)
    assert (arr.state.Gm == ref).all()
    assert (arr.state.stuck[1] == REFERENCE).all()
    assert arr.counters["devices_written"] > 0


def test_the_weights_span_the_range_about_the_weight_zero():
    """step_center 0.375 (the reram preset, its bounds not spread): weights from -0.75 to
    1.25 w_max, what the device holds (not clipped at +-w_max)."""
    arr = xbar(np.array([[-2.0, -0.75, 1.0, 2.0]]), "single", preset="reram", prog_noise=0.0,
               write_noise=0.0, read_noise=0.0, bound_dtod_up=0.0, bound_dtod_down=0.0)
    np.testing.assert_allclose(arr.to_float(), [[-0.75, -0.75, 1.0, 1.25]], atol=1e-3)


@pytest.mark.parametrize("field", ["set_only", "refresh"])
def test_a_single_device_refuses_what_needs_a_partner(field):
    with pytest.raises(InputError, match=f"mapping 'single' is not allowed with {field}"):
        xbar(W, "single", **{field: True})
