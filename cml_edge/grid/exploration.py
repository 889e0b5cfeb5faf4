"""Exploration during training (paper 2.2): random walks and the mixed novelty strategy.

- random: a uniformly random available move (Stöckl et al. 2022);
- mixed: with probability t_expl (Eq. 5) the move whose destination maximises the
  novelty of Eq. 4, the sum of Euclidean distances to the k = 5 nearest previously
  visited locations; otherwise a random move.

Choices the paper leaves open, made here: "visited" is the set of distinct cells
visited since training began (all walks); walk ``i`` counts from 0, so the first walk
has t_expl = 1 (purely novelty-driven, the paper's Figure 2C) and walk N_expl + 1
onwards is purely random (Figure 2D); ties in novelty are broken uniformly at random.

The nearest-neighbour search is a compiled grid index (:func:`knn_novelty`): it scans
Chebyshev rings around the query and stops as soon as no unscanned ring can hold a
closer point; the Python reference path uses scipy's cKDTree instead, and the tests
check the two agree.

Randomness: walk ``w`` starts on the free cell drawn at counter w of the walk-start
stream; step ``n`` of training draws at counters 4n (threshold), 4n + 1 (random move) and
4n + 2 (novelty tie-break) of the exploration stream.

The training loop (:func:`cml_edge.grid.training.train_loop`) explores through three
functions routed by the explorer's type: :func:`start_walk`, :func:`explore` and
:func:`visit`; :class:`GridExplorer` is the compiled explorer, :class:`ReferenceExplorer`
the reference path's.
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np
from numba import njit
from scipy.spatial import cKDTree

from cml_edge.errors import InputError
from cml_edge.grid.arena import MOVES, N_ACTIONS, NTH_MOVE, POPCOUNT, GridArena
from cml_edge.protocol import STREAM_EXPLORE, STREAM_WALK_START
from cml_edge.rng import randint, stream_key, uniform
from cml_edge.routing import routed

EXPLORATIONS = ("random", "mixed")
RANDOM, MIXED = 0, 1
K_NEAREST = 5
N_EXPL_FRACTION = 0.3


def explore_code(name: str) -> int:
    """The integer code of an exploration name; ValueError naming the allowed names."""
    if name not in EXPLORATIONS:
        raise InputError(f"unknown exploration {name!r}; allowed: {', '.join(EXPLORATIONS)}")
    return EXPLORATIONS.index(name)


@njit(cache=True)
def threshold(walk, n_expl):
    """Eq. 5: t_expl = 1 - walk / N_expl for walk <= N_expl, else 0 (walk counts from 0)."""
    if n_expl <= 0 or walk > n_expl:
        return 0.0
    return 1.0 - walk / n_expl


@njit(cache=True)
def random_action(moves, u):
    """The floor(u * n)-th of the n moves in bitmask ``moves`` (uniform for u ~ U[0, 1))."""
    n = POPCOUNT[moves]
    return NTH_MOVE[moves, min(int(u * n), n - 1)]


@njit(cache=True)
def knn_novelty(visited, n_visited, x, y, k, best):
    """Eq. 4 with a grid index: sum of distances from (x, y) to its k nearest visited cells.

    ``visited`` is a uint8 (N, N) grid of visited cells, ``n_visited`` their number and
    ``best`` a float64 work buffer of length >= k. The distances are summed in
    ascending order (as the reference sums cKDTree's sorted output).
    """
    m = min(k, n_visited)
    if m == 0:
        return 0.0
    n = visited.shape[0]
    for i in range(m):
        best[i] = np.inf
    found = 0
    r = 0
    while True:
        for dx in range(-r, r + 1):
            edge = abs(dx) == r
            step = 1 if edge else 2 * r
            dy = -r
            while dy <= r:
                cx = x + dx
                cy = y + dy
                if 0 <= cx < n and 0 <= cy < n and visited[cx, cy]:
                    found += 1
                    d = math.sqrt(dx * dx + dy * dy)
                    if d < best[m - 1]:
                        i = m - 1
                        while i > 0 and best[i - 1] > d:
                            best[i] = best[i - 1]
                            i -= 1
                        best[i] = d
                dy += step
        if found >= m and best[m - 1] <= r + 1:
            break
        r += 1
        if r > 2 * n:
            break
    total = 0.0
    for i in range(m):
        total += best[i]
    return total


@njit(cache=True)
def novelty_action(visited, n_visited, x, y, moves, u_tie, novelty, best):
    """The move in bitmask ``moves`` whose destination is most novel (Eq. 4); ties by u_tie."""
    top = -1.0
    for a in range(N_ACTIONS):
        if moves >> a & 1:
            novelty[a] = knn_novelty(visited, n_visited, x + MOVES[a, 0], y + MOVES[a, 1],
                                     K_NEAREST, best)
            if novelty[a] > top:
                top = novelty[a]
    ties = 0
    for a in range(N_ACTIONS):
        if moves >> a & 1 and novelty[a] == top:
            ties |= 1 << a
    return random_action(ties, u_tie)


@njit(cache=True)
def choose_action(explore, masks, visited, n_visited, x, y, t_expl, key, step, novelty, best):
    """The exploration move at global training step ``step`` (both strategies).

    ``masks`` is the arena's per-cell bitmask of available moves
    (:func:`cml_edge.arena.move_masks`); -1 when no move is available.
    """
    moves = masks[x, y]
    if moves == 0:
        return -1
    ctr = np.uint64(4) * np.uint64(step)
    if explore == MIXED and uniform(key, ctr) < t_expl:
        return novelty_action(visited, n_visited, x, y, moves,
                              uniform(key, ctr + np.uint64(2)), novelty, best)
    return random_action(moves, uniform(key, ctr + np.uint64(1)))


@njit(cache=True)
def nth_free_cell(free, idx):
    """The idx-th free cell in row-major (x, then y) order: a walk's start."""
    n = free.shape[0]
    for x in range(n):
        for y in range(n):
            if free[x, y]:
                if idx == 0:
                    return x, y
                idx -= 1
    return -1, -1


class VisitedSet:
    """The reference path's visited set: distinct cells, queried with scipy's cKDTree."""

    def __init__(self) -> None:
        self.cells: list[tuple[int, int]] = []
        self._seen: set[tuple[int, int]] = set()
        self._tree: cKDTree | None = None

    def add(self, x: int, y: int) -> None:
        if (x, y) not in self._seen:
            self._seen.add((x, y))
            self.cells.append((x, y))
            self._tree = None

    def novelty(self, x: int, y: int, k: int = K_NEAREST) -> float:
        """Eq. 4: sum of distances to the k nearest visited cells, summed in ascending order."""
        m = min(k, len(self.cells))
        if m == 0:
            return 0.0
        if self._tree is None:
            self._tree = cKDTree(np.array(self.cells, dtype=np.float64))
        dist, _ = self._tree.query([float(x), float(y)], k=m)
        total = 0.0
        for d in np.atleast_1d(dist):
            total += float(d)
        return total


def choose_action_reference(explore: int, arena: GridArena, visited: VisitedSet, x: int, y: int,
                            t_expl: float, key, step: int) -> int:
    """Plain-Python twin of :func:`choose_action`, with cKDTree novelty."""
    moves = [a for a in range(N_ACTIONS) if arena.is_free((x + MOVES[a, 0], y + MOVES[a, 1]))]
    if not moves:
        return -1
    ctr = 4 * step
    if explore == MIXED and uniform(key, ctr) < t_expl:
        novelty = {a: visited.novelty(x + MOVES[a, 0], y + MOVES[a, 1]) for a in moves}
        top = max(novelty.values())
        moves = [a for a, v in novelty.items() if v == top]
        u = uniform(key, ctr + 2)
    else:
        u = uniform(key, ctr + 1)
    return moves[min(int(u * len(moves)), len(moves) - 1)]


# the explorer plug-ins of the training loop --------------------------------------------------
@routed
def start_walk(explorer, w):
    """Walk ``w`` starts: its start cell (x, y), visited; its t_expl (Eq. 5) is set."""


@routed
def explore(explorer, x, y, step):
    """The exploration move from (x, y) at global training step ``step``."""


@routed
def visit(explorer, x, y):
    """The agent has arrived at (x, y)."""


class GridExplorer(NamedTuple):
    """The compiled explorer: the visited cells as a grid, novelty by the grid index."""

    free: np.ndarray  # uint8 (N, N)
    masks: np.ndarray  # uint8 (N, N) available moves per cell
    visited: np.ndarray  # uint8 (N, N), since training began
    n_visited: np.ndarray  # int64[1]
    keys: np.ndarray  # uint64[2]: the walk-start and exploration streams
    n_free: int
    code: int  # RANDOM or MIXED
    n_expl: int  # N_expl of Eq. 5
    t_expl: np.ndarray  # float64[1]: this walk's threshold
    novelty: np.ndarray  # float64[N_ACTIONS] work vector
    best: np.ndarray  # float64[K_NEAREST] work vector

    @classmethod
    def of(cls, arena: GridArena, config: Any, seed: int) -> GridExplorer:
        free = arena.free
        return cls(free, arena.move_masks, np.zeros_like(free), np.zeros(1, np.int64),
                   _keys(seed), int(free.sum()), explore_code(config.explore), config.n_expl,
                   np.zeros(1), np.zeros(N_ACTIONS), np.zeros(K_NEAREST))


def _keys(seed: int) -> np.ndarray:
    return np.array([stream_key(seed, STREAM_WALK_START), stream_key(seed, STREAM_EXPLORE)],
                    dtype=np.uint64)


@njit(cache=True, inline="always")
def grid_visit(ex, x, y):
    if not ex.visited[x, y]:
        ex.visited[x, y] = 1
        ex.n_visited[0] += 1


@njit(cache=True, inline="always")
def grid_start_walk(ex, w):
    x, y = nth_free_cell(ex.free, randint(ex.keys[0], w, ex.n_free))
    grid_visit(ex, x, y)
    ex.t_expl[0] = threshold(w, ex.n_expl)
    return x, y


@njit(cache=True, inline="always")
def grid_explore(ex, x, y, step):
    return choose_action(ex.code, ex.masks, ex.visited, ex.n_visited[0], x, y, ex.t_expl[0],
                         ex.keys[1], step, ex.novelty, ex.best)


class ReferenceExplorer:
    """The reference path's explorer: a Python set of visited cells, cKDTree novelty."""

    def __init__(self, arena: GridArena, config: Any, seed: int) -> None:
        self.arena = arena
        self.free = arena.free
        self.n_free = int(self.free.sum())
        self.keys = _keys(seed)
        self.code = explore_code(config.explore)
        self.n_expl = config.n_expl
        self.visited = VisitedSet()
        self.t_expl = 0.0

    def start_walk(self, w: int) -> tuple[int, int]:
        x, y = nth_free_cell(self.free, randint(self.keys[0], w, self.n_free))
        self.visited.add(x, y)
        self.t_expl = threshold(w, self.n_expl)
        return x, y

    def explore(self, x: int, y: int, step: int) -> int:
        return choose_action_reference(self.code, self.arena, self.visited, int(x), int(y),
                                       self.t_expl, self.keys[1], step)

    def visit(self, x: int, y: int) -> None:
        self.visited.add(int(x), int(y))


start_walk.register(GridExplorer, grid_start_walk)
explore.register(GridExplorer, grid_explore)
visit.register(GridExplorer, grid_visit)
start_walk.register(ReferenceExplorer, ReferenceExplorer.start_walk)
explore.register(ReferenceExplorer, ReferenceExplorer.explore)
visit.register(ReferenceExplorer, ReferenceExplorer.visit)
