"""Counter-based random numbers keyed by (seed, stream, counter), usable inside Numba.

The functions have explicit uint64 signatures, so Python ints of any size up to 2^64
and compiled int64 counters reach the same code.

The draws of training and exploration (grid and robot), the robot's evaluation goals,
stochastic rounding and device noise are ``uniform(stream_key(seed, stream), counter)``:
a SplitMix64 output at position ``counter`` of the sequence keyed by (seed, stream). Such
a draw depends on nothing but those three numbers, so the Python reference path and the
compiled fast path, which call these same functions, make bit-identical draws, and a run
is reproducible from its seed whatever order its pieces are computed in. The few draws
that use NumPy generators instead (the CML's initial weights, the grid's evaluation pairs
and obstacles, the DQN's evaluation starts) are listed in :mod:`cml_edge.protocol`.
Standard normals are drawn from these words by :mod:`cml_edge.jit.gauss`.
"""

from __future__ import annotations

import numpy as np
from numba import njit

_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_M1 = np.uint64(0xBF58476D1CE4E5B9)
_M2 = np.uint64(0x94D049BB133111EB)
_TWO_M53 = 1.0 / 9007199254740992.0


@njit("uint64(uint64)", cache=True)
def mix64(z):
    """SplitMix64 finaliser: a bijective avalanche of a uint64."""
    z = np.uint64(z)
    z = (z ^ (z >> np.uint64(30))) * _M1
    z = (z ^ (z >> np.uint64(27))) * _M2
    return z ^ (z >> np.uint64(31))


@njit("uint64(uint64, uint64)", cache=True)
def stream_key(seed, stream):
    """The key of stream ``stream`` of run ``seed`` (both non-negative integers)."""
    return mix64(mix64(np.uint64(seed) + _GOLDEN) ^ (np.uint64(stream) * _GOLDEN))


@njit("uint64(uint64, uint64)", cache=True)
def word(key, counter):
    """The raw 64-bit word at position ``counter`` of stream ``key``."""
    return mix64(np.uint64(key) + np.uint64(counter) * _GOLDEN)


@njit("float64(uint64)", cache=True)
def unit(z):
    """A 64-bit word as a float64 on [0, 1) (its top 53 bits)."""
    return float(z >> np.uint64(11)) * _TWO_M53


@njit("float64(uint64, uint64)", cache=True)
def uniform(key, counter):
    """A float64 uniform on [0, 1) at position ``counter`` of stream ``key``."""
    return unit(word(key, counter))


@njit("int64(uint64, uint64, int64)", cache=True)
def randint(key, counter, n):
    """An integer uniform on [0, n)."""
    i = int(uniform(key, counter) * n)
    return i if i < n else n - 1
