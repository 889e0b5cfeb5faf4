"""The escape planner (past the paper): the paper's WTA until it would revisit a cell, then
a reactive escape, as a chooser of the grid's planning loop (:mod:`cml_edge.grid.planning`).

The paper's WTA is a deterministic function of the position for a fixed goal, so once
it revisits a cell it cycles for ever: that is how it "halts" in front of obstacle
clusters (the paper's Figure 8C). The escape takes the same reads per step as the paper's
planner, and no new ones: with the raw utility u = W_v^T d and K = W_v^T W_v (from W_v's
columns, read once per batch as for the norms), the CML's own estimate of the distance to
the goal is e = max_b u_b / K_bb (about the Chebyshev distance in grid steps when
W_v a = W_q delta_a, which training drives it to), and after a move a the predicted
reading is u - K[:, a] (the embedding is linear), so every neighbour has an estimate
without reading anything. The escape is a Bug-style boundary follower:

1. stall: the paper's winner leads to a cell visited in this plan. The wall is the
   blocked direction (or the arena's edge) of largest utility; remember the hit
   estimate e_hit;
2. follow the boundary with the wall on the left (scan clockwise from the wall
   direction, take the first free move; the last blocked cell scanned is the new
   wall); leave, back to the paper's WTA, at the first cell with e < e_hit - 1/2;
3. touching the arena's edge while following reverses the hand once (the edge cannot
   be walked round); a second touch, or coming back to the hit cell, falls back to
   LRTA* (Korf 1990) for the rest of the plan: h(c) of each visited cell starts at
   e(c) and is raised to min_a 1 + h(c + a) (unvisited neighbours: their predicted
   estimate), moving to an argmin within 1/2 step, ties broken by the paper's u * g.

Boundaries are followed on the plane with the king moves. In three dimensions (and with
the face moves) the wall and the hand of step 2 are not defined: a stall there takes the
LRTA* move instead (step 3's rule) and the next step is the paper's again, so the plan
leaves a cycle by the values LRTA* raises on the cells it revisits.

On every pair the paper's planner solves it never revisits a cell, so the escape
planner takes exactly the paper's path there: no loss by construction. Memory: the
cells visited in this plan with one number each (at most the step budget), and a
handful of scalars (:class:`Escape`'s ``ist`` and ``fst``, indexed by the names below).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from cml_edge.core.step import wta
from cml_edge.grid.arena import MOVES, N_ACTIONS, GridArena

LEAVE_MARGIN = 0.5  # leave the boundary when the estimate is this much below the hit's
TIE_MARGIN = 0.5  # LRTA*: moves within this many steps of the best are ties
GREEDY, FOLLOW, LRTA = 0, 1, 2  # the modes

# the integer slots of Escape.ist
MODE = 0  # GREEDY, FOLLOW or LRTA
WALL = 1  # the direction of the wall being followed
HAND = 2  # 0: the wall on the left, 1: on the right
FLIPPED = 3  # the hand was reversed once at the arena's edge
HIT = 4  # the cell where the boundary was hit (-1: forgotten after a flip)
FOLLOWED = 5  # steps along the boundary since the hit
N_SEEN = 6  # cells visited in this plan
# the float slot of Escape.fst
E_HIT = 0  # the estimate where the boundary was hit


def _wall_next() -> np.ndarray:
    """WALL_NEXT[h, d]: the wall's direction after moving d, following with hand h.

    h = 0 is the left hand (scanning clockwise, so the last blocked cell scanned lies
    at d + 1 from the old cell), h = 1 the right hand (at d - 1). Neighbouring cells of
    the Moore ring are 4-adjacent, so the difference is one of the 8 moves.
    """
    table = np.zeros((2, N_ACTIONS), np.int64)
    for h, side in enumerate((1, -1)):
        for d in range(N_ACTIONS):
            off = MOVES[(d + side) % N_ACTIONS] - MOVES[d]
            table[h, d] = next(i for i in range(N_ACTIONS) if (MOVES[i] == off).all())
    return table


WALL_NEXT = _wall_next()


class Escape(NamedTuple):
    """The escape planner's memory for one plan (reset at each start)."""

    seen: np.ndarray  # uint8 (cells,): the cells visited in this plan
    h: np.ndarray  # float64 (cells,): their LRTA* values
    vis: np.ndarray  # int64 (max_steps + 1,): the cells visited, in order
    ist: np.ndarray  # int64[8]: the integer slots named above
    fst: np.ndarray  # float64[1]: the float slot named above
    f: np.ndarray  # float64[n_actions]: 1 + h of each neighbour, this step
    wall_next: np.ndarray  # WALL_NEXT
    follow: int  # 1: boundaries are followed (the plane's king moves), 0: no boundary
    q: np.ndarray  # int64 (dims,) work vector: the wall's position

    @classmethod
    def of(cls, arena: GridArena, max_steps: int) -> Escape:
        cells = arena.size ** arena.dims
        follow = arena.dims == 2 and arena.moves == "king"
        return cls(np.zeros(cells, np.uint8), np.zeros(cells),
                   np.zeros(max_steps + 1, np.int64), np.zeros(8, np.int64), np.zeros(1),
                   np.zeros(arena.n_actions), WALL_NEXT, int(follow),
                   np.zeros(arena.dims, np.int64))


@njit(cache=True)
def escape_reset(es):
    """Forget the last plan: the visited cells, the mode, the wall."""
    for i in range(es.ist[N_SEEN]):
        es.seen[es.vis[i]] = 0
    es.ist[:] = 0
    es.ist[HIT] = -1
    es.fst[:] = 0.0


@njit(cache=True)
def lrta_choice(f, fmin, score, mask):
    """Among the available moves within TIE_MARGIN of the best f, the largest u * g."""
    best = -1
    for a in range(f.shape[0]):
        if mask[a] and f[a] <= fmin + TIE_MARGIN and (best < 0 or score[a] > score[best]):
            best = a
    return best


@njit(cache=True)
def estimate(u, K, a):
    """The CML's estimate of the steps to the goal, max_b u_b / K_bb, from here (``a`` -1)
    or after the move ``a`` (u - K[:, a] predicted). A column of W_v that reads as zero
    (K_bb = 0: a coarse ADC or 1-bit messages round it away) carries no distance and is
    left out; with none readable the estimate is 0, and LRTA* explores by visits alone."""
    e = -math.inf
    for b in range(K.shape[0]):
        if K[b, b] > 0.0:
            e = max(e, (u[b] if a < 0 else u[b] - K[b, a]) / K[b, b])
    return e if e > -math.inf else 0.0


@njit(cache=True)
def escape_choose(es, cells, c, p, u, score, norms, K, mask):
    """One decision of the escape planner in cell ``c`` at ``p`` (the module docstring)."""
    n = cells.n
    table = cells.table
    offsets = cells.offsets
    ist = es.ist
    seen = es.seen
    h = es.h
    f = es.f
    e = estimate(u, K, -1)
    if not seen[c]:
        seen[c] = 1
        es.vis[ist[N_SEEN]] = c
        ist[N_SEEN] += 1
        h[c] = e
    fmin = math.inf
    for a in range(f.shape[0]):
        f[a] = math.inf
        if mask[a]:
            nb = c + offsets[a]
            if seen[nb]:
                f[a] = 1.0 + h[nb]
            else:
                f[a] = 1.0 + estimate(u, K, a)
        fmin = min(fmin, f[a])
    h[c] = max(h[c], fmin)
    best = wta(score, mask)  # the paper's choice
    if ist[MODE] == FOLLOW and e < es.fst[E_HIT] - LEAVE_MARGIN:
        ist[MODE] = GREEDY  # closer than where the boundary was hit: leave it
    if ist[MODE] == FOLLOW and c == ist[HIT] and ist[FOLLOWED] > 0:
        ist[MODE] = LRTA  # all the way round without getting closer
    if ist[MODE] == GREEDY and seen[c + offsets[best]]:
        wall = -1  # the wall: the blocked direction of largest utility
        for a in range(f.shape[0]):
            if es.follow and not mask[a] and (wall < 0 or u[a] / norms[a] > u[wall] / norms[wall]):
                wall = a
        if wall >= 0:
            ist[MODE] = FOLLOW
            ist[WALL] = wall
            ist[HAND] = 0
            ist[FLIPPED] = 0
            ist[HIT] = c
            ist[FOLLOWED] = 0
            es.fst[E_HIT] = e
        else:
            best = lrta_choice(f, fmin, score, mask)
    if ist[MODE] == FOLLOW:
        inside = True
        for k in range(p.shape[0]):
            es.q[k] = p[k] + table[ist[WALL], k]
            inside = inside and 0 <= es.q[k] < n
        if not inside:
            if ist[FLIPPED]:
                ist[MODE] = LRTA
            else:  # the arena's edge cannot be walked round: turn back
                ist[HAND] = 1 - ist[HAND]
                ist[FLIPPED] = 1
                ist[HIT] = -1
    if ist[MODE] == FOLLOW:
        side = 1 if ist[HAND] == 0 else -1
        for k in range(1, N_ACTIONS):
            best = (ist[WALL] - side * k) % N_ACTIONS
            if mask[best]:  # on the arena and free
                break
        ist[WALL] = es.wall_next[ist[HAND], best]
        ist[FOLLOWED] += 1
    elif ist[MODE] == LRTA:
        best = lrta_choice(f, fmin, score, mask)
    return best
