"""Planning on the grid (paper 2.1): WTA over utility x affordance, blocked moves masked.

At each step the agent reads d = W_q (o* - o) (= s* - s, one read), the utility
u = W_v^T d (the transposed read of W_v; the paper's stand-in for W_v^-1 d), divided
by W_v's column norms unless the utility is ``raw``, and the affordance
g = sigmoid(W_k W_q o). The winner-take-all picks, among the moves available now, the
one with the largest u * g (first index on a tie): a move into an obstacle or off the
arena is not available, which is the paper's reactive obstacle handling. It stops on
the goal or after ``max_steps`` actions, or when no move is available.

:func:`plan_loop` states planning once; the scorer (how u and u * g are read) and the
chooser (what is done with them) are plug-ins routed by type:

- scorers (:mod:`cml_edge.core.step`): the seam's (``direct``, compiled, any device),
  the CML's Python methods (``reference``, the loop's plain-Python ``py_func``,
  bit-identical to ``direct``), or the factored maps of float64 arrays (``factored``);
- choosers (``planner=``): :class:`WTA`, the paper's, or
  :class:`~cml_edge.grid.escape.Escape`, the paper's WTA plus a reactive escape when it
  would revisit a cell (:mod:`cml_edge.grid.escape`).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from cml_edge.core.cml import CML, ReferenceScorer
from cml_edge.core.step import FactoredScorer, SeamScorer, prepare, scores, wta
from cml_edge.engine.stop import chunks
from cml_edge.errors import InputError
from cml_edge.grid.arena import GridArena, cell_at, observe, sense, unpack_moves
from cml_edge.grid.escape import WALL_NEXT, Escape, escape_choose, escape_reset
from cml_edge.jit.kernel import kernel
from cml_edge.jit.routing import routed

PATHS = ("reference", "direct", "factored")
PLANNERS = ("paper", "escape")
MAX_STEPS = 100

__all__ = ["MAX_STEPS", "PATHS", "PLANNERS", "WALL_NEXT", "PlanResult", "plan", "plan_loop"]


class PlanResult(NamedTuple):
    """Per trial: final position, actions taken, and the visited path (padded with -1)."""

    final: np.ndarray  # (trials, dims)
    steps: np.ndarray  # (trials,)
    paths: np.ndarray  # (trials, max_steps + 1, dims)
    work: tuple  # a decision's work arrays (decision_buffers)

    @classmethod
    def empty(cls, trials: int, max_steps: int, arena: GridArena) -> PlanResult:
        """The result arrays of ``trials`` plans on ``arena`` (paths all -1) and the work
        arrays."""
        dims = arena.dims
        return cls(np.zeros((trials, dims), np.int64), np.zeros(trials, np.int64),
                   np.full((trials, max_steps + 1, dims), -1, np.int64),
                   decision_buffers(arena))


def decision_buffers(arena: GridArena) -> tuple:
    """The work arrays of one decision on ``arena``: o and o* - o (position and sensor
    inputs), u, the scores, the available moves, the position and the goal's."""
    dims, n_a, n_i = arena.dims, arena.n_actions, arena.dims + arena.n_sensors
    return (np.zeros(n_i), np.zeros(n_i), np.zeros(n_a), np.zeros(n_a),
            np.zeros(n_a, dtype=np.uint8), np.zeros(dims, np.int64), np.zeros(dims, np.int64))


class WTA(NamedTuple):
    """The paper's planner: winner-take-all over utility x affordance, nothing to remember."""


@routed
def reset(chooser):
    """A new plan starts."""


@routed
def choose(chooser, cells, c, p, u, score, norms, gram, mask):
    """The move from cell ``c`` at position ``p`` of ``cells`` given the raw utility ``u``,
    the scores u / norms x g, W_v's Gram matrix and the available moves ``mask``."""


@njit(cache=True, inline="always")
def wta_reset(chooser):
    pass


@njit(cache=True, inline="always")
def wta_choose(chooser, cells, c, p, u, score, norms, gram, mask):
    return wta(score, mask)


reset.register(WTA, wta_reset)
choose.register(WTA, wta_choose)
reset.register(Escape, escape_reset)
choose.register(Escape, escape_choose)


def plan(cml: CML, arena: GridArena, starts: np.ndarray, goals: np.ndarray,
         max_steps: int = MAX_STEPS, path: str = "direct", planner: str = "paper") -> PlanResult:
    """Plan from each start to its goal on ``arena`` with ``planner`` (module docstring)."""
    if path not in PATHS:
        raise InputError(f"unknown path {path!r}; allowed: {', '.join(PATHS)}")
    if planner not in PLANNERS:
        raise InputError(f"unknown planner {planner!r}; allowed: {', '.join(PLANNERS)}")
    if path == "factored" and not all(getattr(a, "supports_factored", False)
                                      for a in cml.arrays):
        raise InputError("the factored path needs float64 arrays")
    arena.check_inputs(cml.config.n_i)
    starts = np.ascontiguousarray(starts, dtype=np.int64).reshape(-1, arena.dims)
    goals = np.ascontiguousarray(goals, dtype=np.int64).reshape(-1, arena.dims)
    n = len(starts)
    res = PlanResult.empty(n, max_steps, arena)
    scorer = {"reference": ReferenceScorer, "direct": SeamScorer.of,
              "factored": FactoredScorer.of}[path](cml)
    chooser = Escape.of(arena, max_steps) if planner == "escape" else WTA()
    loop = plan_loop.py_func if path == "reference" else plan_loop
    c = cml.config
    cells = arena.cells()
    for t0, t1 in chunks(0, n, max_steps):
        loop(scorer, chooser, cells, c.obs_origin, c.obs_scale, c.utility == "normalized",
             planner == "escape", starts, goals, t0, t1, max_steps, res)
    return res


@njit(cache=True, inline="always")
def decision_inputs(cells, c, p, g, origin, scale, o, dgo):
    """o and o* - o at cell ``c`` (position ``p``) of ``cells`` for the goal at ``g``: the
    planning inputs (o* - o is read through W_q once). The goal's range-sensor inputs are
    those of open space, zero (:mod:`cml_edge.grid.sensors`)."""
    dims = p.shape[0]
    observe(g, origin, scale, dgo)
    observe(p, origin, scale, o)
    sense(cells, c, dims, o)
    for i in range(dims):
        dgo[i] -= o[i]
    for i in range(dims, o.shape[0]):
        dgo[i] = -o[i] * cells.open_goal


@kernel
def plan_loop(scorer, chooser, cells, origin, scale, normalize, gram, starts, goals, t0, t1,
              max_steps, res):
    """Plan (start, goal) pairs ``t0 .. t1 - 1`` (the module docstring) on ``cells``
    (:meth:`~cml_edge.grid.arena.GridArena.cells`), for any scorer and chooser. A
    :func:`~cml_edge.jit.kernel.kernel`: no decision pays reference counts."""
    if t0 == 0:
        prepare(scorer, normalize, gram)  # W_v's columns, read once per batch
    norms, K = scorer.norms, scorer.gram
    o, dgo, u, score, mask, p, g = res.work
    table = cells.table
    dims = p.shape[0]
    for trial in range(t0, t1):
        reset(chooser)
        for k in range(dims):
            p[k] = starts[trial, k]
            g[k] = goals[trial, k]
            res.paths[trial, 0, k] = p[k]
        c = cell_at(p, cells.n)
        goal = cell_at(g, cells.n)
        taken = 0
        while taken < max_steps and c != goal:
            decision_inputs(cells, c, p, g, origin, scale, o, dgo)
            scores(scorer, o, dgo, u, score)
            if unpack_moves(cells.masks[c], mask) == 0:
                break
            a = choose(chooser, cells, c, p, u, score, norms, K, mask)
            c += cells.offsets[a]
            taken += 1
            for k in range(dims):
                p[k] += table[a, k]
                res.paths[trial, taken, k] = p[k]
        for k in range(dims):
            res.final[trial, k] = p[k]
        res.steps[trial] = taken
