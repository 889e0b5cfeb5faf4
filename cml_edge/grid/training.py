"""Training on the grid: exploration walks with the local rule, one loop on three paths.

:func:`train_loop` states the training once: each walk starts on a random free cell, each
step picks an exploration move, reads the observations of the two cells and runs the
local rule (Eqs. 1-3), and the walk's end applies what it accumulated. Exploration is
the same compiled code on every path (:mod:`cml_edge.grid.exploration`); the learner is a
plug-in routed by type (:mod:`cml_edge.core.step`), which makes the three paths:

- ``reference``: the loop's plain-Python ``py_func`` with the reference learner (the
  arrays' Python methods, :mod:`cml_edge.core.learning`);
- ``direct``: the loop compiled with the seam learner; the same operations,
  bit-identical to the reference, and what device arrays emulate operation by operation;
- ``factored``: the loop compiled with :class:`FactoredLearner`, the exact shortcut for
  float64 arrays under the per-walk schedule.

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
from typing import NamedTuple

import numpy as np
from numba import njit

from cml_edge.core.cml import CML
from cml_edge.core.finite import check_weights
from cml_edge.core.learning import ReferenceLearner, check_walks, schedule_defers
from cml_edge.core.step import SeamLearner, begin_walk, copy_matrix, end_walk, learn
from cml_edge.engine.stop import chunks
from cml_edge.errors import InputError
from cml_edge.grid.arena import GridArena, observe, position, sense
from cml_edge.grid.exploration import (
    N_EXPL_FRACTION,
    GridExplorer,
    choose_action,
    explore_code,
    nth_free_cell,
    threshold,
    visit,
)
from cml_edge.jit.kernel import allocates, kernel
from cml_edge.jit.rng import randint

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


def train(cml: CML, arena: GridArena, config: TrainConfig, seed: int, path: str = "direct",
          epoch: int = 10, on_epoch: Callable[[int], None] | None = None,
          first_walk: int = 0) -> np.ndarray:
    """Train ``cml`` in place; returns the mean training error ||e_t|| of each walk.

    ``on_epoch(walks_done)`` is called every ``epoch`` walks and at the end (the
    paper evaluates every 10 walks). ``first_walk``: the walks are those of index
    ``first_walk`` onward of the seed's streams (their start cells and moves), e.g. more
    walks after a training of ``first_walk`` walks; the visited set of mixed exploration
    starts empty all the same. Weights that end NaN or infinite raise
    :class:`~cml_edge.core.finite.NonFiniteError` (a failed run).
    """
    if isinstance(first_walk, bool) or int(first_walk) != first_walk or first_walk < 0:
        raise InputError(f"first walk {first_walk!r} is not an integer >= 0")
    if path not in PATHS:
        raise InputError(f"unknown path {path!r}; allowed: {', '.join(PATHS)}")
    defer = schedule_defers(config.schedule)
    if path == "factored" and not (defer and all(
            getattr(a, "supports_factored", False) for a in cml.arrays)):
        raise InputError("the factored path needs float64 arrays and the per-walk schedule")
    if path == "factored" and arena.n_sensors:
        raise InputError("the factored path needs an observation of the position alone "
                         "(range sensors train on the direct path)")
    arena.check_inputs(cml.config.n_i)
    learner = make_learner(cml, path, defer, arena)
    explorer = GridExplorer.of(arena, config, seed)
    loop = train_loop.py_func if path == "reference" else train_loop
    c = cml.config
    errors = np.zeros(first_walk + config.walks)
    done = 0
    while done < config.walks:
        stop = min(done + epoch, config.walks)
        for w0, w1 in chunks(first_walk + done, first_walk + stop, config.steps):
            loop(learner, explorer, c.obs_origin, c.obs_scale, w0, w1, config.steps, errors)
        done = stop
        if on_epoch is not None:
            on_epoch(done)
    check_weights(cml, "training", seed)
    return errors[first_walk:]


def make_learner(cml: CML, path: str, defer: bool, arena: GridArena):
    """The learner of ``path``: reference, seam (direct) or factored (float64)."""
    if path == "reference":
        return ReferenceLearner(cml, defer)
    if path == "factored":
        return FactoredLearner.of(cml, arena)
    return SeamLearner.of(cml, defer)


@kernel
def train_loop(learner, explorer, origin, scale, w0, w1, steps, errors):
    """Walks w0..w1-1: the training of the module docstring, for any learner. A
    :func:`~cml_edge.jit.kernel.kernel`: no step pays reference counts."""
    cells, visited, n_visited, keys = (explorer.cells, explorer.visited, explorer.n_visited,
                                       explorer.keys)
    novelty, best = explorer.novelty, explorer.best
    table = cells.table
    o_t = explorer.obs[0]  # the observation of the cell, then of the next (swapped as
    o_1 = explorer.obs[1]  # the agent moves: o_{t+1} is the next step's o_t)
    p = explorer.pos[0]  # the cell's position, then the next's
    p_1 = explorer.pos[1]
    q = explorer.pos[2]
    off = explorer.pos[3]
    dims = p.shape[0]
    for w in range(w0, w1):
        c = nth_free_cell(cells.free, randint(keys[0], w, explorer.n_free))
        position(c, cells.n, p)
        observe(p, origin, scale, o_t)
        sense(cells, c, dims, o_t)
        visit(visited, n_visited, c)
        t_expl = threshold(w, explorer.n_expl)
        begin_walk(learner)
        total = 0.0
        for t in range(steps):
            a = choose_action(explorer.code, cells, visited, n_visited[0], c, p, t_expl,
                              keys[1], w * steps + t, novelty, best, q, off)
            for k in range(dims):
                p_1[k] = p[k] + table[a, k]
            c += cells.offsets[a]
            observe(p_1, origin, scale, o_1)
            sense(cells, c, dims, o_1)
            total += learn(learner, o_t, o_1, a)
            p, p_1 = p_1, p
            o_t, o_1 = o_1, o_t
            visit(visited, n_visited, c)
        total += end_walk(learner)
        errors[w] = total / steps


# the factored learner ---------------------------------------------------------------------
class FactoredLearner(NamedTuple):
    """The per-walk schedule on float64 weights through the accumulators of the module
    docstring. Two more exact rearrangements keep a step to a few additions: the
    affordance term of A, sum_t g(o_t) o_t^T, is summed per visited cell
    (n_cell g(o_cell) o_cell^T, one sigmoid per cell and walk instead of one per step), and
    the training error ||e_t|| = ||W_q delta_a - W_v a|| depends only on the action, so it
    is formed once per action and walk (delta_a = the move's displacement / obs_scale)."""

    Wq: np.ndarray
    Wk: np.ndarray
    Wv: np.ndarray
    lr: np.ndarray  # float64[3]: lr_q, lr_k, lr_v
    frame: np.ndarray  # float64[2]: obs_origin, obs_scale
    table: np.ndarray  # int64 (n_a, n_i): each action's displacement
    n: int  # the arena's side
    M: np.ndarray  # (n_a, n_i) W_k W_q, per walk
    err_a: np.ndarray  # (n_a) ||W_q delta_a - W_v a||, per walk
    E: np.ndarray  # (n_a, n_i) sum a_t o_t^T
    B: np.ndarray  # (n_i, n_a)
    cnt: np.ndarray  # (n_a) n
    C: np.ndarray  # (n_i, n_i)
    D: np.ndarray  # (n_a, n_i)
    visits: np.ndarray  # (cells,) int64: steps from each cell in this walk
    cells: np.ndarray  # (cells,) int64: the cells visited, in order
    n_cells: np.ndarray  # int64[1]
    o: np.ndarray  # (n_i) work vector
    p: np.ndarray  # (n_i) int64 work vector: a cell's position

    @classmethod
    def of(cls, cml: CML, arena: GridArena) -> FactoredLearner:
        c = cml.config
        n_a, n_i = c.n_a, c.n_i
        cells = arena.size ** arena.dims
        return cls(cml.W_q.state.W, cml.W_k.state.W, cml.W_v.state.W,
                   np.array([c.lr_q, c.lr_k, c.lr_v]), np.array([c.obs_origin, c.obs_scale]),
                   arena.move_table, arena.size, np.zeros((n_a, n_i)), np.zeros(n_a),
                   np.zeros((n_a, n_i)), np.zeros((n_i, n_a)), np.zeros(n_a),
                   np.zeros((n_i, n_i)), np.zeros((n_a, n_i)), np.zeros(cells, np.int64),
                   np.zeros(cells, np.int64), np.zeros(1, np.int64), np.zeros(n_i),
                   np.zeros(n_i, np.int64))


@allocates  # (matrix products)
def factored_begin_walk(fl):
    Wq = fl.Wq
    Wv = fl.Wv
    scale = fl.frame[1]
    copy_matrix(fl.M, fl.Wk @ Wq)
    for a in range(fl.err_a.shape[0]):
        sq = 0.0
        for r in range(Wq.shape[0]):
            e = 0.0
            for k in range(Wq.shape[1]):
                e += Wq[r, k] * (fl.table[a, k] / scale)
            e -= Wv[r, a]
            sq += e * e
        fl.err_a[a] = math.sqrt(sq)
    fl.E[:] = 0.0
    fl.B[:] = 0.0
    fl.cnt[:] = 0.0
    fl.C[:] = 0.0
    fl.D[:] = 0.0
    fl.n_cells[0] = 0


@njit(cache=True, inline="always")
def factored_learn(fl, o_t, o_1, a):
    n_i = o_t.shape[0]
    for i in range(n_i):
        di = o_1[i] - o_t[i]
        fl.E[a, i] += o_t[i]
        fl.B[i, a] += di
        fl.D[a, i] += o_1[i]
        for j in range(n_i):
            fl.C[i, j] += di * o_1[j]
    fl.cnt[a] += 1.0
    # the cell of o_t (the frame maps cells to observations one to one)
    c = 0
    for i in range(n_i):
        c = c * fl.n + int(round(o_t[i] * fl.frame[1] + fl.frame[0]))
    if fl.visits[c] == 0:
        fl.cells[fl.n_cells[0]] = c
        fl.n_cells[0] += 1
    fl.visits[c] += 1
    return 0.0


@allocates  # (matrix products)
def factored_end_walk(fl):
    Wq = fl.Wq
    Wk = fl.Wk
    Wv = fl.Wv
    M = fl.M
    o = fl.o
    A = fl.E.copy()  # A = sum (a_t - g_t) o_t^T
    for i in range(fl.n_cells[0]):
        c = fl.cells[i]
        m = fl.visits[c]
        fl.visits[c] = 0
        position(c, fl.n, fl.p)
        observe(fl.p, fl.frame[0], fl.frame[1], o)
        for r in range(M.shape[0]):
            z = 0.0
            for j in range(o.shape[0]):
                z += M[r, j] * o[j]
            g = m / (1.0 + math.exp(-z))
            for j in range(o.shape[0]):
                A[r, j] -= g * o[j]
    total = 0.0
    for a in range(fl.cnt.shape[0]):
        total += fl.cnt[a] * fl.err_a[a]
    lr_q, lr_k, lr_v = fl.lr[0], fl.lr[1], fl.lr[2]
    Wk += lr_k * (A @ Wq.T)
    dWv = lr_v * (Wq @ fl.B - Wv * fl.cnt)
    Wq += lr_q * (Wv @ fl.D - Wq @ fl.C)
    Wv += dWv
    return total


begin_walk.register(FactoredLearner, factored_begin_walk)
learn.register(FactoredLearner, factored_learn)
end_walk.register(FactoredLearner, factored_end_walk)
