"""The CML's compiled step through the synaptic-array seam, shared by every compiled loop
(the grid's :func:`cml_edge.training.train_direct` and :func:`cml_edge.planning.plan_direct`,
the robot's loops in :mod:`cml_edge.robot.cml`).

Each function takes the three array states ``q, k, v`` (W_q, W_k, W_v) and preallocated
work vectors, so a loop allocates once, before its first step. ``inline="always"`` keeps
the loops as fast as when these bodies were written out in them.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from cml_edge.backends.dispatch import sa_commit, sa_matvec, sa_outer_update, sa_rmatvec, sa_sigmoid


@njit(cache=True)
def learn_buffers(n_s, n_i, n_a):
    """Work vectors for :func:`seam_learn`: s, ds, va, e, -e (n_s); z, g, a - g, a (n_a);
    o_{t+1} - o_t (n_i)."""
    return (np.zeros(n_s), np.zeros(n_s), np.zeros(n_s), np.zeros(n_s), np.zeros(n_s),
            np.zeros(n_a), np.zeros(n_a), np.zeros(n_a), np.zeros(n_a), np.zeros(n_i))


@njit(cache=True, inline="always")
def seam_learn(q, k, v, o_t, o_1, a, lr_q, lr_k, lr_v, defer, buf):
    """One step of Eqs. 1-3 (the compiled twin of :func:`cml_edge.learning.learn_step`,
    held to bit equality by the tests); returns ||e_t||^2. All reads precede the updates."""
    s, ds, va, e, neg_e, z, g, post_k, action, d_o = buf
    n_s = s.shape[0]
    n_a = z.shape[0]
    for i in range(n_a):
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
    for i in range(n_s):
        e[i] = ds[i] - va[i]  # e_t = s_{t+1} - s_hat_{t+1}
        neg_e[i] = -e[i]
        sq += e[i] * e[i]
    for i in range(n_a):
        post_k[i] = action[i] - g[i]
    sa_outer_update(k, post_k, s, lr_k, defer)  # Eq. 1
    sa_outer_update(v, e, action, lr_v, defer)  # Eq. 2
    sa_outer_update(q, neg_e, o_1, lr_q, defer)  # Eq. 3
    return sq


@njit(cache=True, inline="always")
def seam_commit(q, k, v):
    """Apply the accumulated updates of a walk (the per-walk schedule)."""
    sa_commit(q)
    sa_commit(k)
    sa_commit(v)


@njit(cache=True)
def plan_buffers(n_s, n_a):
    """Work vectors for :func:`seam_scores`: d, s (n_s); u, z, g (n_a)."""
    return np.zeros(n_s), np.zeros(n_s), np.zeros(n_a), np.zeros(n_a), np.zeros(n_a)


@njit(cache=True)
def seam_utility_norms(v, normalize, norms):
    """||W_v a|| per action, read once per planning batch (ones for the raw utility)."""
    n_s = v[0].shape[0]
    n_a = norms.shape[0]
    col = np.zeros(n_s)
    action = np.zeros(n_a)
    for a in range(n_a):
        norms[a] = 1.0
        if normalize:
            action[:] = 0.0
            action[a] = 1.0
            sa_matvec(v, action, col)
            total = 0.0
            for i in range(n_s):
                total += col[i] * col[i]
            norms[a] = math.sqrt(total) if total > 0 else 1.0


@njit(cache=True, inline="always")
def seam_scores(q, k, v, o, dgo, norms, score, buf):
    """Utility x affordance per action (paper 2.1): score_a = (W_v^T W_q (o* - o))_a / norms_a
    x sigmoid(W_k W_q o)_a, with ``dgo`` = o* - o read through W_q once."""
    d, s, u, z, g = buf
    sa_matvec(q, dgo, d)  # d = s* - s
    sa_rmatvec(v, d, u)  # u = W_v^T d
    sa_matvec(q, o, s)
    sa_matvec(k, s, z)
    sa_sigmoid(k, z, g)  # affordance
    for a in range(score.shape[0]):
        score[a] = u[a] / norms[a] * g[a]


@njit(cache=True)
def wta(score, mask):
    """Winner-take-all over the available actions (``mask``); -1 if none is available."""
    best = -1
    for a in range(score.shape[0]):
        if mask[a] and (best < 0 or score[a] > score[best]):
            best = a
    return best
