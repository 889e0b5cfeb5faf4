"""The one Gaussian sampler (cml_edge.jit.gauss): the ziggurat's normals, and the block of
them a long read takes in one vectorised pass, the same draws at the same counters."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from cml_edge.jit.gauss import BLOCK_MIN, normal_at, normals
from cml_edge.jit.rng import stream_key


def test_normal_moments_and_tail():
    key = stream_key(3, 9)
    z, ctr = np.zeros(200_000), 0
    for t in range(z.size):
        z[t], ctr = normal_at(key, ctr)
    n = z.size
    assert abs(z.mean()) < 4 / np.sqrt(n)
    assert abs(z.std() - 1) < 4 / np.sqrt(2 * n)
    tail = np.mean(np.abs(z) > 3.6541528853610088)  # the ziggurat's tail layer: 2.58e-4
    assert abs(tail - 2.58e-4) < 4 * np.sqrt(2.58e-4 / n)
    assert n < ctr < 1.03 * n  # ~1.5 % of words take the slow path, which takes more


@settings(max_examples=60, deadline=None)
@given(n=st.integers(0, 400), spare=st.integers(0, 40), start=st.integers(0, 2**40),
       seed=st.integers(0, 2**31))
def test_a_block_is_the_in_order_normals(n, spare, start, seed):
    key = np.uint64(stream_key(seed, 7))
    want = np.zeros(n)
    ctr = np.uint64(start)
    for o in range(n):  # the definition: one normal_at after another
        want[o], ctr = normal_at(key, ctr)
    z = np.full(n + spare, np.nan)  # few spare candidates: the rejections run past them
    end = normals(key, np.uint64(start), z, n, np.zeros((n + spare + 63) // 64, np.int64))
    np.testing.assert_array_equal(z[:n], want)
    assert end == ctr
    assert 1 < BLOCK_MIN < 400  # both sides of the block threshold are drawn
