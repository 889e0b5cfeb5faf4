"""Evaluation metrics (paper 2.4.1) and the fixed (start, goal) pairs of the protocol.

- e_pos = ||p_goal - p_final||_2 (Eq. 8);
- path overhead lambda = steps / d_Ch(p_init, p_goal) (Eq. 9), over successful trials
  (d_Ch the fewest moves on the empty arena: Chebyshev with the king moves, on the plane
  and in space, Manhattan with the face moves);
- success: the final position is the goal;
- with obstacles, also steps / geodesic (BFS) distance, and success over the pairs that
  are connected at all.

Pooled over several model seeds, the metrics are those of all seeds x trials
(:func:`pool_records`, :func:`pool_pairs`), whatever ran the seeds.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from cml_edge.errors import InputError
from cml_edge.grid.arena import GridArena, fewest_moves


@dataclass(frozen=True)
class Pairs:
    """Evaluation (start, goal) pairs, with their empty-arena (``chebyshev``: d_Ch of Eq. 9,
    :func:`~cml_edge.grid.arena.fewest_moves`) and geodesic distances."""

    starts: np.ndarray  # (n, dims)
    goals: np.ndarray  # (n, dims)
    chebyshev: np.ndarray  # (n,) the fewest moves on the empty arena (fewest_moves)
    geodesic: np.ndarray  # (n,), -1 where the goal cannot be reached at all


def draw_pairs(arena: GridArena, trials: int, seed: int) -> Pairs:
    """``trials`` pairs of distinct free cells drawn uniformly from ``seed``.

    Every method evaluated with the same arena, count and seed sees the same pairs.
    """
    if isinstance(trials, bool) or int(trials) != trials or trials < 1:
        raise InputError(f"trials {trials!r} is not a positive integer")
    free = np.argwhere(~arena.blocked)
    if len(free) < 2:
        raise InputError("the arena has fewer than two free cells")
    rng = np.random.default_rng(seed)
    starts = np.zeros((trials, arena.dims), np.int64)
    goals = np.zeros((trials, arena.dims), np.int64)
    for i in range(trials):
        a, b = rng.choice(len(free), size=2, replace=False)
        starts[i], goals[i] = free[a], free[b]
    return Pairs(starts, goals, fewest_moves(starts, goals, arena.moves),
                 geodesic_distances(arena, starts, goals))


def geodesic_distances(arena: GridArena, starts: np.ndarray, goals: np.ndarray) -> np.ndarray:
    """BFS distance (fewest moves of the arena's set) of each pair; -1 where not connected."""
    if arena.n_obstacles == 0:
        return fewest_moves(starts, goals, arena.moves)
    cache: dict[tuple[int, ...], np.ndarray] = {}
    out = np.zeros(len(starts), np.int64)
    cells = arena.cells()  # the move masks, once for every search
    for i, (s, g) in enumerate(zip(starts, goals)):
        key = tuple(int(v) for v in g)
        if key not in cache:
            cache[key] = arena.geodesic(key, cells)  # the moves are symmetric: from the goal
        out[i] = cache[key][tuple(int(v) for v in s)]
    return out


def e_pos(final: np.ndarray, goals: np.ndarray) -> np.ndarray:
    """Eq. 8: Euclidean distance between goal and final position."""
    return np.linalg.norm(np.asarray(goals, float) - np.asarray(final, float), axis=-1)


def summarize(final: np.ndarray, steps: np.ndarray, pairs: Pairs) -> dict[str, float | int | None]:
    """The protocol's metrics over one set of trials (JSON-ready; None where undefined)."""
    err = e_pos(final, pairs.goals)
    success = err == 0
    overhead = steps[success] / pairs.chebyshev[success]
    connected = pairs.geodesic > 0
    geo_ok = success & connected
    out = {
        "trials": int(len(err)),
        "success_rate": float(success.mean()),
        "e_pos_mean": float(err.mean()),
        "e_pos_median": float(np.median(err)),
        "overhead_mean": _mean(overhead),
        "overhead_median": _median(overhead),
        "connected_pairs": int(connected.sum()),
        "success_rate_connected": float(geo_ok.sum() / connected.sum()) if connected.any()
        else None,
        "overhead_geodesic_mean": _mean(steps[geo_ok] / pairs.geodesic[geo_ok]),
    }
    return out


def pool_pairs(pairs: Pairs, times: int) -> Pairs:
    """``pairs`` repeated ``times`` times (pooling the trials of several models)."""
    return Pairs(*(np.concatenate([a] * times) for a in
                   (pairs.starts, pairs.goals, pairs.chebyshev, pairs.geodesic)))


def pool_records(records: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    """The metrics of :func:`summarize` (Eqs. 8, 9) over the trials
    of several seeds' JSON records (each with its ``final``, ``steps``, ``starts``,
    ``goals``, ``chebyshev`` and ``geodesic`` lists)."""
    final = np.concatenate([np.asarray(r["final"], np.int64).reshape(len(r["steps"]), -1)
                            for r in records])
    steps = np.concatenate([np.asarray(r["steps"], np.int64) for r in records])
    pairs = Pairs(*(np.concatenate([np.asarray(r[k], np.int64) for r in records])
                    for k in ("starts", "goals", "chebyshev", "geodesic")))
    return summarize(final, steps, pairs)


CONVERGENCE_TOL = 0.5  # cells: half a grid cell


def convergence_index(values, tol: float = CONVERGENCE_TOL) -> int:
    """First index of an evaluation curve from which it stays within ``tol`` of its last
    value (the training-to-convergence point of the CML and the DQN alike)."""
    v = np.asarray(values, dtype=float)
    if len(v) == 0:
        raise InputError("empty curve")
    outside = np.flatnonzero(np.abs(v - v[-1]) > tol)
    return int(outside[-1] + 1) if len(outside) else 0


def _mean(x: np.ndarray) -> float | None:
    """The mean, or None (JSON null) when there is nothing to average."""
    return float(x.mean()) if len(x) else None


def _median(x: np.ndarray) -> float | None:
    return float(np.median(x)) if len(x) else None
