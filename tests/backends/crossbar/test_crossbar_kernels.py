"""The crossbar read's fast paths against the plain sums of its reference, bit for bit.

A read's analog sums (:func:`~cml_edge.backends.crossbar.read._mac`: vector lanes for a
short matrix and for the eight partial sums of a transposed read, the DAC's masks for a
sparse input, in either memory layout) must be the sums
:mod:`cml_edge.backends.crossbar.reference` writes as plain loops, and the DAC's masks and
sum of squares what their definitions say. The whole read, noise included, is held to
the reference in ``tests/backends/test_references.py``.
"""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from cml_edge.backends.crossbar.read import _mac, _quantise_inputs
from cml_edge.backends.crossbar.reference import column_order, eight_lanes, steps_of


@settings(max_examples=60, deadline=None)
@given(rows=st.integers(1, 40), cols=st.integers(1, 200), density=st.sampled_from(
    [0.0, 0.005, 0.05, 0.5, 1.0]), nan=st.booleans(), order=st.sampled_from("FC"),
       dac=st.sampled_from([0.0, 1 / 127]), seed=st.integers(0, 2**31))
def test_forward_read_sums_in_column_order(rows, cols, density, nan, order, dac, seed):
    rng = np.random.default_rng(seed)
    Gp = np.array(rng.uniform(0, 25, (rows, cols)), order=order)
    Gm = np.array(rng.uniform(0, 25, (rows, cols)), order=order)
    x = rng.normal(size=cols) * (rng.random(cols) < density)
    if nan:
        x[rng.integers(cols)] = math.nan
    xs = np.zeros(cols)
    driven = np.zeros((cols + 63) // 64, np.int64)
    nnz, sq = _quantise_inputs(x, xs, cols, dac, 0.5, True, driven)
    if dac:
        q = [steps_of(v * 0.5, dac) * dac for v in x]
        assert np.array_equal(xs, q, equal_nan=True)
    assert nnz == np.count_nonzero(xs)
    total = 0.0
    for v in xs:  # the sum of squares in index order, zeros included
        total += v * v
    assert sq == total or (math.isnan(sq) and math.isnan(total))
    bits = [(int(driven[j // 64]) >> (j % 64)) & 1 for j in range(cols)]
    assert bits == [int(v != 0.0) for v in xs]  # NaN drives its line
    out = np.zeros(max(rows, cols))
    _mac(Gp, Gm, xs, out, False, driven, nnz)
    W = Gp - Gm
    np.testing.assert_array_equal(out[:rows], [column_order(W[i], list(xs))
                                               for i in range(rows)])


@settings(max_examples=40, deadline=None)
@given(rows=st.integers(1, 100), cols=st.integers(1, 12), order=st.sampled_from("FC"),
       seed=st.integers(0, 2**31))
def test_transposed_read_sums_in_eight_lanes(rows, cols, order, seed):
    rng = np.random.default_rng(seed)
    Gp = np.array(rng.uniform(0, 25, (rows, cols)), order=order)
    Gm = np.array(rng.uniform(0, 25, (rows, cols)), order=order)
    y = rng.normal(size=rows) * (rng.random(rows) < 0.8)
    out = np.zeros(max(rows, cols))
    _mac(Gp, Gm, y, out, True, np.zeros((rows + 63) // 64, np.int64), 0)
    W = Gp - Gm
    np.testing.assert_array_equal(out[:cols], [eight_lanes(W[:, o], list(y))
                                               for o in range(cols)])
