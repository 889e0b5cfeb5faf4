"""Standard normal deviates from the counter-based stream: the Marsaglia-Tsang ziggurat.

The package's one Gaussian sampler. A normal is drawn from the 64-bit words of a stream
(:func:`cml_edge.jit.rng.word`) at consecutive counters, so, like a uniform, it depends
on nothing but (key, counter): the devices that draw normals (the crossbar's
programming, pulse and read noise, drift) make the same draws in a compiled loop as from
Python, and a reference written as plain loops makes them too.

:func:`normal_at` is the definition: one word gives a layer (bits 0-7), a sign (bit 8)
and, in its top 53 bits, the uniform of ``uniform(key, counter)``; the candidate
x = u ZIG_X[layer] is accepted at once when it lies under the next layer's edge (~98.5 %
of words), and otherwise the slow path (:func:`normal_slow`: the tail beyond r, or the
wedge test, and on rejection a whole new draw) consumes further words until one is
accepted. 256 layers, exact, and ~8x cheaper than Box-Muller.

:func:`normals` gives the same normals at the same counters as calling
:func:`normal_at` one after another, faster for a long block: it takes the fast path of
a run of words in one pass that vectorises (:func:`fast_candidates`), then walks the
candidates run by run up to each rejected word (:func:`next_rejected`), whose slow path,
and the words it consumes, continues the draws at the counter it leaves.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numba.cpython.unsafe.numbers import trailing_zeros

from cml_edge.jit.kernel import kernel
from cml_edge.jit.rng import uniform, unit, word

_ONE = np.uint64(1)

BLOCK_MIN = 64
"""A block of at least this many normals takes the vectorised pass of :func:`normals`; a
shorter one draws in order (the pass would cost more than it saves)."""
BLOCK_PAD = 16
"""Candidates beyond the normals asked for, for the words the slow paths consume (5.6 on
average in a block of 256); past them :func:`normals` draws in order."""


def _ziggurat_tables() -> tuple[np.ndarray, np.ndarray, float]:
    """The layer edges x_i, f(x_i) = exp(-x_i^2 / 2) and the tail's start r (Marsaglia &
    Tsang 2000, 256 layers of equal area v)."""
    n, r, v = 256, 3.6541528853610088, 0.00492867323399
    x = np.zeros(n + 1)
    x[0] = v / math.exp(-0.5 * r * r)
    x[1] = r
    for i in range(2, n):
        x[i] = math.sqrt(-2.0 * math.log(v / x[i - 1] + math.exp(-0.5 * x[i - 1] ** 2)))
    return x, np.exp(-0.5 * x * x), r


ZIG_X, ZIG_F, ZIG_R = _ziggurat_tables()


@njit(cache=True, inline="always")
def candidate(w):
    """The fast path's reading of the word w: (layer i, candidate |z| = x, negative)."""
    i = np.int64(w & np.uint64(255))
    return i, unit(w) * ZIG_X[i], (w >> np.uint64(8)) & _ONE != 0


@kernel
def normal_slow(key, ctr, i, x, negative):
    """The rare branches of :func:`normal_at` for a word of layer i and candidate x it
    rejected, the words from ``ctr`` on: the tail (layer 0) or the wedge test, and on
    rejection the whole draw again, until one is accepted; returns (z, next counter)."""
    while True:
        if i == 0:  # the tail beyond r (Marsaglia 1964)
            while True:
                a = -math.log(1.0 - uniform(key, ctr)) / ZIG_R
                b = -math.log(1.0 - uniform(key, ctr + _ONE))
                ctr += np.uint64(2)
                if b + b > a * a:
                    break
            x = ZIG_R + a
            return (-x if negative else x), ctr
        y = ZIG_F[i] + uniform(key, ctr) * (ZIG_F[i + 1] - ZIG_F[i])
        ctr += _ONE
        if y < math.exp(-0.5 * x * x):
            return (-x if negative else x), ctr
        i, x, negative = candidate(word(key, ctr))
        ctr += _ONE
        if x < ZIG_X[i + 1]:
            return (-x if negative else x), ctr


@kernel
def normal_at(key, ctr):
    """A standard normal from the stream ``key`` at counters ctr, ctr + 1, ...; returns
    (z, the counter after the words it consumed)."""
    i, x, negative = candidate(word(key, ctr))
    ctr += _ONE
    if x < ZIG_X[i + 1]:  # the sign without a branch (a random branch mispredicts)
        return math.copysign(x, 0.5 - negative), ctr
    return normal_slow(key, ctr, i, x, negative)


@kernel
def fast_candidates(key, ctr, z, masks, m):
    """The fast path of :func:`normal_at` for the words at counters ctr .. ctr + m - 1, in
    one pass that vectorises: z[t] is the normal of the word at ctr + t where the fast
    path accepts it, and bit t % 64 of masks[t // 64] is set where it does not (the slow
    path's words). ``masks`` is int64 scratch holding the bits of uint64 words."""
    for b in range((m + 63) >> 6):
        mk = np.uint64(0)
        for u in range(min(m - (b << 6), 64)):
            t = (b << 6) + u
            i, x, negative = candidate(word(key, ctr + np.uint64(t)))
            mk |= np.uint64(not x < ZIG_X[i + 1]) << np.uint64(u)
            z[t] = x - 2.0 * np.float64(negative) * x  # x or -x, exact
        masks[b] = np.int64(mk)


@kernel
def next_rejected(masks, t, limit):
    """The first word at or after t that the fast path rejects, or ``limit`` if none is
    below it."""
    while t < limit:
        b = t >> 6
        rest = np.uint64(masks[b]) >> np.uint64(t & 63)
        if rest != 0:
            return min(t + np.int64(trailing_zeros(rest)), limit)
        t = (b + 1) << 6
    return limit


@kernel
def normals(key, ctr, z, n, masks):
    """z[:n] = the n normals :func:`normal_at` gives one after another from counter
    ``ctr``; returns the counter after them.

    A block of at least :data:`BLOCK_MIN` takes the candidates of up to ``z.shape[0]``
    words (n + :data:`BLOCK_PAD` at most) in one pass, into z itself (``masks``: at least
    one int64 per 64 of them), and moves the accepted ones down into place run by run: a
    normal's candidate never lies before it, so no candidate is overwritten before it is
    read. A rejected word's slow path continues the draws at the counter it leaves, and
    the rest of the block, if the rejections carry it past the candidates, draws in order.
    """
    m = 0
    if n >= BLOCK_MIN:
        m = min(n + BLOCK_PAD, z.shape[0])
        fast_candidates(key, ctr, z, masks, m)
    o = 0  # normals done
    t = 0  # words consumed
    while o < n:
        if t < m:  # a run of accepted candidates (unsigned indices: the copy vectorises)
            e = next_rejected(masks, t, min(t + n - o, m))
            if t != o:
                uo = np.uint64(o)
                ut = np.uint64(t)
                for k in range(np.uint64(e - t)):
                    z[uo + k] = z[ut + k]
            o += e - t
            t = e
            if o == n or t == m:
                continue
            i, x, negative = candidate(word(key, ctr + np.uint64(t)))  # the rejected word
            v, c = normal_slow(key, ctr + np.uint64(t) + _ONE, i, x, negative)
        else:  # in order
            v, c = normal_at(key, ctr + np.uint64(t))
        z[o] = v
        o += 1
        t = np.int64(c - ctr)
    return ctr + np.uint64(t)
