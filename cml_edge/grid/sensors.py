"""Range sensors in the embedding (the paper's section 5: "we deliberately did not integrate
distance sensor readouts in the embedding space"): K readings appended to what the CML
observes, in two or three dimensions.

A sensor looks along one of K directions of the arena's move set: the face directions
(K = 4 on the plane, 6 in space) or the king directions (8, 26), in the arena's action
order (:func:`~cml_edge.grid.arena.move_table`). Its reading is the number of free cells
d the agent could step along that direction before an obstacle or the arena's edge,
clipped at the ``range`` R. The observation grows from o = (p - origin) / scale to

    o = ((p - origin) / scale, -w (1 - d_1 / R), ..., -w (1 - d_K / R)),  w = W / sqrt K

with W the ``weight`` of the K inputs together. Choices made here:

- Proximity, zero in the open. A sensor enters as its proximity 1 - d / R, so in open
  space (every reading at the range) the sensor inputs are zero and the embedding
  W_q o is the paper's; only what is near changes it. The affordance sigmoid(W_k W_q o)
  has no bias term (:mod:`cml_edge.core.cml`), and an always-on input would act as one.
- Weight. W = 0.5 by default: the K inputs together span at most what one coordinate
  spans ([-0.5, 0.5]), so Eq. 3's per-walk gain lr_q x steps x E|o|^2 stays below 1
  (at most 0.001 x 900 x (1/6 + 1/4) = 0.38 on the plane). The weight decides how much
  the sensors move the plans; ``cml-edge sweep sensors`` measures it from 0.02 up.
- The goal (``goal``). ``open`` (default): the goal's observation o* carries the
  proximity the agent would read at the goal in open space, zero; d = W_q (o* - o) then
  holds -W_q o_sensors, so the utility W_v^T d also favours the moves that, on average
  over training, lowered the proximity (moves away from what is near): a repulsion
  from obstacles and walls on top of the pull to the goal. ``here``: o* carries the
  agent's own current proximities, which cancel in o* - o; the sensors then reach
  planning only through the affordance.
- Training meets obstacles. With sensors, walks run on an arena with ``train_obstacles``
  point obstacles (None: a third of the cells, the density of the paper's 300 of 900),
  placed once from ``layout_seed`` (a placement no evaluation draws: evaluations place
  theirs from the evaluation seed); a walk starts on a free cell and, as at the walls,
  draws only among the moves that stay on free cells (:mod:`cml_edge.grid.exploration`).
  So the sensors read obstacles during training, and the readings change as the agent
  moves. ``k = 0`` keeps that training with no readings: the control that tells the
  sensors' effect from the obstacles' in training.

The readings of every cell are computed once per arena (:func:`cell_readings`) and read
by cell number in the compiled loops (:class:`~cml_edge.grid.arena.Cells`). The factored
training shortcut assumes an observation that is a function of the position alone; a
sensed arena trains on the ``direct`` path (:mod:`cml_edge.grid.paths`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from cml_edge.core.records import Record, integer
from cml_edge.errors import InputError
from cml_edge.sizes import checked, checked_float

GOALS = ("open", "here")
"""What the goal's observation o* carries in its sensor inputs (module docstring)."""

LAYOUT_SEED = 2024
"""The seed of the training arena's obstacles (no evaluation seed of cml-edge uses it)."""


def sensor_counts(dims: int) -> tuple[int, int]:
    """The allowed K of a ``dims``-dimensional arena: its face and king direction counts."""
    return 2 * dims, 3 ** dims - 1


@dataclass(frozen=True)
class Sensors(Record):
    """K range readings in the observation and the obstacles of training (module
    docstring)."""

    what = "sensor settings"

    k: int = 8
    range: int = 5
    weight: float = 0.5
    goal: str = "open"
    train_obstacles: int | None = None
    layout_seed: int = LAYOUT_SEED

    def __post_init__(self) -> None:
        object.__setattr__(self, "k", integer("sensors", self.k, 0))
        object.__setattr__(self, "range", integer("sensor range", self.range, 1))
        checked("sensor_range", self.range, "sensor range")
        if isinstance(self.weight, bool) or not isinstance(self.weight, (int, float)):
            raise InputError(f"sensor weight {self.weight!r} is not a number")
        object.__setattr__(self, "weight", checked_float("sensor_weight", float(self.weight),
                                                         "sensor weight"))
        if self.goal not in GOALS:
            raise InputError(f"unknown sensor goal {self.goal!r}; allowed: {', '.join(GOALS)}")
        if self.train_obstacles is not None:
            object.__setattr__(self, "train_obstacles",
                               integer("training obstacles", self.train_obstacles, 0))
        object.__setattr__(self, "layout_seed", integer("layout seed", self.layout_seed, 0))

    def check(self, dims: int, size: int) -> None:
        """InputError unless K is a direction count of the arena and the training
        obstacles leave two free cells."""
        allowed = sensor_counts(dims)
        if self.k not in (0, *allowed):
            raise InputError(f"--sensors {self.k} is not allowed in {dims} dimensions "
                             f"(allowed: 0, {allowed[0]} face or {allowed[1]} king directions)")
        obstacles = self.obstacles_on(size, dims)
        if obstacles > size ** dims - 2:
            raise InputError(f"training obstacles {obstacles} do not fit the "
                             f"{' x '.join([str(size)] * dims)} arena (allowed: 0.."
                             f"{size ** dims - 2})")

    def obstacles_on(self, size: int, dims: int) -> int:
        """The training arena's obstacle count: ``train_obstacles``, or a third of its
        cells."""
        return (self.train_obstacles if self.train_obstacles is not None
                else size ** dims // 3)

    @property
    def per_sensor(self) -> float:
        """w = weight / sqrt K: the K inputs together at most ``weight``."""
        return self.weight / math.sqrt(self.k) if self.k else 0.0

    def move_set(self, dims: int) -> str:
        """The move set whose directions the sensors look along: ``face`` (K = 2 dims) or
        ``king`` (:func:`~cml_edge.grid.arena.move_table`)."""
        return "face" if self.k == 2 * dims else "king"

    def readings(self, free: np.ndarray, n: int, dirs: np.ndarray) -> np.ndarray:
        """float64 (cells, K): each cell's sensor inputs along the unit steps ``dirs``
        (K, dims) (:func:`cell_readings`)."""
        out = np.zeros((free.size, self.k))
        if self.k:
            cell_readings(free, n, dirs, self.range, self.per_sensor, out)
        return out


@njit(cache=True)
def cell_readings(free, n, dirs, rng, weight, out):
    """out[c, k] = -weight (1 - d / rng) for each free cell c (C order, side ``n``) and
    direction ``dirs[k]``: d the free cells stepped along it before an obstacle or the
    edge, at most ``rng``. Blocked cells read 0 (the agent never stands there)."""
    dims = dirs.shape[1]
    pos = np.zeros(dims, np.int64)
    for c in range(free.shape[0]):
        if free[c] == 0:
            continue
        r = c
        for k in range(dims - 1, -1, -1):
            pos[k] = r % n
            r //= n
        for s in range(dirs.shape[0]):
            d = 0
            while d < rng:
                q = 0
                inside = True
                for k in range(dims):
                    v = pos[k] + (d + 1) * dirs[s, k]
                    if v < 0 or v >= n:
                        inside = False
                        break
                    q = q * n + v
                if not inside or free[q] == 0:
                    break
                d += 1
            out[c, s] = -weight * (1.0 - d / rng)
