"""The crossbar's fast read paths against their plain definitions, bit for bit.

A read's analog sums (:func:`_mac`: vector lanes for a short matrix and for the eight
partial sums of a transposed read, the DAC's masks for a sparse input) must be the sums of
the plain loops, and its noise
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
from cml_edge.jit.rng import stream_key


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
    nz = np.zeros(cols + rows, np.int64)
    nnz, sq = _quantise_inputs(x, xs, cols, dac, 0.5, True, nz)
    if dac:
        q = np.copysign(np.floor(np.abs(x * 0.5) * (1.0 / dac) + 0.5), x) * dac
        assert np.array_equal(xs, q, equal_nan=True) or not np.isfinite(x).all()
    assert nnz == np.count_nonzero(xs)
    total = 0.0
    for v in xs:  # the sum of squares in index order, zeros included
        total += v * v
    assert sq == total or (math.isnan(sq) and math.isnan(total))
    bits = [(int(nz[j // 64]) >> (j % 64)) & 1 for j in range(cols)]
    assert bits == [int(v != 0.0) for v in xs]  # NaN drives its line
    out = np.zeros(max(rows, cols))
    _mac(Gp, Gm, xs, out, False, nz, nnz)
    np.testing.assert_array_equal(out[:rows], column_sums(Gp, Gm, xs))


def lane_sums(Gp, Gm, y):
    """W^T y as the plain loop sums it: eight interleaved partial sums per output, the
    rows left over into the first, then ((s0 + s1) + (s2 + s3)) + ((s4 + s5) + (s6 + s7))."""
    rows, cols = Gp.shape
    out = np.zeros(cols)
    for o in range(cols):
        s = [0.0] * 8
        k = 0
        while k + 8 <= rows:
            for lane in range(8):
                s[lane] += (Gp[k + lane, o] - Gm[k + lane, o]) * y[k + lane]
            k += 8
        while k < rows:
            s[0] += (Gp[k, o] - Gm[k, o]) * y[k]
            k += 1
        out[o] = ((s[0] + s[1]) + (s[2] + s[3])) + ((s[4] + s[5]) + (s[6] + s[7]))
    return out


@settings(max_examples=40, deadline=None)
@given(rows=st.integers(1, 100), cols=st.integers(1, 12), order=st.sampled_from("FC"),
       seed=st.integers(0, 2**31))
def test_transposed_read_sums_in_eight_lanes(rows, cols, order, seed):
    rng = np.random.default_rng(seed)
    Gp = np.array(rng.uniform(0, 25, (rows, cols)), order=order)
    Gm = np.array(rng.uniform(0, 25, (rows, cols)), order=order)
    y = rng.normal(size=rows) * (rng.random(rows) < 0.8)
    out = np.zeros(max(rows, cols))
    _mac(Gp, Gm, y, out, True, np.zeros(rows + cols, np.int64), 0)
    np.testing.assert_array_equal(out[:cols], lane_sums(Gp, Gm, y))


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
