"""The yardstick of ``cml-edge bench``: the float64 step hand-fused, with no seam.

:class:`FusedLearner` and :class:`FusedScorer` are plug-ins of the same training and
planning loops (:func:`cml_edge.grid.training.train_loop`,
:func:`cml_edge.grid.planning.plan_loop`) whose step is one plain Numba function on the
raw float64 weights: no state tuple, no counters, no work vectors beyond the two it
needs, the reads and the three updates (Eqs. 1-3) fused into as few passes as the data
dependencies allow. It does the same float64 arithmetic as the ``direct`` path on a
float64 :class:`~cml_edge.backends.floating.array.FloatArray` (the summation orders of
:mod:`cml_edge.backends.floating.kernels`: W_q's reads as sums of columns with zero inputs
skipped, W_k's rows in eight interleaved partial sums, W_v^T's columns in index order),
so the weights it learns and the plans it makes are bit-identical to the direct path's
(tests/bench/test_bench.py), and the bench's ratio direct / fused is what the seam costs.
The per-walk schedule only (the protocol's): updates accumulate and are applied at the
walk's end.

:class:`FusedFactoredLearner` is the yardstick of the factored learner: its fields, its
step (:func:`fused_factored_step`) with the accumulators passed as
arguments, not read from the learner's tuple at every access.
"""

from __future__ import annotations

import math
from collections import namedtuple
from typing import NamedTuple

import numpy as np
from numba import njit

from cml_edge.backends.floating.kernels import _row_dots
from cml_edge.core.cml import CML
from cml_edge.core.step import begin_walk, end_walk, learn, norms_and_gram, prepare, scores
from cml_edge.grid.arena import GridArena
from cml_edge.grid.training import (
    FactoredLearner,
    factored_begin_walk,
    factored_end_walk,
)
from cml_edge.jit.kernel import allocates


class FusedLearner(NamedTuple):
    """Eqs. 1-3 on the raw weights, accumulated per walk (module docstring)."""

    Wq: np.ndarray  # (n_s, n_i), column-major, as the float64 array stores it
    Wk: np.ndarray  # (n_a, n_s), row-major
    Wv: np.ndarray  # (n_s, n_a), column-major
    Aq: np.ndarray  # the walk's accumulated updates, shaped and laid out as the weights
    Ak: np.ndarray
    Av: np.ndarray
    lr: np.ndarray  # float64[3]: lr_q, lr_k, lr_v
    s: np.ndarray  # (n_s) s_t
    ds: np.ndarray  # (n_s) s_{t+1} - s_t
    g: np.ndarray  # (n_a) the affordance
    d_o: np.ndarray  # (n_i) o_{t+1} - o_t

    @classmethod
    def of(cls, cml: CML) -> FusedLearner:
        """The learner of ``cml``'s float64 weights (trained in place)."""
        Wq, Wk, Wv = (arr.state.W for arr in cml.arrays)
        c = cml.config
        return cls(Wq, Wk, Wv, np.zeros_like(Wq), np.zeros_like(Wk), np.zeros_like(Wv),
                   np.array([c.lr_q, c.lr_k, c.lr_v]), np.zeros(c.n_s), np.zeros(c.n_s),
                   np.zeros(c.n_a), np.zeros(c.n_i))


@njit(cache=True, inline="always")
def two_reads(Wq, x, y, out_x, out_y):
    """out_x = W_q x and out_y = W_q y, each a sum of W_q's columns in index order (zero
    inputs skipped), as the float64 array reads its tall matrices."""
    n_s, n_i = Wq.shape
    for r in range(n_s):
        out_x[r] = 0.0
        out_y[r] = 0.0
    for j in range(n_i):
        if x[j] != 0.0:
            for r in range(n_s):
                out_x[r] += Wq[r, j] * x[j]
        if y[j] != 0.0:
            for r in range(n_s):
                out_y[r] += Wq[r, j] * y[j]


@njit(cache=True, inline="always")
def fused_step(Wq, Wk, Wv, Aq, Ak, Av, lr, s, ds, g, d_o, o_t, o_1, a):
    """One step of Eqs. 1-3; returns ||e_t||."""
    n_s, n_i = Wq.shape
    for j in range(n_i):
        d_o[j] = o_1[j] - o_t[j]
    two_reads(Wq, o_t, d_o, s, ds)  # s_t = W_q o_t and s_{t+1} - s_t = W_q (o_1 - o_t)
    _row_dots(Wk, s, g)
    lr_q, lr_k, lr_v = lr[0], lr[1], lr[2]
    for i in range(g.shape[0]):  # Eq. 1: W_k += lr_k (a_t - g_t) s_t^T
        p = lr_k * ((1.0 if i == a else 0.0) - 1.0 / (1.0 + math.exp(-g[i])))
        if p != 0.0:
            for r in range(n_s):
                Ak[i, r] += p * s[r]
    sq = 0.0
    for r in range(n_s):  # e_t, Eq. 2 (W_v's column a) and Eq. 3 (W_q's live columns)
        e = ds[r] - Wv[r, a]
        sq += e * e
        Av[r, a] += lr_v * e
        for j in range(n_i):
            if o_1[j] != 0.0:
                Aq[r, j] += (lr_q * -e) * o_1[j]
    return math.sqrt(sq)


@njit(cache=True)
def _apply(W, A):
    for i in range(W.shape[0]):
        for j in range(W.shape[1]):
            if A[i, j] != 0.0:
                W[i, j] += A[i, j]
                A[i, j] = 0.0


@njit(cache=True, inline="always")
def _fused_learn(fl, o_t, o_1, a):
    return fused_step(fl.Wq, fl.Wk, fl.Wv, fl.Aq, fl.Ak, fl.Av, fl.lr, fl.s, fl.ds, fl.g,
                      fl.d_o, o_t, o_1, a)


@njit(cache=True, inline="always")
def _fused_begin_walk(fl):
    pass


@njit(cache=True)
def _fused_end_walk(fl):
    _apply(fl.Wq, fl.Aq)
    _apply(fl.Wk, fl.Ak)
    _apply(fl.Wv, fl.Av)
    return 0.0


class FusedScorer(NamedTuple):
    """Utility x affordance on the raw weights (module docstring)."""

    Wq: np.ndarray
    Wk: np.ndarray
    Wv: np.ndarray
    norms: np.ndarray
    gram: np.ndarray
    d: np.ndarray  # (n_s) s* - s
    s: np.ndarray  # (n_s)
    z: np.ndarray  # (n_a)

    @classmethod
    def of(cls, cml: CML) -> FusedScorer:
        c = cml.config
        Wq, Wk, Wv = (arr.state.W for arr in cml.arrays)
        return cls(Wq, Wk, Wv, np.ones(c.n_a), np.zeros((c.n_a, c.n_a)), np.zeros(c.n_s),
                   np.zeros(c.n_s), np.zeros(c.n_a))


@allocates  # (a contiguous copy of W_v's columns)
def _fused_prepare(sc, normalize, gram):
    norms_and_gram(np.ascontiguousarray(sc.Wv.T), normalize, gram, sc.norms, sc.gram)


@njit(cache=True, inline="always")
def fused_scores(Wq, Wk, Wv, norms, d, s, z, o, dgo, u, score):
    """u = W_v^T W_q (o* - o) and score = u / norms x sigmoid(W_k W_q o)."""
    n_s = Wq.shape[0]
    two_reads(Wq, dgo, o, d, s)
    _row_dots(Wk, s, z)
    for a in range(score.shape[0]):
        t = 0.0
        for r in range(n_s):
            t += Wv[r, a] * d[r]
        u[a] = t
        score[a] = t / norms[a] * (1.0 / (1.0 + math.exp(-z[a])))


@njit(cache=True, inline="always")
def _fused_scores(sc, o, dgo, u, score):
    fused_scores(sc.Wq, sc.Wk, sc.Wv, sc.norms, sc.d, sc.s, sc.z, o, dgo, u, score)


FusedFactoredLearner = namedtuple("FusedFactoredLearner", FactoredLearner._fields)
"""The factored learner's fields, its step given them as arguments."""


def fused_factored_of(cml: CML, arena: GridArena):
    """The yardstick of :class:`FactoredLearner` for ``cml`` on ``arena``."""
    return FusedFactoredLearner(*FactoredLearner.of(cml, arena))


@njit(cache=True, inline="always")
def fused_factored_step(E, B, D, C, cnt, visits, cells, n_cells, frame, n, o_t, o_1, a):
    """The factored step on the learner's arrays, passed as arguments (the yardstick of
    :mod:`cml_edge.bench.fused`)."""
    n_i = o_t.shape[0]
    for i in range(n_i):
        di = o_1[i] - o_t[i]
        E[a, i] += o_t[i]
        B[i, a] += di
        D[a, i] += o_1[i]
        for j in range(n_i):
            C[i, j] += di * o_1[j]
    cnt[a] += 1.0
    # the cell of o_t (the frame maps cells to observations one to one)
    c = 0
    for i in range(n_i):
        c = c * n + int(round(o_t[i] * frame[1] + frame[0]))
    if visits[c] == 0:
        cells[n_cells[0]] = c
        n_cells[0] += 1
    visits[c] += 1
    return 0.0


@njit(cache=True, inline="always")
def _ff_learn(fl, o_t, o_1, a):
    return fused_factored_step(fl.E, fl.B, fl.D, fl.C, fl.cnt, fl.visits, fl.cells, fl.n_cells,
                               fl.frame, fl.n, o_t, o_1, a)


begin_walk.register(FusedLearner, _fused_begin_walk)
learn.register(FusedLearner, _fused_learn)
end_walk.register(FusedLearner, _fused_end_walk)
prepare.register(FusedScorer, _fused_prepare)
scores.register(FusedScorer, _fused_scores)
begin_walk.register(FusedFactoredLearner, factored_begin_walk)
learn.register(FusedFactoredLearner, _ff_learn)
end_walk.register(FusedFactoredLearner, factored_end_walk)
