"""Planning (paper 2.1): WTA over utility x affordance, blocked moves masked.

At each step the agent reads d = W_q (o* - o) (= s* - s, one read), the utility
u = W_v^T d (the transposed read of W_v; the paper's stand-in for W_v^-1 d), divided
by W_v's column norms unless the utility is ``raw``, and the affordance
g = sigmoid(W_k W_q o). The winner-take-all picks, among the moves available now, the
one with the largest u * g (first index on a tie): a move into an obstacle or off the
arena is not available, which is the paper's reactive obstacle handling. It stops on
the goal or after ``max_steps`` actions, or when no move is available.

Three paths, as for training: ``reference`` (Python, one array call per operation),
``direct`` (compiled, through the seam, bit-identical to the reference) and
``factored`` (float64 arrays: the N_a x N_i utility map U = W_v^T W_q / norms and
M = W_k W_q, so a step costs 2 N_a N_i multiply-adds).

Two planners (``planner=``):

- ``paper``: the WTA above. It is a deterministic function of the position for a fixed
  goal, so once it revisits a cell it cycles for ever: that is how it "halts" in front
  of obstacle clusters (the paper's Figure 8C).
- ``escape`` (past the paper): the paper's WTA until its winner would revisit a cell of
  this plan, then a reactive escape. It takes the same reads per step as the paper's
  planner, and no new ones: with the raw utility u = W_v^T d and K = W_v^T W_v (from
  W_v's columns, read once per batch as for the norms), the CML's own estimate of the
  distance to the goal is e = max_b u_b / K_bb (about the Chebyshev distance in grid
  steps when W_v a = W_q delta_a, which training drives it to), and after a move a the
  predicted reading is u - K[:, a] (the embedding is linear), so every neighbour has an
  estimate without reading anything. The escape is a Bug-style boundary follower:

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

  On every pair the paper's planner solves it never revisits a cell, so the escape
  planner takes exactly the paper's path there: no loss by construction. Memory: the
  cells visited in this plan with one number each (at most the step budget), and a
  handful of scalars.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from cml_edge.backends.dispatch import sa_matvec
from cml_edge.core.cml import CML, column_norm
from cml_edge.core.step import plan_buffers, seam_scores, seam_utility_norms, wta
from cml_edge.errors import InputError
from cml_edge.grid.arena import MOVES, N_ACTIONS, GridArena, available_moves

PATHS = ("reference", "direct", "factored")
PLANNERS = ("paper", "escape")
MAX_STEPS = 100
LEAVE_MARGIN = 0.5  # leave the boundary when the estimate is this much below the hit's
TIE_MARGIN = 0.5  # LRTA*: moves within this many steps of the best are ties
GREEDY, FOLLOW, LRTA = 0, 1, 2


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


@dataclass
class PlanResult:
    """Per trial: final position, actions taken, and the visited path (padded with -1)."""

    final: np.ndarray  # (trials, 2)
    steps: np.ndarray  # (trials,)
    paths: np.ndarray  # (trials, max_steps + 1, 2)


def plan(cml: CML, arena: GridArena, starts: np.ndarray, goals: np.ndarray,
         max_steps: int = MAX_STEPS, path: str = "direct", planner: str = "paper") -> PlanResult:
    """Plan from each start to its goal on ``arena`` with ``planner`` (module docstring)."""
    if path not in PATHS:
        raise InputError(f"unknown path {path!r}; allowed: {', '.join(PATHS)}")
    if planner not in PLANNERS:
        raise InputError(f"unknown planner {planner!r}; allowed: {', '.join(PLANNERS)}")
    starts = np.ascontiguousarray(starts, dtype=np.int64).reshape(-1, 2)
    goals = np.ascontiguousarray(goals, dtype=np.int64).reshape(-1, 2)
    n = len(starts)
    res = PlanResult(np.zeros((n, 2), np.int64), np.zeros(n, np.int64),
                     np.full((n, max_steps + 1, 2), -1, np.int64))
    free = arena.free
    normalize = cml.config.utility == "normalized"
    scale = cml.config.obs_scale
    origin = cml.config.obs_origin
    if path == "factored" and not all(getattr(a, "supports_factored", False)
                                      for a in cml.arrays):
        raise InputError("the factored path needs float64 arrays")
    if planner == "escape":
        if path == "direct":
            plan_escape_direct(cml.W_q.state, cml.W_k.state, cml.W_v.state, free, origin,
                               scale, starts, goals, max_steps, normalize, WALL_NEXT,
                               res.final, res.steps, res.paths)
        elif path == "factored":
            plan_escape_factored(cml.W_q.state.W, cml.W_k.state.W, cml.W_v.state.W, free,
                                 origin, scale, starts, goals, max_steps, normalize, WALL_NEXT,
                                 res.final, res.steps, res.paths)
        else:
            plan_escape_reference(cml, free, starts, goals, max_steps, res)
    elif path == "direct":
        plan_direct(cml.W_q.state, cml.W_k.state, cml.W_v.state, free, origin, scale, starts,
                    goals, max_steps, normalize, res.final, res.steps, res.paths)
    elif path == "factored":
        plan_factored(cml.W_q.state.W, cml.W_k.state.W, cml.W_v.state.W, free, origin, scale,
                      starts, goals, max_steps, normalize, res.final, res.steps, res.paths)
    else:
        plan_reference(cml, free, starts, goals, max_steps, res)
    return res


def plan_reference(cml: CML, free: np.ndarray, starts: np.ndarray, goals: np.ndarray,
                   max_steps: int, res: PlanResult) -> None:
    """Plain-Python planning: the readable statement of the planner."""
    norms = cml.utility_norms()
    mask = np.zeros(N_ACTIONS, dtype=np.uint8)
    for trial, (start, goal) in enumerate(zip(starts, goals)):
        x, y = int(start[0]), int(start[1])
        res.paths[trial, 0] = (x, y)
        taken = 0
        o_goal = cml.observe(goal)
        while taken < max_steps and (x, y) != (goal[0], goal[1]):
            o = cml.observe((x, y))
            u = cml.utility(cml.W_q.matvec(o_goal - o), norms)  # W_v^T (s* - s)
            score = u * cml.affordance(cml.embed(o))
            if available_moves(free, x, y, mask) == 0:
                break
            a = int(np.argmax(np.where(mask == 1, score, -np.inf)))
            x, y = x + int(MOVES[a, 0]), y + int(MOVES[a, 1])
            taken += 1
            res.paths[trial, taken] = (x, y)
        res.final[trial] = (x, y)
        res.steps[trial] = taken


@njit(cache=True)
def plan_direct(q, k, v, free, origin, scale, starts, goals, max_steps, normalize, final, steps,
                paths):
    """The compiled twin of :func:`plan_reference`, through the synaptic-array seam."""
    n_s = q[0].shape[0]
    n_i = q[0].shape[1]
    n_a = k[0].shape[0]
    norms = np.ones(n_a)
    seam_utility_norms(v, normalize, norms)  # W_v's columns, read once per batch
    o = np.zeros(n_i)
    dgo = np.zeros(n_i)
    buf = plan_buffers(n_s, n_a)
    score = np.zeros(n_a)
    mask = np.zeros(N_ACTIONS, dtype=np.uint8)
    for trial in range(starts.shape[0]):
        x = starts[trial, 0]
        y = starts[trial, 1]
        gx = goals[trial, 0]
        gy = goals[trial, 1]
        paths[trial, 0, 0] = x
        paths[trial, 0, 1] = y
        taken = 0
        while taken < max_steps and not (x == gx and y == gy):
            o[0] = (x - origin) / scale
            o[1] = (y - origin) / scale
            dgo[0] = (gx - origin) / scale - o[0]
            dgo[1] = (gy - origin) / scale - o[1]
            seam_scores(q, k, v, o, dgo, norms, score, buf)
            if available_moves(free, x, y, mask) == 0:
                break
            a = wta(score, mask)
            x += MOVES[a, 0]
            y += MOVES[a, 1]
            taken += 1
            paths[trial, taken, 0] = x
            paths[trial, taken, 1] = y
        final[trial, 0] = x
        final[trial, 1] = y
        steps[trial] = taken


@njit(cache=True)
def plan_factored(Wq, Wk, Wv, free, origin, scale, starts, goals, max_steps, normalize, final,
                  steps, paths):
    """Planning with the utility map U = W_v^T W_q / norms and M = W_k W_q (float64)."""
    n_s, n_i = Wq.shape
    n_a = Wk.shape[0]
    U = Wv.T @ Wq
    M = Wk @ Wq
    if normalize:
        for a in range(n_a):
            total = 0.0
            for i in range(n_s):
                total += Wv[i, a] * Wv[i, a]
            norm = math.sqrt(total) if total > 0 else 1.0
            for j in range(n_i):
                U[a, j] /= norm
    score = np.zeros(n_a)
    mask = np.zeros(N_ACTIONS, dtype=np.uint8)
    for trial in range(starts.shape[0]):
        x = starts[trial, 0]
        y = starts[trial, 1]
        gx = goals[trial, 0]
        gy = goals[trial, 1]
        paths[trial, 0, 0] = x
        paths[trial, 0, 1] = y
        taken = 0
        while taken < max_steps and not (x == gx and y == gy):
            ox = (x - origin) / scale
            oy = (y - origin) / scale
            dx = (gx - origin) / scale - ox
            dy = (gy - origin) / scale - oy
            for a in range(n_a):
                zk = M[a, 0] * ox + M[a, 1] * oy
                score[a] = (U[a, 0] * dx + U[a, 1] * dy) / (1.0 + math.exp(-zk))
            if available_moves(free, x, y, mask) == 0:
                break
            a = wta(score, mask)
            x += MOVES[a, 0]
            y += MOVES[a, 1]
            taken += 1
            paths[trial, taken, 0] = x
            paths[trial, taken, 1] = y
        final[trial, 0] = x
        final[trial, 1] = y
        steps[trial] = taken



# the escape planner (module docstring) ------------------------------------------------
def _gram_from_columns(cols: list[np.ndarray]) -> np.ndarray:
    """K[a, b] = col_a . col_b, summed in index order (as the compiled loops sum it)."""
    n_a = len(cols)
    K = np.zeros((n_a, n_a))
    for a in range(n_a):
        for b in range(n_a):
            total = 0.0
            for i in range(len(cols[a])):
                total += float(cols[a][i]) * float(cols[b][i])
            K[a, b] = total
    return K


def plan_escape_reference(cml: CML, free: np.ndarray, starts: np.ndarray, goals: np.ndarray,
                          max_steps: int, res: PlanResult) -> None:
    """Plain-Python escape planning: the readable statement of the escape planner."""
    n_a = cml.config.n_a
    cols = [cml.action_effect(a) for a in range(n_a)]  # W_v's columns, read once
    K = _gram_from_columns(cols)
    norms = (np.array([column_norm(c) for c in cols]) if cml.config.utility == "normalized"
             else np.ones(n_a))
    n = free.shape[0]
    mask = np.zeros(N_ACTIONS, dtype=np.uint8)

    def is_free(cx: int, cy: int) -> bool:
        return 0 <= cx < n and 0 <= cy < n and free[cx, cy] != 0

    def estimate(u: np.ndarray, a: int) -> float:
        """max_b (u - K[:, a])_b / K_bb: the estimate after move a (a < 0: here)."""
        best = -math.inf
        for b in range(n_a):
            ub = u[b] if a < 0 else u[b] - K[b, a]
            best = max(best, ub / K[b, b])
        return best

    for trial, (start, goal) in enumerate(zip(starts, goals)):
        x, y = int(start[0]), int(start[1])
        gx, gy = int(goal[0]), int(goal[1])
        res.paths[trial, 0] = (x, y)
        taken = 0
        h: dict[tuple[int, int], float] = {}  # the cells visited in this plan
        mode, wall, hand, flipped, hit, follow, e_hit = GREEDY, 0, 0, False, None, 0, 0.0
        o_goal = cml.observe(goal)
        while taken < max_steps and (x, y) != (gx, gy):
            o = cml.observe((x, y))
            u = cml.W_v.rmatvec(cml.W_q.matvec(o_goal - o))  # raw utility W_v^T (s* - s)
            g = cml.affordance(cml.embed(o))
            score = u / norms * g
            if available_moves(free, x, y, mask) == 0:
                break
            e = estimate(u, -1)
            h.setdefault((x, y), e)
            f = np.full(N_ACTIONS, math.inf)
            for a in range(N_ACTIONS):
                if mask[a]:
                    c = (x + int(MOVES[a, 0]), y + int(MOVES[a, 1]))
                    f[a] = 1.0 + (h[c] if c in h else estimate(u, a))
            fmin = float(f.min())
            h[(x, y)] = max(h[(x, y)], fmin)
            best = int(np.argmax(np.where(mask == 1, score, -np.inf)))  # the paper's WTA
            if mode == FOLLOW and e < e_hit - LEAVE_MARGIN:
                mode = GREEDY  # closer than where the boundary was hit: leave it
            if mode == FOLLOW and (x, y) == hit and follow > 0:
                mode = LRTA  # all the way round without getting closer
            if mode == GREEDY and (x + int(MOVES[best, 0]), y + int(MOVES[best, 1])) in h:
                blocked = [a for a in range(N_ACTIONS) if not mask[a]]
                if blocked:  # the wall: the blocked direction of largest utility
                    wall = max(blocked, key=lambda a: (u[a] / norms[a], -a))
                    mode, hand, flipped, hit, follow, e_hit = FOLLOW, 0, False, (x, y), 0, e
                else:
                    best = _lrta_choice_ref(f, fmin, score, mask)
            if mode == FOLLOW and not (0 <= x + MOVES[wall, 0] < n
                                       and 0 <= y + MOVES[wall, 1] < n):
                if flipped:
                    mode = LRTA
                else:  # the arena's edge cannot be walked round: turn back
                    hand, flipped, hit = 1 - hand, True, None
            if mode == FOLLOW:
                side = 1 if hand == 0 else -1
                for k in range(1, N_ACTIONS):
                    best = (wall - side * k) % N_ACTIONS
                    if is_free(x + int(MOVES[best, 0]), y + int(MOVES[best, 1])):
                        break
                wall = int(WALL_NEXT[hand, best])
                follow += 1
            elif mode == LRTA:
                best = _lrta_choice_ref(f, fmin, score, mask)
            x, y = x + int(MOVES[best, 0]), y + int(MOVES[best, 1])
            taken += 1
            res.paths[trial, taken] = (x, y)
        res.final[trial] = (x, y)
        res.steps[trial] = taken


def _lrta_choice_ref(f: np.ndarray, fmin: float, score: np.ndarray, mask: np.ndarray) -> int:
    """Among the available moves within TIE_MARGIN of the best f, the largest u * g."""
    best = -1
    for a in range(N_ACTIONS):
        if mask[a] and f[a] <= fmin + TIE_MARGIN and (best < 0 or score[a] > score[best]):
            best = a
    return best


@njit(cache=True)
def _escape_step(free, x, y, u, score, K, norms, mask, seen, h, vis, ist, fst, wall_next):
    """One decision of the escape planner (compiled; see :func:`plan_escape_reference`).

    ``ist`` = [mode, wall, hand, flipped, hit x, hit y, follow steps, visited count],
    ``fst`` = [e_hit]; ``seen``/``h`` hold the visited cells and their h values.
    """
    n = free.shape[0]
    n_a = K.shape[0]
    e = -math.inf
    for b in range(n_a):
        e = max(e, u[b] / K[b, b])
    if not seen[x, y]:
        seen[x, y] = 1
        nv = ist[7]
        vis[nv, 0] = x
        vis[nv, 1] = y
        ist[7] = nv + 1
        h[x, y] = e
    f = np.full(N_ACTIONS, math.inf)
    for a in range(N_ACTIONS):
        if mask[a]:
            cx = x + MOVES[a, 0]
            cy = y + MOVES[a, 1]
            if seen[cx, cy]:
                f[a] = 1.0 + h[cx, cy]
            else:
                est = -math.inf
                for b in range(n_a):
                    est = max(est, (u[b] - K[b, a]) / K[b, b])
                f[a] = 1.0 + est
    fmin = math.inf
    for a in range(N_ACTIONS):
        fmin = min(fmin, f[a])
    h[x, y] = max(h[x, y], fmin)
    best = wta(score, mask)
    if ist[0] == FOLLOW and e < fst[0] - LEAVE_MARGIN:
        ist[0] = GREEDY
    if ist[0] == FOLLOW and x == ist[4] and y == ist[5] and ist[6] > 0:
        ist[0] = LRTA
    if ist[0] == GREEDY and seen[x + MOVES[best, 0], y + MOVES[best, 1]]:
        wall = -1
        for a in range(N_ACTIONS):
            if not mask[a] and (wall < 0 or u[a] / norms[a] > u[wall] / norms[wall]):
                wall = a
        if wall >= 0:
            ist[0] = FOLLOW
            ist[1] = wall
            ist[2] = 0
            ist[3] = 0
            ist[4] = x
            ist[5] = y
            ist[6] = 0
            fst[0] = e
        else:
            best = _lrta_choice(f, fmin, score, mask)
    if ist[0] == FOLLOW:
        wx = x + MOVES[ist[1], 0]
        wy = y + MOVES[ist[1], 1]
        if not (0 <= wx < n and 0 <= wy < n):
            if ist[3]:
                ist[0] = LRTA
            else:
                ist[2] = 1 - ist[2]
                ist[3] = 1
                ist[4] = -1
                ist[5] = -1
    if ist[0] == FOLLOW:
        side = 1 if ist[2] == 0 else -1
        for k in range(1, N_ACTIONS):
            best = (ist[1] - side * k) % N_ACTIONS
            cx = x + MOVES[best, 0]
            cy = y + MOVES[best, 1]
            if 0 <= cx < n and 0 <= cy < n and free[cx, cy] != 0:
                break
        ist[1] = wall_next[ist[2], best]
        ist[6] += 1
    elif ist[0] == LRTA:
        best = _lrta_choice(f, fmin, score, mask)
    return best


@njit(cache=True)
def _lrta_choice(f, fmin, score, mask):
    best = -1
    for a in range(N_ACTIONS):
        if mask[a] and f[a] <= fmin + TIE_MARGIN and (best < 0 or score[a] > score[best]):
            best = a
    return best


@njit(cache=True)
def _escape_reset(seen, vis, ist, fst):
    for i in range(ist[7]):
        seen[vis[i, 0], vis[i, 1]] = 0
    ist[:] = 0
    ist[4] = -1
    ist[5] = -1
    fst[:] = 0.0


@njit(cache=True)
def plan_escape_direct(q, k, v, free, origin, scale, starts, goals, max_steps, normalize,
                       wall_next, final, steps, paths):
    """The compiled twin of :func:`plan_escape_reference`, through the synaptic-array seam."""
    n_s = q[0].shape[0]
    n_i = q[0].shape[1]
    n_a = k[0].shape[0]
    n = free.shape[0]
    norms = np.ones(n_a)
    cols = np.zeros((n_a, n_s))
    action = np.zeros(n_a)
    col = np.zeros(n_s)
    for a in range(n_a):  # read W_v's columns once per batch: norms and K
        action[:] = 0.0
        action[a] = 1.0
        sa_matvec(v, action, col)
        cols[a, :] = col
    K = np.zeros((n_a, n_a))
    for a in range(n_a):
        for b in range(n_a):
            total = 0.0
            for i in range(n_s):
                total += cols[a, i] * cols[b, i]
            K[a, b] = total
        if normalize:
            total = 0.0
            for i in range(n_s):
                total += cols[a, i] * cols[a, i]
            norms[a] = math.sqrt(total) if total > 0 else 1.0
    o = np.zeros(n_i)
    dgo = np.zeros(n_i)
    buf = plan_buffers(n_s, n_a)
    u = buf[2]  # the raw utility W_v^T (s* - s), written by seam_scores
    score = np.zeros(n_a)
    mask = np.zeros(N_ACTIONS, dtype=np.uint8)
    seen = np.zeros((n, n), np.uint8)
    h = np.zeros((n, n))
    vis = np.zeros((max_steps + 1, 2), np.int64)
    ist = np.zeros(8, np.int64)
    fst = np.zeros(1)
    for trial in range(starts.shape[0]):
        _escape_reset(seen, vis, ist, fst)
        x = starts[trial, 0]
        y = starts[trial, 1]
        gx = goals[trial, 0]
        gy = goals[trial, 1]
        paths[trial, 0, 0] = x
        paths[trial, 0, 1] = y
        taken = 0
        while taken < max_steps and not (x == gx and y == gy):
            o[0] = (x - origin) / scale
            o[1] = (y - origin) / scale
            dgo[0] = (gx - origin) / scale - o[0]
            dgo[1] = (gy - origin) / scale - o[1]
            seam_scores(q, k, v, o, dgo, norms, score, buf)
            if available_moves(free, x, y, mask) == 0:
                break
            a = _escape_step(free, x, y, u, score, K, norms, mask, seen, h, vis, ist, fst,
                             wall_next)
            x += MOVES[a, 0]
            y += MOVES[a, 1]
            taken += 1
            paths[trial, taken, 0] = x
            paths[trial, taken, 1] = y
        final[trial, 0] = x
        final[trial, 1] = y
        steps[trial] = taken


@njit(cache=True)
def plan_escape_factored(Wq, Wk, Wv, free, origin, scale, starts, goals, max_steps, normalize,
                         wall_next, final, steps, paths):
    """Escape planning on float64 arrays with R = W_v^T W_q, M = W_k W_q, K = W_v^T W_v."""
    n_s, n_i = Wq.shape
    n_a = Wk.shape[0]
    n = free.shape[0]
    R = Wv.T @ Wq
    M = Wk @ Wq
    K = Wv.T @ Wv
    norms = np.ones(n_a)
    if normalize:
        for a in range(n_a):
            total = 0.0
            for i in range(n_s):
                total += Wv[i, a] * Wv[i, a]
            norms[a] = math.sqrt(total) if total > 0 else 1.0
    u = np.zeros(n_a)
    score = np.zeros(n_a)
    mask = np.zeros(N_ACTIONS, dtype=np.uint8)
    seen = np.zeros((n, n), np.uint8)
    h = np.zeros((n, n))
    vis = np.zeros((max_steps + 1, 2), np.int64)
    ist = np.zeros(8, np.int64)
    fst = np.zeros(1)
    for trial in range(starts.shape[0]):
        _escape_reset(seen, vis, ist, fst)
        x = starts[trial, 0]
        y = starts[trial, 1]
        gx = goals[trial, 0]
        gy = goals[trial, 1]
        paths[trial, 0, 0] = x
        paths[trial, 0, 1] = y
        taken = 0
        while taken < max_steps and not (x == gx and y == gy):
            ox = (x - origin) / scale
            oy = (y - origin) / scale
            dx = (gx - origin) / scale - ox
            dy = (gy - origin) / scale - oy
            for a in range(n_a):
                zk = M[a, 0] * ox + M[a, 1] * oy
                u[a] = R[a, 0] * dx + R[a, 1] * dy
                score[a] = u[a] / norms[a] / (1.0 + math.exp(-zk))
            if available_moves(free, x, y, mask) == 0:
                break
            a = _escape_step(free, x, y, u, score, K, norms, mask, seen, h, vis, ist, fst,
                             wall_next)
            x += MOVES[a, 0]
            y += MOVES[a, 1]
            taken += 1
            paths[trial, taken, 0] = x
            paths[trial, taken, 1] = y
        final[trial, 0] = x
        final[trial, 1] = y
        steps[trial] = taken
