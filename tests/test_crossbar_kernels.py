"""The crossbar's fast read paths (issue 15) against their plain definitions, bit for bit.

A read's analog sums (:func:`_mac`: vector lanes for a short matrix, the DAC's masks for a
sparse input) must be the column-order sums of the plain loop, and its noise
(:func:`_add_noise`: a vectorised pass of candidates) the normals :func:`normal_at` gives
output after output, at the same counters.
"""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from cml_edge.backends.crossbar.kernels import (
    BLOCK_OUTPUTS,
    _add_noise,
    _mac,
    _quantise_inputs,
    normal_at,
)
from cml_edge.rng import stream_key


def column_sums(Gp, Gm, x):
    """W x as the plain loop sums it: each output over the nonzero inputs, in order."""
    out = np.zeros(Gp.shape[0])
    for i in range(Gp.shape[0]):
        s = 0.0
        for j in range(Gp.shape[1]):
            if x[j] != 0.0:
                s += (Gp[i, j] - Gm[i, j]) * x[j]
        out[i] = s
    return out


@settings(max_examples=60, deadline=None)
@given(rows=st.integers(1, 40), cols=st.integers(1, 200), density=st.sampled_from(
    [0.0, 0.005, 0.05, 0.5, 1.0]), nan=st.booleans(), seed=st.integers(0, 2**31))
def test_forward_read_sums_in_column_order(rows, cols, density, nan, seed):
    rng = np.random.default_rng(seed)
    Gp = np.asfortranarray(rng.uniform(0, 25, (rows, cols)))
    Gm = np.asfortranarray(rng.uniform(0, 25, (rows, cols)))
    x = rng.normal(size=cols) * (rng.random(cols) < density)
    if nan:
        x[rng.integers(cols)] = math.nan
    xs = np.zeros(cols)
    nz = np.zeros(cols + rows, np.int64)
    nnz, _ = _quantise_inputs(x, xs, cols, 0.0, 1.0, False, nz)
    assert nnz == np.count_nonzero(xs)
    bits = [(int(nz[j // 64]) >> (j % 64)) & 1 for j in range(cols)]
    assert bits == [int(v != 0.0) for v in xs]  # NaN drives its line
    out = np.zeros(max(rows, cols))
    _mac(Gp, Gm, xs, out, False, nz, nnz)
    np.testing.assert_array_equal(out[:rows], column_sums(Gp, Gm, xs))


@settings(max_examples=60, deadline=None)
@given(n=st.integers(1, 400), spare=st.integers(0, 40), start=st.integers(0, 2**40),
       per_output=st.booleans(), seed=st.integers(0, 2**31))
def test_noise_is_the_in_order_normals(n, spare, start, per_output, seed):
    rng = np.random.default_rng(seed)
    key = np.uint64(stream_key(seed, 7))
    buf = rng.normal(size=n) * 10
    var = rng.random(n) * 3
    sigma, wn, inv_g = 0.06, (0.05 if per_output else 0.0), 0.04
    expected = buf.copy()
    ctr = np.uint64(start)
    for o in range(n):  # the definition: one normal_at after another
        z, ctr = normal_at(key, ctr)
        s = math.sqrt(sigma * sigma + wn * wn * var[o]) if per_output else sigma
        expected[o] = expected[o] * inv_g + s * z
    state = np.array([key, start], dtype=np.uint64)
    zc = np.zeros(n + spare)  # few spare candidates: the rejections run past them
    _add_noise(buf, var, n, inv_g, sigma, wn, state, zc, np.zeros(n + spare + 64, np.int64))
    np.testing.assert_array_equal(buf, expected)
    assert state[1] == ctr


def test_long_reads_take_the_candidate_pass():
    """The property test above covers both sides of the threshold."""
    assert 1 < BLOCK_OUTPUTS < 400
