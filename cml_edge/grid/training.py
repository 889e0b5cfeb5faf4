"""Training: exploration walks with the local rule, on three paths that agree.

- ``reference``: plain Python, one array call per operation (:mod:`cml_edge.core.learning`);
- ``direct``: the same operations as one compiled Numba loop, the backend's kernels
  compiled in through the seam (:mod:`cml_edge.backends.dispatch`); bit-identical to
  the reference, and what device arrays emulate operation by operation;
- ``factored``: the exact shortcut for float64 arrays under the per-walk schedule.

The factored form. Within a walk the weights are frozen and s_t = W_q o_t, so
W_k s_t = (W_k W_q) o_t, and the walk's summed updates factor through accumulators of
size N_a x N_i, N_i x N_a, N_a, N_i x N_i and N_a x N_i (60 numbers for the paper's
sizes):

    A = sum (a_t - g_t) o_t^T     dW_k = lr_k A W_q^T
    B = sum (o_{t+1} - o_t) a_t^T, n = sum a_t
                                  dW_v = lr_v (W_q B - W_v diag(n))
    C = sum (o_{t+1} - o_t) o_{t+1}^T, D = sum a_t o_{t+1}^T
                                  dW_q = lr_q (W_v D - W_q C)

It is exact algebra, not an approximation: the weights agree with the direct loop to
rounding (tests: relative 1e-12). Exploration consumes the same random numbers on
every path, so the walks themselves are identical.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numba import njit

from cml_edge.core.cml import CML
from cml_edge.core.learning import check_walks, end_walk, learn_step, schedule_defers
from cml_edge.core.step import learn_buffers, seam_commit, seam_learn
from cml_edge.errors import InputError
from cml_edge.grid.arena import MOVES, N_ACTIONS, GridArena
from cml_edge.grid.exploration import (
    K_NEAREST,
    N_EXPL_FRACTION,
    VisitedSet,
    choose_action,
    choose_action_reference,
    explore_code,
    nth_free_cell,
    threshold,
)
from cml_edge.protocol import STREAM_EXPLORE, STREAM_WALK_START
from cml_edge.rng import randint, stream_key

PATHS = ("reference", "direct", "factored")


@dataclass(frozen=True)
class TrainConfig:
    """The paper's protocol by default: 100 walks x 900 steps, random, per-walk updates."""

    walks: int = 100
    steps: int = 900
    explore: str = "random"
    schedule: str = "walk"

    def __post_init__(self) -> None:
        check_walks(self.walks, self.steps)
        explore_code(self.explore)
        schedule_defers(self.schedule)

    @property
    def n_expl(self) -> int:
        """N_expl = 0.3 x walks (paper 2.2)."""
        return int(round(N_EXPL_FRACTION * self.walks))


class Explorer:
    """Exploration state that persists across walks: the visited cells (Eq. 4)."""

    def __init__(self, arena: GridArena) -> None:
        self.arena = arena
        self.free = arena.free
        self.masks = arena.move_masks
        self.visited = np.zeros_like(self.free)
        self.n_visited = np.zeros(1, dtype=np.int64)
        self.reference = VisitedSet()


def train(cml: CML, arena: GridArena, config: TrainConfig, seed: int, path: str = "direct",
          epoch: int = 10, on_epoch: Callable[[int], None] | None = None) -> np.ndarray:
    """Train ``cml`` in place; returns the mean training error ||e_t|| of each walk.

    ``on_epoch(walks_done)`` is called every ``epoch`` walks and at the end (the
    paper evaluates every 10 walks).
    """
    if path not in PATHS:
        raise InputError(f"unknown path {path!r}; allowed: {', '.join(PATHS)}")
    defer = schedule_defers(config.schedule)
    if path == "factored" and not (defer and all(
            getattr(a, "supports_factored", False) for a in cml.arrays)):
        raise InputError("the factored path needs float64 arrays and the per-walk schedule")
    explorer = Explorer(arena)
    errors = np.zeros(config.walks)
    done = 0
    while done < config.walks:
        stop = min(done + epoch, config.walks)
        _train_walks(cml, explorer, config, seed, path, defer, done, stop, errors)
        done = stop
        if on_epoch is not None:
            on_epoch(done)
    return errors


def _train_walks(cml, explorer, config, seed, path, defer, w0, w1, errors):
    c = cml.config
    args = (explorer.free, explorer.masks, explorer.visited, explorer.n_visited, c.obs_origin,
            c.obs_scale, w0, w1, config.steps, config.n_expl, explore_code(config.explore),
            c.lr_q, c.lr_k, c.lr_v, int(seed), errors)
    if path == "direct":
        train_direct(cml.W_q.state, cml.W_k.state, cml.W_v.state, defer, *args)
    elif path == "factored":
        train_factored(cml.W_q.state.W, cml.W_k.state.W, cml.W_v.state.W, *args)
    else:
        train_reference(cml, explorer, config, seed, defer, w0, w1, errors)


def train_reference(cml: CML, explorer: Explorer, config: TrainConfig, seed: int, defer: bool,
                    w0: int, w1: int, errors: np.ndarray) -> None:
    """Walks w0..w1-1 in plain Python: the readable statement of the training loop."""
    start_key = stream_key(seed, STREAM_WALK_START)
    key = stream_key(seed, STREAM_EXPLORE)
    code = explore_code(config.explore)
    n_free = int(explorer.free.sum())
    visited = explorer.reference
    for w in range(w0, w1):
        x, y = nth_free_cell(explorer.free, randint(start_key, w, n_free))
        visited.add(x, y)
        t_expl = threshold(w, config.n_expl)
        total = 0.0
        for t in range(config.steps):
            a = choose_action_reference(code, explorer.arena, visited, x, y, t_expl, key,
                                        w * config.steps + t)
            nx, ny = x + MOVES[a, 0], y + MOVES[a, 1]
            total += learn_step(cml, cml.observe((x, y)), cml.observe((nx, ny)), a, defer)
            x, y = int(nx), int(ny)
            visited.add(x, y)
        end_walk(cml, defer)
        errors[w] = total / config.steps


@njit(cache=True)
def _visit(visited, n_visited, x, y):
    if not visited[x, y]:
        visited[x, y] = 1
        n_visited[0] += 1


@njit(cache=True)
def train_direct(q, k, v, defer, free, masks, visited, n_visited, origin, scale, w0, w1, steps,
                 n_expl, explore, lr_q, lr_k, lr_v, seed, errors):
    """The compiled twin of :func:`train_reference`, through the synaptic-array seam
    (:func:`cml_edge.core.step.seam_learn`)."""
    n_s = q[0].shape[0]
    n_i = q[0].shape[1]
    n_a = k[0].shape[0]
    o_t = np.zeros(n_i)
    o_1 = np.zeros(n_i)
    buf = learn_buffers(n_s, n_i, n_a)
    novelty = np.zeros(N_ACTIONS)
    best = np.zeros(K_NEAREST)
    start_key = stream_key(seed, STREAM_WALK_START)
    key = stream_key(seed, STREAM_EXPLORE)
    n_free = 0
    for cx in range(free.shape[0]):
        for cy in range(free.shape[1]):
            n_free += free[cx, cy]
    for w in range(w0, w1):
        x, y = nth_free_cell(free, randint(start_key, w, n_free))
        _visit(visited, n_visited, x, y)
        t_expl = threshold(w, n_expl)
        total = 0.0
        for t in range(steps):
            a = choose_action(explore, masks, visited, n_visited[0], x, y, t_expl, key,
                              w * steps + t, novelty, best)
            nx = x + MOVES[a, 0]
            ny = y + MOVES[a, 1]
            o_t[0] = (x - origin) / scale
            o_t[1] = (y - origin) / scale
            o_1[0] = (nx - origin) / scale
            o_1[1] = (ny - origin) / scale
            total += math.sqrt(seam_learn(q, k, v, o_t, o_1, a, lr_q, lr_k, lr_v, defer, buf))
            x = nx
            y = ny
            _visit(visited, n_visited, x, y)
        if defer:
            seam_commit(q, k, v)
        errors[w] = total / steps


@njit(cache=True)
def train_factored(Wq, Wk, Wv, free, masks, visited, n_visited, origin, scale, w0, w1, steps,
                   n_expl, explore, lr_q, lr_k, lr_v, seed, errors):
    """The exact factored form of the per-walk schedule (module docstring), float64 only.

    Two more exact rearrangements keep a step to a few additions: the affordance term
    of A, sum_t g(o_t) o_t^T, is summed per visited cell (n_cell g(o_cell) o_cell^T,
    one sigmoid per cell and walk instead of one per step), and the training error
    ||e_t|| = ||W_q delta_a - W_v a|| depends only on the action, so it is formed
    once per action and walk (delta_a = MOVES[a] / obs_scale).
    """
    n_s, n_i = Wq.shape
    n_a = Wk.shape[0]
    n = free.shape[0]
    M = np.zeros((n_a, n_i))
    E = np.zeros((n_a, n_i))  # sum a_t o_t^T
    B = np.zeros((n_i, n_a))
    cnt = np.zeros(n_a)
    C = np.zeros((n_i, n_i))
    D = np.zeros((n_a, n_i))
    err_a = np.zeros(n_a)
    visits = np.zeros((n, n), np.int64)
    cells = np.zeros((steps + 1, 2), np.int64)
    o_t = np.zeros(n_i)
    o_1 = np.zeros(n_i)
    novelty = np.zeros(N_ACTIONS)
    best = np.zeros(K_NEAREST)
    start_key = stream_key(seed, STREAM_WALK_START)
    key = stream_key(seed, STREAM_EXPLORE)
    n_free = 0
    for cx in range(free.shape[0]):
        for cy in range(free.shape[1]):
            n_free += free[cx, cy]
    for w in range(w0, w1):
        M[:] = Wk @ Wq
        for a in range(n_a):
            sq = 0.0
            for r in range(n_s):
                e = Wq[r, 0] * (MOVES[a, 0] / scale) + Wq[r, 1] * (MOVES[a, 1] / scale) - Wv[r, a]
                sq += e * e
            err_a[a] = math.sqrt(sq)
        E[:] = 0.0
        B[:] = 0.0
        cnt[:] = 0.0
        C[:] = 0.0
        D[:] = 0.0
        n_cells = 0
        x, y = nth_free_cell(free, randint(start_key, w, n_free))
        _visit(visited, n_visited, x, y)
        t_expl = threshold(w, n_expl)
        for t in range(steps):
            a = choose_action(explore, masks, visited, n_visited[0], x, y, t_expl, key,
                              w * steps + t, novelty, best)
            nx = x + MOVES[a, 0]
            ny = y + MOVES[a, 1]
            o_t[0] = (x - origin) / scale
            o_t[1] = (y - origin) / scale
            o_1[0] = (nx - origin) / scale
            o_1[1] = (ny - origin) / scale
            for i in range(n_i):
                di = o_1[i] - o_t[i]
                E[a, i] += o_t[i]
                B[i, a] += di
                D[a, i] += o_1[i]
                for j in range(n_i):
                    C[i, j] += di * o_1[j]
            cnt[a] += 1.0
            if visits[x, y] == 0:
                cells[n_cells, 0] = x
                cells[n_cells, 1] = y
                n_cells += 1
            visits[x, y] += 1
            x = nx
            y = ny
            _visit(visited, n_visited, x, y)
        A = E.copy()  # A = sum (a_t - g_t) o_t^T
        total = 0.0
        for c in range(n_cells):
            cx = cells[c, 0]
            cy = cells[c, 1]
            m = visits[cx, cy]
            visits[cx, cy] = 0
            o_t[0] = (cx - origin) / scale
            o_t[1] = (cy - origin) / scale
            for r in range(n_a):
                z = 0.0
                for j in range(n_i):
                    z += M[r, j] * o_t[j]
                g = m / (1.0 + math.exp(-z))
                for j in range(n_i):
                    A[r, j] -= g * o_t[j]
        for a in range(n_a):
            total += cnt[a] * err_a[a]
        Wk += lr_k * (A @ Wq.T)
        dWv = lr_v * (Wq @ B - Wv * cnt)
        Wq += lr_q * (Wv @ D - Wq @ C)
        Wv += dWv
        errors[w] = total / steps
