"""The CML's step as plug-ins of the worlds' loops: learners, scorers, and the choice.

A world's training loop (the grid's :func:`cml_edge.grid.training.train_loop`, the robot's
:func:`cml_edge.robot.training.train_loop`) calls, for each walk::

    begin_walk(learner)
    total += learn(learner, o_t, o_1, a)        # every step: Eqs. 1-3, returns ||e_t||
    total += end_walk(learner)                  # the walk's end: the per-walk commit

and its planning loop calls ``prepare(scorer, normalize, gram)`` once per batch and
``scores(scorer, o, dgo, u, score)`` at every decision, then :func:`wta`. Each of these is
routed by the type of the plug-in (:func:`cml_edge.jit.routing.routed`), so one loop serves
every learner and scorer, compiled or, through the loop's ``py_func``, in plain Python:

- :class:`SeamLearner` / :class:`SeamScorer`: the reads and updates through the three
  arrays' seam, compiled (the ``direct`` path; any device);
- :class:`ReferenceLearner` / :class:`ReferenceScorer`: the same operations through the
  arrays' Python methods (:mod:`cml_edge.core.learning`, the CML's methods; the
  ``reference`` path), which the tests hold bit-identical to the seam's;
- :class:`FactoredScorer`: float64 arrays only, the utility and affordance maps
  R = W_v^T W_q and M = W_k W_q formed once per batch, so a decision costs 2 N_a N_i
  multiply-adds (the ``factored`` path); the grid adds its factored learner.

Reads are the displacement reads of :mod:`cml_edge.core.cml`: s_{t+1} - s_t and s* - s are
read as W_q (o_{t+1} - o_t) and W_q (o* - o), one read each.
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np
from numba import njit

from cml_edge.backends.dispatch import (
    sa_commit,
    sa_matvec,
    sa_outer_update,
    sa_rmatvec,
    sa_sigmoid,
)
from cml_edge.jit.kernel import allocates
from cml_edge.jit.routing import routed


# the routed plug-in functions ------------------------------------------------------------
@routed
def begin_walk(learner):
    """A walk starts (the factored learner forms its per-walk maps)."""


@routed
def learn(learner, o_t, o_1, a):
    """One step of Eqs. 1-3, from observation o_t to o_1 by action a; returns ||e_t||
    (0 for a learner that sums its error at the walk's end)."""


@routed
def end_walk(learner):
    """A walk ends: apply what it accumulated (the paper's schedule); returns the part of
    the walk's summed error not yet returned by :func:`learn`."""


@routed
def prepare(scorer, normalize, gram):
    """Read, once per planning batch, W_v's column norms (``normalize``; ones otherwise) and,
    if ``gram``, its Gram matrix K = W_v^T W_v (the escape planner's)."""


@routed
def scores(scorer, o, dgo, u, score):
    """u = W_v^T W_q (o* - o) (the raw utility; ``dgo`` = o* - o) and
    score = u / norms x sigmoid(W_k W_q o), utility x affordance (paper 2.1)."""


# shared arithmetic --------------------------------------------------------------------
@njit(cache=True)
def column_norm(col):
    """||col||, summed in index order; 1 for a zero column (so that dividing by it is safe)."""
    total = 0.0
    for i in range(col.shape[0]):
        total += col[i] * col[i]
    return math.sqrt(total) if total > 0 else 1.0


@njit(cache=True)
def norms_and_gram(cols, normalize, gram, norms, K):
    """From W_v's columns (rows of ``cols``): norms[a] = ||W_v a|| (if ``normalize``, else 1)
    and, if ``gram``, K[a, b] = (W_v a) . (W_v b), each summed in index order."""
    n_a = cols.shape[0]
    for a in range(n_a):
        norms[a] = column_norm(cols[a]) if normalize else 1.0
        if gram:
            for b in range(n_a):
                total = 0.0
                for i in range(cols.shape[1]):
                    total += cols[a, i] * cols[b, i]
                K[a, b] = total


@njit(cache=True)
def wta(score, mask):
    """Winner-take-all over the available actions (``mask``); -1 if none is available.
    The first index wins a tie."""
    best = -1
    for a in range(score.shape[0]):
        if mask[a] and (best < 0 or score[a] > score[best]):
            best = a
    return best


# through the seam (the direct path) ----------------------------------------------------------
class SeamLearner(NamedTuple):
    """Eqs. 1-3 through the three arrays' seam, compiled; work vectors allocated once."""

    q: Any  # W_q's state
    k: Any  # W_k's state
    v: Any  # W_v's state
    lr_q: float
    lr_k: float
    lr_v: float
    buf: tuple  # work vectors: s, ds, va, e, -e (n_s); z, g, a - g, a (n_a); o_1 - o_t (n_i)

    @classmethod
    def of(cls, cml: Any, defer: bool) -> SeamLearner:
        """The learner of ``cml``'s arrays: a :class:`WalkSeamLearner` (``defer``) or a
        :class:`StepSeamLearner`."""
        c = cml.config
        q, k, v = (arr.state for arr in cml.arrays)
        buf = (*(np.zeros(c.n_s) for _ in range(5)), *(np.zeros(c.n_a) for _ in range(4)),
               np.zeros(c.n_i))
        kind = WalkSeamLearner if defer else StepSeamLearner
        return kind(q, k, v, c.lr_q, c.lr_k, c.lr_v, buf)


class WalkSeamLearner(SeamLearner):
    """A :class:`SeamLearner` of the per-walk schedule (accumulate, commit at the walk's
    end), and :class:`StepSeamLearner` of the per-step one: the schedule is the type (no
    field holds it), so a loop compiled for one passes it to the seam as a constant and
    Numba compiles only the update that schedule runs (:func:`cml_edge.jit.routing.routed`)."""

    __slots__ = ()


class StepSeamLearner(SeamLearner):
    """A :class:`SeamLearner` of the per-step schedule (each update applied at once)."""

    __slots__ = ()


@njit(cache=True, inline="always")
def seam_learn(q, k, v, o_t, o_1, a, lr_q, lr_k, lr_v, defer, buf):
    """One step of Eqs. 1-3 (the compiled twin of :func:`cml_edge.core.learning.learn_step`,
    held to bit equality by the tests); returns ||e_t||. All reads precede the updates."""
    s, ds, va, e, neg_e, z, g, post_k, action, d_o = buf
    for i in range(action.shape[0]):
        action[i] = 0.0
    action[a] = 1.0
    sa_matvec(q, o_t, s)  # s_t = W_q o_t
    sa_matvec(k, s, z)
    sa_sigmoid(k, z, g)  # g_t = sigmoid(W_k s_t)
    for i in range(d_o.shape[0]):
        d_o[i] = o_1[i] - o_t[i]
    sa_matvec(q, d_o, ds)  # s_{t+1} - s_t, one read
    sa_matvec(v, action, va)  # W_v a_t
    sq = 0.0
    for i in range(e.shape[0]):
        e[i] = ds[i] - va[i]  # e_t = s_{t+1} - s_hat_{t+1}
        neg_e[i] = -e[i]
        sq += e[i] * e[i]
    for i in range(action.shape[0]):
        post_k[i] = action[i] - g[i]
    sa_outer_update(k, post_k, s, lr_k, defer)  # Eq. 1
    sa_outer_update(v, e, action, lr_v, defer)  # Eq. 2
    sa_outer_update(q, neg_e, o_1, lr_q, defer)  # Eq. 3
    return math.sqrt(sq)


# (the plug-ins pass their fields on as arguments, read once per step; the schedule is
# the learner's type)
@njit(cache=True, inline="always")
def _walk_learn(lr, o_t, o_1, a):
    return seam_learn(lr.q, lr.k, lr.v, o_t, o_1, a, lr.lr_q, lr.lr_k, lr.lr_v, True, lr.buf)


@njit(cache=True, inline="always")
def _step_learn(lr, o_t, o_1, a):
    return seam_learn(lr.q, lr.k, lr.v, o_t, o_1, a, lr.lr_q, lr.lr_k, lr.lr_v, False, lr.buf)


@njit(cache=True, inline="always")
def _seam_begin_walk(lr):
    pass


@njit(cache=True, inline="always")
def _walk_end_walk(lr):
    sa_commit(lr.q)
    sa_commit(lr.k)
    sa_commit(lr.v)
    return 0.0


@njit(cache=True, inline="always")
def _step_end_walk(lr):
    return 0.0


class SeamScorer(NamedTuple):
    """Utility x affordance through the seam, compiled; work vectors allocated once."""

    q: Any
    k: Any
    v: Any
    norms: np.ndarray  # (n_a) W_v's column norms (or ones), from prepare
    gram: np.ndarray  # (n_a, n_a) W_v^T W_v, from prepare when asked
    cols: np.ndarray  # (n_a, n_s) W_v's columns as read
    buf: tuple  # work vectors: one-hot (n_a), d = s* - s, s (n_s), z, g (n_a)

    @classmethod
    def of(cls, cml: Any) -> SeamScorer:
        c = cml.config
        q, k, v = (arr.state for arr in cml.arrays)
        buf = (np.zeros(c.n_a), np.zeros(c.n_s), np.zeros(c.n_s), np.zeros(c.n_a),
               np.zeros(c.n_a))
        return cls(q, k, v, np.ones(c.n_a), np.zeros((c.n_a, c.n_a)), np.zeros((c.n_a, c.n_s)),
                   buf)


@njit(cache=True)
def _seam_prepare(sc, normalize, gram):
    if not (normalize or gram):  # nothing to read
        sc.norms[:] = 1.0
        return
    onehot = sc.buf[0]
    for a in range(onehot.shape[0]):  # W_v's columns, one read each
        onehot[:] = 0.0
        onehot[a] = 1.0
        sa_matvec(sc.v, onehot, sc.cols[a])
    norms_and_gram(sc.cols, normalize, gram, sc.norms, sc.gram)


@njit(cache=True, inline="always")
def seam_scores(q, k, v, o, dgo, norms, u, score, buf):
    """u = W_v^T W_q (o* - o) and score = u / norms x sigmoid(W_k W_q o), through the seam."""
    _, d, s, z, g = buf
    sa_matvec(q, dgo, d)  # d = s* - s, one read
    sa_rmatvec(v, d, u)  # u = W_v^T d
    sa_matvec(q, o, s)
    sa_matvec(k, s, z)
    sa_sigmoid(k, z, g)  # affordance
    for a in range(score.shape[0]):
        score[a] = u[a] / norms[a] * g[a]


@njit(cache=True, inline="always")
def _seam_scores(sc, o, dgo, u, score):
    seam_scores(sc.q, sc.k, sc.v, o, dgo, sc.norms, u, score, sc.buf)


# the factored float64 shortcut ------------------------------------------------------------
class FactoredScorer(NamedTuple):
    """Planning on float64 weights with R = W_v^T W_q and M = W_k W_q formed per batch."""

    Wq: np.ndarray
    Wk: np.ndarray
    Wv: np.ndarray
    R: np.ndarray  # (n_a, n_i)
    M: np.ndarray  # (n_a, n_i)
    norms: np.ndarray
    gram: np.ndarray
    inv: np.ndarray  # 1 / norms

    @classmethod
    def of(cls, cml: Any) -> FactoredScorer:
        c = cml.config
        return cls(cml.W_q.state.W, cml.W_k.state.W, cml.W_v.state.W, np.zeros((c.n_a, c.n_i)),
                   np.zeros((c.n_a, c.n_i)), np.ones(c.n_a), np.zeros((c.n_a, c.n_a)),
                   np.ones(c.n_a))


@njit(cache=True, inline="always")
def copy_matrix(dst, src):
    """dst = src, element by element: ``dst[:] = src`` would also compile Numba's message
    for mismatched shapes (seconds of a first run) for a check that cannot fail here."""
    for i in range(src.shape[0]):
        for j in range(src.shape[1]):
            dst[i, j] = src[i, j]


@allocates  # (matrix products)
def _factored_prepare(sc, normalize, gram):
    copy_matrix(sc.R, sc.Wv.T @ sc.Wq)
    copy_matrix(sc.M, sc.Wk @ sc.Wq)
    norms_and_gram(np.ascontiguousarray(sc.Wv.T), normalize, gram, sc.norms, sc.gram)
    for a in range(sc.inv.shape[0]):
        sc.inv[a] = 1.0 / sc.norms[a]


@njit(cache=True, inline="always")
def factored_scores(R, M, inv, o, dgo, u, score):
    """u = R (o* - o) and score = u / norms x sigmoid(M o), from the per-batch maps."""
    for a in range(score.shape[0]):
        ua = 0.0
        z = 0.0
        for j in range(o.shape[0]):
            ua += R[a, j] * dgo[j]
            z += M[a, j] * o[j]
        u[a] = ua
        score[a] = ua * inv[a] / (1.0 + math.exp(-z))


@njit(cache=True, inline="always")
def _factored_scores(sc, o, dgo, u, score):
    factored_scores(sc.R, sc.M, sc.inv, o, dgo, u, score)


for _kind, _learn, _end_walk in ((WalkSeamLearner, _walk_learn, _walk_end_walk),
                                  (StepSeamLearner, _step_learn, _step_end_walk)):
    begin_walk.register(_kind, _seam_begin_walk)
    learn.register(_kind, _learn)
    end_walk.register(_kind, _end_walk)
prepare.register(SeamScorer, _seam_prepare)
scores.register(SeamScorer, _seam_scores)
prepare.register(FactoredScorer, _factored_prepare)
scores.register(FactoredScorer, _factored_scores)
