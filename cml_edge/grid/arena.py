"""Grid arenas (paper 2.1, 3.4): N x N (or N x N x N) integer positions, king moves,
point obstacles.

Positions are (x, y), or (x, y, z) in three dimensions, with 0 <= each < N;
``blocked[x, y]`` (``blocked[x, y, z]``) marks an obstacle. A move that would leave the
arena or enter an obstacle is unavailable: the agent never leaves the arena and never
stands on an obstacle. ``MOVES[a]`` is the displacement of action ``a`` on the plane,
counter-clockwise from east; :func:`move_table` gives every arena's actions: the king
moves (8 on the plane, 26 in space: every neighbour sharing a face, an edge or a corner)
or the face moves (4, 6: the axis neighbours only). The third dimension extends the
plane's order: the plane's moves first (z unchanged), then straight up and the plane's
moves one level up, then straight down and the plane's moves one level down; so a 3-D
arena's first actions are the plane's, and an action's effect is its displacement on
every axis, as the paper's section 2 states it on two.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, NamedTuple

import numpy as np
from numba import njit

from cml_edge.errors import InputError

if TYPE_CHECKING:
    from cml_edge.grid.sensors import Sensors

MOVES = np.array(
    [[1, 0], [1, 1], [0, 1], [-1, 1], [-1, 0], [-1, -1], [0, -1], [1, -1]], dtype=np.int64
)
N_ACTIONS = 8
DIMS = (2, 3)
MOVE_SETS = ("king", "face")


def move_table(dims: int = 2, moves: str = "king") -> np.ndarray:
    """int64 (n_actions, dims): the displacement of each action of a ``dims``-dimensional
    arena with the ``moves`` set (module docstring; ``MOVES`` for the plane's king moves)."""
    if dims not in DIMS:
        raise InputError(f"dims {dims!r} is not allowed (allowed: {', '.join(map(str, DIMS))})")
    if moves not in MOVE_SETS:
        raise InputError(f"unknown move set {moves!r}; allowed: {', '.join(MOVE_SETS)}")
    plane = MOVES if moves == "king" else MOVES[0::2]
    if dims == 2:
        return plane.copy()
    rows = [[*m, 0] for m in plane]
    for dz in (1, -1):
        rows.append([0, 0, dz])
        if moves == "king":
            rows += [[*m, dz] for m in plane]
    return np.array(rows, dtype=np.int64)


@njit(cache=True)
def cell_masks(free, n, table, masks):
    """Bit a of ``masks[c]`` set when action a (displacement ``table[a]``) from cell c stays
    on a free cell; cells numbered in ``free``'s order (C order of the arena's shape, side
    ``n``). Computed once per arena, it makes "which moves are available" one lookup in
    the compiled loops."""
    dims = table.shape[1]
    pos = np.zeros(dims, np.int64)
    for c in range(free.shape[0]):
        r = c
        for k in range(dims - 1, -1, -1):
            pos[k] = r % n
            r //= n
        m = 0
        for a in range(table.shape[0]):
            ok = True
            q = 0
            for k in range(dims):
                v = pos[k] + table[a, k]
                if v < 0 or v >= n:
                    ok = False
                    break
                q = q * n + v
            if ok and free[q] != 0:
                m |= 1 << a
        masks[c] = m


class Cells(NamedTuple):
    """An arena as the compiled loops see it: its cells numbered in C order of its shape
    (cell = (x N + y) N + z), a position an int64 vector of its coordinates."""

    free: np.ndarray  # uint8 (cells,): 1 where the agent may stand
    masks: np.ndarray  # uint32 (cells,): bit a set when action a is available (cell_masks)
    table: np.ndarray  # int64 (n_actions, dims): each action's displacement
    offsets: np.ndarray  # int64 (n_actions,): each action's change of the cell number
    n: int  # the side
    readings: np.ndarray  # float64 (cells, K): each cell's range-sensor inputs
    # (:mod:`cml_edge.grid.sensors`; K = 0 without sensors)
    open_goal: float  # 1.0: the goal's sensor inputs are open space's (zero); 0.0: the
    # agent's own (:data:`cml_edge.grid.sensors.GOALS`)


@njit(cache=True, inline="always")
def cell_at(p, n):
    """The number of the cell at position ``p``."""
    c = 0
    for k in range(p.shape[0]):
        c = c * n + p[k]
    return c


@njit(cache=True, inline="always")
def position(c, n, p):
    """Write the position of cell ``c`` into ``p``."""
    for k in range(p.shape[0] - 1, -1, -1):
        p[k] = c % n
        c //= n


@njit(cache=True, inline="always")
def observe(p, origin, scale, out):
    """The observation of the cell at ``p``: o = (p - origin) / scale, axis by axis (the
    CML's frame, :class:`cml_edge.core.cml.CMLConfig`'s ``obs_origin`` and
    ``obs_scale``)."""
    for k in range(p.shape[0]):
        out[k] = (p[k] - origin) / scale


@njit(cache=True, inline="always")
def sense(cells, c, dims, out):
    """The sensor inputs of cell ``c`` after the position in ``out`` (out[dims:]; nothing
    without sensors): the observation of :mod:`cml_edge.grid.sensors`."""
    for k in range(cells.readings.shape[1]):
        out[dims + k] = cells.readings[c, k]


@njit(cache=True, inline="always")
def unpack_moves(m, mask):
    """mask[a] = bit a of the move mask ``m``; returns how many are set."""
    count = 0
    for a in range(mask.shape[0]):
        mask[a] = (m >> a) & 1
        count += mask[a]
    return count


@njit(cache=True, inline="always")
def nth_move(m, r):
    """The r-th (from 0) set bit of the move mask ``m``, ascending; -1 if there are fewer."""
    a = 0
    while m:
        if m & 1:
            if r == 0:
                return a
            r -= 1
        m >>= 1
        a += 1
    return -1


def chebyshev(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Chebyshev distance max(|dx|, |dy|, ...): the fewest king moves on an empty grid."""
    d = np.abs(np.asarray(p) - np.asarray(q))
    return d.max(axis=-1)


def fewest_moves(p: np.ndarray, q: np.ndarray, moves: str = "king") -> np.ndarray:
    """The fewest moves between cells on an empty arena: the Chebyshev distance with the
    king moves (the paper's d_Ch of Eq. 9), the Manhattan distance with the face moves."""
    d = np.abs(np.asarray(p) - np.asarray(q))
    return d.max(axis=-1) if moves == "king" else d.sum(axis=-1)


@dataclass(frozen=True, eq=False)
class GridArena:
    """An N x N (or N x N x N) grid; ``blocked`` is a bool array of that shape indexed
    [x, y] ([x, y, z]); ``moves`` the move set (:func:`move_table`)."""

    size: int
    blocked: np.ndarray
    moves: str = "king"
    sensors: Sensors | None = None
    """Range sensors the agent reads here (:mod:`cml_edge.grid.sensors`); None: none."""

    def __post_init__(self) -> None:
        if int(self.size) != self.size or self.size < 2:
            raise InputError(f"arena size {self.size!r} is not an integer >= 2")
        dims = self.blocked.ndim
        if dims not in DIMS or self.blocked.shape != (self.size,) * dims:
            raise InputError(f"blocked has shape {self.blocked.shape}, expected "
                             f"{(self.size,) * 2} or {(self.size,) * 3}")
        move_table(dims, self.moves)
        if self.sensors is not None:
            self.sensors.check(dims, self.size)

    def sensing(self, sensors: Sensors | None) -> GridArena:
        """This arena with ``sensors`` read on it."""
        return replace(self, sensors=sensors)

    @property
    def n_sensors(self) -> int:
        """K, the range readings in the observation (0 without sensors)."""
        return self.sensors.k if self.sensors is not None else 0

    def check_inputs(self, n_i: int) -> None:
        """InputError unless a CML of ``n_i`` inputs observes this arena (a position per
        axis and a reading per range sensor)."""
        if n_i != self.dims + self.n_sensors:
            raise InputError(f"the CML takes {n_i} inputs; the {self.dims}-D arena with "
                             f"{self.n_sensors} range sensors gives "
                             f"{self.dims + self.n_sensors}")

    @classmethod
    def empty(cls, size: int = 30, dims: int = 2, moves: str = "king") -> GridArena:
        _check_size(size)
        move_table(dims, moves)
        return cls(int(size), np.zeros((int(size),) * dims, dtype=bool), moves)

    @classmethod
    def sensed(cls, sensors: Sensors, size: int, dims: int = 2, moves: str = "king"
               ) -> GridArena:
        """The arena a model with range ``sensors`` trains on: side ``size``, its obstacles
        placed from the sensors' layout seed (:mod:`cml_edge.grid.sensors`), the sensors
        read on it."""
        sensors.check(dims, size)
        return cls.with_obstacles(size, sensors.obstacles_on(size, dims), sensors.layout_seed,
                                  dims, moves).sensing(sensors)

    @classmethod
    def with_obstacles(cls, size: int, n_obstacles: int, seed: int, dims: int = 2,
                       moves: str = "king") -> GridArena:
        """``n_obstacles`` point obstacles on distinct cells drawn uniformly from ``seed``."""
        _check_size(size)
        move_table(dims, moves)
        cells = int(size) ** dims
        if int(n_obstacles) != n_obstacles or not 0 <= n_obstacles <= cells - 2:
            raise InputError(f"obstacles {n_obstacles!r} is not an integer in 0..{cells - 2}")
        drawn = np.random.default_rng(seed).choice(cells, size=int(n_obstacles),
                                                   replace=False)
        blocked = np.zeros(cells, dtype=bool)
        blocked[drawn] = True
        return cls(int(size), blocked.reshape((int(size),) * dims), moves)

    @property
    def dims(self) -> int:
        return int(self.blocked.ndim)

    @property
    def move_table(self) -> np.ndarray:
        """int64 (n_actions, dims): each action's displacement (:func:`move_table`)."""
        return move_table(self.dims, self.moves)

    @property
    def n_actions(self) -> int:
        return len(self.move_table)

    @property
    def free(self) -> np.ndarray:
        """uint8, the arena's shape: 1 where the agent may stand (what compiled loops take)."""
        return (~self.blocked).astype(np.uint8)

    @property
    def move_masks(self) -> np.ndarray:
        """uint32, the arena's shape: per cell the bitmask of the available moves
        (:func:`cell_masks`)."""
        return self.cells().masks.reshape(self.blocked.shape)

    def cells(self) -> Cells:
        """The arena as the compiled loops take it (:class:`Cells`)."""
        free = self.free.ravel()
        masks = np.zeros(free.size, np.uint32)
        table = self.move_table
        cell_masks(free, self.size, table, masks)
        strides = self.size ** np.arange(self.dims - 1, -1, -1)
        readings = (self.sensors.readings(free, self.size, move_table(
            self.dims, self.sensors.move_set(self.dims))) if self.sensors is not None
                    else np.zeros((free.size, 0)))
        open_goal = float(self.sensors is None or self.sensors.goal == "open")
        return Cells(free, masks, table, (table * strides).sum(axis=1).astype(np.int64),
                     self.size, readings, open_goal)

    @property
    def n_obstacles(self) -> int:
        return int(self.blocked.sum())

    def contains(self, pos) -> bool:
        return len(pos) == self.dims and all(0 <= p < self.size for p in pos)

    def is_free(self, pos) -> bool:
        return self.contains(pos) and not self.blocked[tuple(int(p) for p in pos)]

    def available(self, pos) -> np.ndarray:
        """Bool mask of the moves available from ``pos``."""
        m = int(self.move_masks[tuple(int(p) for p in pos)])
        return np.array([m >> a & 1 for a in range(self.n_actions)], dtype=bool)

    def geodesic(self, source, cells: Cells | None = None) -> np.ndarray:
        """BFS distances (fewest moves of the arena's set) from ``source``, in the arena's
        shape; -1 where unreachable. ``cells``: :meth:`cells`, when the caller searches
        from many sources."""
        dist = np.full(self.blocked.size, -1, dtype=np.int64)
        if self.is_free(source):
            cells = self.cells() if cells is None else cells
            start = int(np.ravel_multi_index(tuple(int(p) for p in source), self.blocked.shape))
            bfs_cells(cells.masks, cells.offsets, start, dist,
                      np.zeros(self.blocked.size, np.int64))
        return dist.reshape(self.blocked.shape)


@njit(cache=True)
def bfs_cells(masks, offsets, start, dist, queue):
    """Breadth-first search from the free cell ``start`` over the free cells, by the
    available moves (``masks``, :func:`cell_masks`; ``offsets[a]``: action a's change of
    the cell number): dist[c] = the fewest moves to cell c, left as it is (-1) where no
    path reaches; ``queue``: int64 (cells) scratch."""
    dist[start] = 0
    queue[0] = start
    head = 0
    tail = 1
    while head < tail:
        c = queue[head]
        head += 1
        m = masks[c]
        for a in range(offsets.shape[0]):
            if m >> a & 1:
                q = c + offsets[a]
                if dist[q] < 0:
                    dist[q] = dist[c] + 1
                    queue[tail] = q
                    tail += 1


def _check_size(size) -> None:
    if isinstance(size, bool) or int(size) != size or size < 2:
        raise InputError(f"arena size {size!r} is not an integer >= 2")
