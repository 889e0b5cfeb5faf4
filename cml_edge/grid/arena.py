"""Grid arenas (paper 2.1, 3.4): N x N integer positions, 8 king moves, point obstacles.

Positions are (x, y) with 0 <= x, y < N; ``blocked[x, y]`` marks an obstacle. A move
that would leave the arena or enter an obstacle is unavailable: the agent never
leaves the arena and never stands on an obstacle. ``MOVES[a]`` is the displacement
of action ``a``, counter-clockwise from east.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from cml_edge.errors import InputError

MOVES = np.array(
    [[1, 0], [1, 1], [0, 1], [-1, 1], [-1, 0], [-1, -1], [0, -1], [1, -1]], dtype=np.int64
)
N_ACTIONS = 8


def _bit_tables() -> tuple[np.ndarray, np.ndarray]:
    popcount = np.array([bin(m).count("1") for m in range(256)], dtype=np.int64)
    nth = np.full((256, N_ACTIONS), -1, dtype=np.int64)
    for m in range(256):
        for r, a in enumerate(a for a in range(N_ACTIONS) if m >> a & 1):
            nth[m, r] = a
    return popcount, nth


# POPCOUNT[m]: how many moves mask m allows; NTH_MOVE[m, r]: the r-th of them, ascending.
POPCOUNT, NTH_MOVE = _bit_tables()


@njit(cache=True)
def move_masks(free):
    """uint8 (N, N): bit a of cell (x, y) is set when move a from there is available.

    Computed once per arena, it makes "which moves are available" one lookup in the
    compiled loops.
    """
    n = free.shape[0]
    masks = np.zeros((n, n), dtype=np.uint8)
    for x in range(n):
        for y in range(n):
            m = 0
            for a in range(N_ACTIONS):
                nx = x + MOVES[a, 0]
                ny = y + MOVES[a, 1]
                if 0 <= nx < n and 0 <= ny < n and free[nx, ny] != 0:
                    m |= 1 << a
            masks[x, y] = m
    return masks


@njit(cache=True)
def available_moves(free, x, y, mask):
    """mask[a] = 1 where move a from (x, y) stays on a free cell; returns their number."""
    n = free.shape[0]
    count = 0
    for a in range(N_ACTIONS):
        nx = x + MOVES[a, 0]
        ny = y + MOVES[a, 1]
        ok = 0 <= nx < n and 0 <= ny < n and free[nx, ny] != 0
        mask[a] = 1 if ok else 0
        count += mask[a]
    return count


@njit(cache=True, inline="always")
def observe(x, y, origin, scale, out):
    """The observation of cell (x, y): o = (p - origin) / scale (the CML's frame,
    :class:`cml_edge.core.cml.CMLConfig`'s ``obs_origin`` and ``obs_scale``)."""
    out[0] = (x - origin) / scale
    out[1] = (y - origin) / scale


def chebyshev(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Chebyshev distance max(|dx|, |dy|): the fewest king moves on an empty grid."""
    d = np.abs(np.asarray(p) - np.asarray(q))
    return d.max(axis=-1)


@dataclass(frozen=True, eq=False)
class GridArena:
    """An N x N grid; ``blocked`` is a bool (N, N) array indexed [x, y]."""

    size: int
    blocked: np.ndarray

    def __post_init__(self) -> None:
        if int(self.size) != self.size or self.size < 2:
            raise InputError(f"arena size {self.size!r} is not an integer >= 2")
        if self.blocked.shape != (self.size, self.size):
            raise InputError(f"blocked has shape {self.blocked.shape}, expected "
                             f"({self.size}, {self.size})")

    @classmethod
    def empty(cls, size: int = 30) -> GridArena:
        _check_size(size)
        return cls(int(size), np.zeros((size, size), dtype=bool))

    @classmethod
    def with_obstacles(cls, size: int, n_obstacles: int, seed: int) -> GridArena:
        """``n_obstacles`` point obstacles on distinct cells drawn uniformly from ``seed``."""
        _check_size(size)
        if int(n_obstacles) != n_obstacles or not 0 <= n_obstacles <= size * size - 2:
            raise InputError(f"obstacles {n_obstacles!r} is not an integer in 0..{size * size - 2}")
        cells = np.random.default_rng(seed).choice(size * size, size=int(n_obstacles),
                                                   replace=False)
        blocked = np.zeros(size * size, dtype=bool)
        blocked[cells] = True
        return cls(int(size), blocked.reshape(size, size))

    @property
    def free(self) -> np.ndarray:
        """uint8 (N, N): 1 where the agent may stand (what compiled loops take)."""
        return (~self.blocked).astype(np.uint8)

    @property
    def move_masks(self) -> np.ndarray:
        """Per-cell bitmask of the available moves (see :func:`move_masks`)."""
        return move_masks(self.free)

    @property
    def n_obstacles(self) -> int:
        return int(self.blocked.sum())

    def contains(self, pos) -> bool:
        x, y = pos
        return 0 <= x < self.size and 0 <= y < self.size

    def is_free(self, pos) -> bool:
        return self.contains(pos) and not self.blocked[pos[0], pos[1]]

    def available(self, pos) -> np.ndarray:
        """Bool mask of the moves available from ``pos``."""
        mask = np.zeros(N_ACTIONS, dtype=np.uint8)
        available_moves(self.free, int(pos[0]), int(pos[1]), mask)
        return mask.astype(bool)

    def geodesic(self, source) -> np.ndarray:
        """BFS distances (8-connected king moves) from ``source``; -1 where unreachable."""
        dist = np.full((self.size, self.size), -1, dtype=np.int64)
        if self.is_free(source):
            bfs_distances(self.free, int(source[0]), int(source[1]), dist,
                          np.zeros((self.size * self.size, 2), np.int64))
        return dist


@njit(cache=True)
def bfs_distances(free, sx, sy, dist, queue):
    """Breadth-first search from the free cell (sx, sy) over the free cells, by the 8 king
    moves (:func:`available_moves`): dist[x, y] = the fewest moves to (x, y), left as it
    is (-1) where no path reaches; ``queue``: int64 (cells, 2) scratch."""
    mask = np.zeros(N_ACTIONS, np.uint8)
    dist[sx, sy] = 0
    queue[0, 0] = sx
    queue[0, 1] = sy
    head = 0
    tail = 1
    while head < tail:
        x = queue[head, 0]
        y = queue[head, 1]
        head += 1
        available_moves(free, x, y, mask)
        for a in range(N_ACTIONS):
            nx = x + MOVES[a, 0]
            ny = y + MOVES[a, 1]
            if mask[a] and dist[nx, ny] < 0:
                dist[nx, ny] = dist[x, y] + 1
                queue[tail, 0] = nx
                queue[tail, 1] = ny
                tail += 1


def _check_size(size) -> None:
    if isinstance(size, bool) or int(size) != size or size < 2:
        raise InputError(f"arena size {size!r} is not an integer >= 2")
