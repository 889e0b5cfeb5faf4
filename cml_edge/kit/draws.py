"""The random numbers a kit device draws: ``uniform(rng)`` and ``normal(rng)``.

``rng`` is the array's stream, the ``uint64[2]`` (key, next counter) its functions are
given: the key is ``stream_key(seed, STREAM_DEVICE + index)`` (:mod:`cml_edge.protocol`:
index 0, 1, 2 for W_q, W_k, W_v), and each draw takes the words at the counter and moves
it on. So a draw depends only on the seed, the matrix and how many words were drawn
before it: the compiled kernels and the readable reference (the same loops run as plain
Python) make the same draws, and a seed fixes every bit. Both functions are compiled and
callable from Python alike; ``normal`` is the package's one Gaussian sampler
(:func:`cml_edge.jit.gauss.normal_at`), ``uniform`` takes one word
(:func:`cml_edge.jit.rng.uniform`).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from cml_edge.jit.gauss import normal_at
from cml_edge.jit.rng import uniform as uniform_at

_ONE = np.uint64(1)


@njit(cache=True)
def uniform(rng):
    """A float uniform on [0, 1) from the stream ``rng``, which it moves on by one word."""
    u = uniform_at(rng[0], rng[1])
    rng[1] += _ONE
    return u


@njit(cache=True)
def normal(rng):
    """A standard normal from the stream ``rng``, which it moves past the words it took
    (one, rarely more)."""
    z, ctr = normal_at(rng[0], rng[1])
    rng[1] = ctr
    return z
