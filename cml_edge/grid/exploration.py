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
Chebyshev rings (shells, in three dimensions) around the query and stops as soon as no
unscanned ring can hold a closer point; the tests check it against scipy's cKDTree.

Randomness: walk ``w`` starts on the free cell drawn at counter w of the walk-start
stream; step ``n`` of training draws at counters 4n (threshold), 4n + 1 (random move) and
4n + 2 (novelty tie-break) of the exploration stream.

Every compute path of the training loop (:func:`cml_edge.grid.training.train_loop`)
explores with these compiled functions, so the walks are the same on every path.
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np
from numba import njit

from cml_edge.errors import InputError
from cml_edge.grid.arena import Cells, GridArena, nth_move
from cml_edge.jit.rng import stream_key, uniform
from cml_edge.jit.simd import popcount
from cml_edge.protocol import STREAM_EXPLORE, STREAM_WALK_START

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


def _byte_tables() -> tuple[np.ndarray, np.ndarray]:
    popcount_ = np.array([bin(m).count("1") for m in range(256)], dtype=np.int64)
    nth = np.full((256, 8), -1, dtype=np.int64)
    for m in range(256):
        for r, a in enumerate(a for a in range(8) if m >> a & 1):
            nth[m, r] = a
    return popcount_, nth


# BYTE_COUNT[m]: the moves a mask m < 256 allows; BYTE_NTH[m, r]: the r-th of them, ascending
BYTE_COUNT, BYTE_NTH = _byte_tables()


@njit(cache=True)
def random_action(moves, u):
    """The floor(u * n)-th of the n moves in bitmask ``moves`` (uniform for u ~ U[0, 1)):
    two table lookups for the plane's masks (a byte; the choice is random, so a loop over
    the bits would mispredict), the bits counted and walked for larger ones."""
    if moves < 256:
        n = BYTE_COUNT[moves]
        return BYTE_NTH[moves, min(int(u * n), n - 1)]
    n = popcount(moves)
    return nth_move(moves, min(int(u * n), n - 1))


@njit(cache=True)
def knn_novelty(visited, n_visited, q, n, k, best, off):
    """Eq. 4 with a grid index: sum of distances from position ``q`` to its k nearest
    visited cells. ``visited`` is a uint8 grid of visited cells by cell number (side ``n``),
    ``n_visited`` their number, ``best`` a float64 work buffer of length >= k and ``off`` an
    int64 one of q's length. Scans Chebyshev shells of radius r = 0, 1, ... around q (each
    shell's offsets in lexicographic order, the interior skipped); the distances are summed
    in ascending order (as scipy's cKDTree returns them).
    """
    m = min(k, n_visited)
    if m == 0:
        return 0.0
    dims = q.shape[0]
    for i in range(m):
        best[i] = np.inf
    found = 0
    r = 0
    while True:
        for i in range(dims):
            off[i] = -r
        while True:
            inside = True
            c = 0
            sq = 0
            for i in range(dims):
                v = q[i] + off[i]
                if v < 0 or v >= n:
                    inside = False
                c = c * n + v
                sq += off[i] * off[i]
            if inside and visited[c]:
                found += 1
                d = math.sqrt(sq)
                if d < best[m - 1]:
                    i = m - 1
                    while i > 0 and best[i - 1] > d:
                        best[i] = best[i - 1]
                        i -= 1
                    best[i] = d
            # the next offset of the shell: the last axis steps by 2r unless an earlier
            # axis is on the shell's face
            i = dims - 1
            while i >= 0:
                edge = False
                for j in range(i):
                    if abs(off[j]) == r:
                        edge = True
                step = 1 if edge or i < dims - 1 else 2 * r
                if step > 0 and off[i] + step <= r:
                    off[i] += step
                    break
                off[i] = -r
                i -= 1
            if i < 0:
                break
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
def novelty_action(visited, n_visited, p, cells, moves, u_tie, novelty, best, q, off):
    """The move in bitmask ``moves`` whose destination is most novel (Eq. 4); ties by
    u_tie. ``q`` and ``off``: int64 work vectors of p's length."""
    table = cells.table
    top = -1.0
    for a in range(table.shape[0]):
        if moves >> a & 1:
            for i in range(p.shape[0]):
                q[i] = p[i] + table[a, i]
            novelty[a] = knn_novelty(visited, n_visited, q, cells.n, K_NEAREST, best, off)
            if novelty[a] > top:
                top = novelty[a]
    ties = 0
    for a in range(table.shape[0]):
        if moves >> a & 1 and novelty[a] == top:
            ties |= 1 << a
    return random_action(ties, u_tie)


@njit(cache=True)
def choose_action(explore, cells, visited, n_visited, c, p, t_expl, key, step, novelty, best,
                  q, off):
    """The exploration move from cell ``c`` at position ``p`` at global training step
    ``step`` (both strategies), among the arena's available moves
    (:meth:`cml_edge.grid.arena.GridArena.cells`); -1 when no move is available.
    """
    moves = np.int64(cells.masks[c])
    if moves == 0:
        return -1
    ctr = np.uint64(4) * np.uint64(step)
    if explore == MIXED and uniform(key, ctr) < t_expl:
        return novelty_action(visited, n_visited, p, cells, moves,
                              uniform(key, ctr + np.uint64(2)), novelty, best, q, off)
    return random_action(moves, uniform(key, ctr + np.uint64(1)))


@njit(cache=True)
def nth_free_cell(free, idx):
    """The idx-th free cell in C order (x, then y, then z): a walk's start; -1 if none."""
    for c in range(free.shape[0]):
        if free[c]:
            if idx == 0:
                return c
            idx -= 1
    return -1


# the exploration state of a training run -------------------------------------------------------
class GridExplorer(NamedTuple):
    """What exploration remembers across the walks of one training run (the visited cells
    since training began, Eq. 4) and the arena and streams it draws from. The training loop
    (:func:`cml_edge.grid.training.train_loop`) unpacks it once and calls
    :func:`choose_action` with its arrays."""

    cells: Cells  # the arena
    visited: np.ndarray  # uint8 (cells,), since training began
    n_visited: np.ndarray  # int64[1]
    keys: np.ndarray  # uint64[2]: the walk-start and exploration streams
    n_free: int
    code: int  # RANDOM or MIXED
    n_expl: int  # N_expl of Eq. 5
    novelty: np.ndarray  # float64[n_actions] work vector
    best: np.ndarray  # float64[K_NEAREST] work vector
    obs: np.ndarray  # float64 (2, dims + K) work vectors: the observations o_t, o_{t+1}
    pos: np.ndarray  # int64 (4, dims) work vectors: p_t, p_{t+1}, a neighbour, an offset

    @classmethod
    def of(cls, arena: GridArena, config: Any, seed: int) -> GridExplorer:
        cells = arena.cells()
        keys = np.array([stream_key(seed, STREAM_WALK_START), stream_key(seed, STREAM_EXPLORE)],
                        dtype=np.uint64)
        return cls(cells, np.zeros_like(cells.free), np.zeros(1, np.int64), keys,
                   int(cells.free.sum()), explore_code(config.explore), config.n_expl,
                   np.zeros(arena.n_actions), np.zeros(K_NEAREST),
                   np.zeros((2, arena.dims + arena.n_sensors)),
                   np.zeros((4, arena.dims), np.int64))


@njit(cache=True, inline="always")
def visit(visited, n_visited, c):
    """Mark cell c visited (Eq. 4's set of cells visited since training began)."""
    if not visited[c]:
        visited[c] = 1
        n_visited[0] += 1
