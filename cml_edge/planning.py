"""Planning (paper 2.1): WTA over utility x affordance, blocked moves masked.

At each step the agent reads d = W_q (o* - o) (= s* - s, one read), the utility
u = W_v^T d (the transposed read of W_v; the paper's stand-in for W_v^-1 d), divided
by W_v's column norms unless the utility is ``raw``, and the affordance
g = sigmoid(W_k W_q o). The winner-take-all picks, among the moves available now, the
one with the largest u * g (first index on a tie): a move into an obstacle or off the
arena is not available, which is the paper's reactive obstacle handling. It stops on
the goal or after ``max_steps`` actions, or when no move is available.

Three paths, as for training: ``reference`` (Python, one array call per operation),
``direct`` (compiled, through the seam, bit-identical to the reference) and
``factored`` (float64 arrays: the N_a x N_i utility map U = W_v^T W_q / norms and
M = W_k W_q, so a step costs 2 N_a N_i multiply-adds).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from cml_edge.arena import MOVES, N_ACTIONS, GridArena, available_moves
from cml_edge.cml import CML
from cml_edge.kernels.dispatch import sa_matvec, sa_rmatvec, sa_sigmoid

PATHS = ("reference", "direct", "factored")
MAX_STEPS = 100


@dataclass
class PlanResult:
    """Per trial: final position, actions taken, and the visited path (padded with -1)."""

    final: np.ndarray  # (trials, 2)
    steps: np.ndarray  # (trials,)
    paths: np.ndarray  # (trials, max_steps + 1, 2)


def plan(cml: CML, arena: GridArena, starts: np.ndarray, goals: np.ndarray,
         max_steps: int = MAX_STEPS, path: str = "direct") -> PlanResult:
    """Plan from each start to its goal on ``arena``."""
    if path not in PATHS:
        raise ValueError(f"unknown path {path!r}; allowed: {', '.join(PATHS)}")
    starts = np.ascontiguousarray(starts, dtype=np.int64).reshape(-1, 2)
    goals = np.ascontiguousarray(goals, dtype=np.int64).reshape(-1, 2)
    n = len(starts)
    res = PlanResult(np.zeros((n, 2), np.int64), np.zeros(n, np.int64),
                     np.full((n, max_steps + 1, 2), -1, np.int64))
    free = arena.free
    normalize = cml.config.utility == "normalized"
    scale = cml.config.obs_scale
    origin = cml.config.obs_origin
    if path == "direct":
        plan_direct(cml.W_q.state, cml.W_k.state, cml.W_v.state, free, origin, scale, starts,
                    goals, max_steps, normalize, res.final, res.steps, res.paths)
    elif path == "factored":
        if not all(getattr(a, "supports_factored", False) for a in cml.arrays):
            raise ValueError("the factored path needs float64 arrays")
        plan_factored(cml.W_q.state.W, cml.W_k.state.W, cml.W_v.state.W, free, origin, scale,
                      starts, goals, max_steps, normalize, res.final, res.steps, res.paths)
    else:
        plan_reference(cml, free, starts, goals, max_steps, res)
    return res


def plan_reference(cml: CML, free: np.ndarray, starts: np.ndarray, goals: np.ndarray,
                   max_steps: int, res: PlanResult) -> None:
    """Plain-Python planning: the readable statement of the planner."""
    norms = cml.utility_norms()
    mask = np.zeros(N_ACTIONS, dtype=np.uint8)
    for trial, (start, goal) in enumerate(zip(starts, goals)):
        x, y = int(start[0]), int(start[1])
        res.paths[trial, 0] = (x, y)
        taken = 0
        o_goal = cml.observe(goal)
        while taken < max_steps and (x, y) != (goal[0], goal[1]):
            o = cml.observe((x, y))
            u = cml.utility(cml.W_q.matvec(o_goal - o), norms)  # W_v^T (s* - s)
            score = u * cml.affordance(cml.embed(o))
            if available_moves(free, x, y, mask) == 0:
                break
            a = int(np.argmax(np.where(mask == 1, score, -np.inf)))
            x, y = x + int(MOVES[a, 0]), y + int(MOVES[a, 1])
            taken += 1
            res.paths[trial, taken] = (x, y)
        res.final[trial] = (x, y)
        res.steps[trial] = taken


@njit(cache=True)
def _wta(score, mask):
    best = -1
    for a in range(N_ACTIONS):
        if mask[a] and (best < 0 or score[a] > score[best]):
            best = a
    return best


@njit(cache=True)
def plan_direct(q, k, v, free, origin, scale, starts, goals, max_steps, normalize, final, steps,
                paths):
    """The compiled twin of :func:`plan_reference`, through the synaptic-array seam."""
    n_s = q[0].shape[0]
    n_i = q[0].shape[1]
    n_a = k[0].shape[0]
    norms = np.ones(n_a)
    action = np.zeros(n_a)
    col = np.zeros(n_s)
    o = np.zeros(n_i)
    dgo = np.zeros(n_i)
    d = np.zeros(n_s)
    s = np.zeros(n_s)
    u = np.zeros(n_a)
    z = np.zeros(n_a)
    g = np.zeros(n_a)
    score = np.zeros(n_a)
    mask = np.zeros(N_ACTIONS, dtype=np.uint8)
    if normalize:
        for a in range(n_a):  # read W_v's columns once per batch
            action[:] = 0.0
            action[a] = 1.0
            sa_matvec(v, action, col)
            total = 0.0
            for i in range(n_s):
                total += col[i] * col[i]
            norms[a] = math.sqrt(total) if total > 0 else 1.0
    for trial in range(starts.shape[0]):
        x = starts[trial, 0]
        y = starts[trial, 1]
        gx = goals[trial, 0]
        gy = goals[trial, 1]
        paths[trial, 0, 0] = x
        paths[trial, 0, 1] = y
        taken = 0
        while taken < max_steps and not (x == gx and y == gy):
            o[0] = (x - origin) / scale
            o[1] = (y - origin) / scale
            dgo[0] = (gx - origin) / scale - o[0]
            dgo[1] = (gy - origin) / scale - o[1]
            sa_matvec(q, dgo, d)  # s* - s
            sa_rmatvec(v, d, u)  # u = W_v^T d
            sa_matvec(q, o, s)
            sa_matvec(k, s, z)
            sa_sigmoid(k, z, g)  # affordance
            for a in range(n_a):
                score[a] = u[a] / norms[a] * g[a]
            if available_moves(free, x, y, mask) == 0:
                break
            a = _wta(score, mask)
            x += MOVES[a, 0]
            y += MOVES[a, 1]
            taken += 1
            paths[trial, taken, 0] = x
            paths[trial, taken, 1] = y
        final[trial, 0] = x
        final[trial, 1] = y
        steps[trial] = taken


@njit(cache=True)
def plan_factored(Wq, Wk, Wv, free, origin, scale, starts, goals, max_steps, normalize, final,
                  steps, paths):
    """Planning with the utility map U = W_v^T W_q / norms and M = W_k W_q (float64)."""
    n_s, n_i = Wq.shape
    n_a = Wk.shape[0]
    U = Wv.T @ Wq
    M = Wk @ Wq
    if normalize:
        for a in range(n_a):
            total = 0.0
            for i in range(n_s):
                total += Wv[i, a] * Wv[i, a]
            norm = math.sqrt(total) if total > 0 else 1.0
            for j in range(n_i):
                U[a, j] /= norm
    score = np.zeros(n_a)
    mask = np.zeros(N_ACTIONS, dtype=np.uint8)
    for trial in range(starts.shape[0]):
        x = starts[trial, 0]
        y = starts[trial, 1]
        gx = goals[trial, 0]
        gy = goals[trial, 1]
        paths[trial, 0, 0] = x
        paths[trial, 0, 1] = y
        taken = 0
        while taken < max_steps and not (x == gx and y == gy):
            ox = (x - origin) / scale
            oy = (y - origin) / scale
            dx = (gx - origin) / scale - ox
            dy = (gy - origin) / scale - oy
            for a in range(n_a):
                zk = M[a, 0] * ox + M[a, 1] * oy
                score[a] = (U[a, 0] * dx + U[a, 1] * dy) / (1.0 + math.exp(-zk))
            if available_moves(free, x, y, mask) == 0:
                break
            a = _wta(score, mask)
            x += MOVES[a, 0]
            y += MOVES[a, 1]
            taken += 1
            paths[trial, taken, 0] = x
            paths[trial, taken, 1] = y
        final[trial, 0] = x
        final[trial, 1] = y
        steps[trial] = taken

