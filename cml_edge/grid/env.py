"""Gymnasium adapters of the grid arena (paper 2.3), used by the DQN baseline.

Needs the optional ``dqn`` extra (gymnasium); the core package never imports this module.
``import cml_edge`` registers three environments (:data:`cml_edge.GYMNASIUM_ENVS`, as soon as
Gymnasium is imported)::

    import cml_edge
    import gymnasium as gym

    env = gym.make("cml_edge/GridNav-v0", reward="tailored", goal=(20, 7))
    env = gym.make("cml_edge/GridNavGoal-v0")        # goal-conditioned
    env = gym.make("cml_edge/GridNav3D-v0")          # an N x N x N volume, 26 moves

Dynamics, the same as the CML's arena (:mod:`cml_edge.grid.arena`):

- positions are integer cells of an N x N grid (default 30, the paper's), or of an
  N x N x N volume (``dims=3``), with optional point obstacles (``obstacles`` cells placed
  from ``obstacle_seed`` exactly as :meth:`GridArena.with_obstacles` places them, or an
  explicit ``arena``);
- the actions are the arena's moves (:func:`~cml_edge.grid.arena.move_table`): on the
  plane the 8 king moves ``MOVES[a]`` (E, NE, N, NW, W, SW, S, SE), in space 26 (or, with
  ``moves="face"``, 4 and 6), no "stay";
- a move off the arena or into an obstacle leaves the agent **in place** (the step is
  spent and rewarded like any other). This is what grid-world environments usually do,
  and it keeps the action space fixed for the DQN. The CML's planner instead masks such
  moves (it never proposes them); the DQN has to learn not to take them;
- reaching the goal ends the episode (``terminated``); otherwise the episode is truncated
  after ``max_steps`` = 100 actions (T_epis of Eq. 6).

Observation (float32, every component in [-1, 1]): the paper's (x, y) for the fixed-goal
environment, (x, y, goal x, goal y) for the goal-conditioned one ((x, y, z) and
(x, y, z, goal x, goal y, goal z) in space), each coordinate scaled
as ``o = 2 p / (N - 1) - 1`` (cell 0 -> -1, cell N-1 -> +1). The paper feeds "the agent's
coordinates" without saying how they are scaled; centred unit-range inputs are what a
small ReLU network trains well on (raw cell indices up to 29 would saturate the first
layer's initial scale).

Rewards, per step t = 1, 2, ... (p(t) is the cell after action t, distances in cells):

- ``simplified`` (Eq. 6): r_t = -||p_goal - p(t)||_2, so the episode return is R_simp;
- ``tailored`` (Eq. 7): r_t = -||p_goal - p(t)||_2 - [t > d_Ch(p_init, p_goal)]
  (d_Ch the fewest moves on the empty arena, :func:`~cml_edge.grid.arena.fewest_moves`)
  + R_goal [p(t) = p_goal], with R_goal = 100. The indicator is the per-step increment
  of R_path = max(t - d_Ch, 0), so the episode return is exactly R_tail: a penalty of 1
  for every action beyond the shortest path. (It depends on t and p_init, which the
  paper's (x, y) observation does not show the network; that is the paper's design.)
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from cml_edge.errors import InputError
from cml_edge.grid.arena import MOVES, GridArena, fewest_moves
from cml_edge.protocol import R_GOAL, REWARDS

MAX_EPISODE_STEPS = 100
ENV_ID = "cml_edge/GridNav-v0"
GOAL_ENV_ID = "cml_edge/GridNavGoal-v0"
ENV_3D_ID = "cml_edge/GridNav3D-v0"


def scale_positions(p: np.ndarray, size: int) -> np.ndarray:
    """Observation scaling: cell index p in 0..N-1 -> 2 p / (N - 1) - 1 in [-1, 1] (float32)."""
    return (2.0 * np.asarray(p, dtype=np.float64) / (size - 1) - 1.0).astype(np.float32)


def apply_moves(free: np.ndarray, pos: np.ndarray, actions: np.ndarray,
                table: np.ndarray = MOVES) -> np.ndarray:
    """Next cells of agents at ``pos`` (n, dims) taking ``actions`` (n,) of the move
    ``table``: a move off the arena or into an obstacle leaves the agent in place. The
    environment and the batched evaluation both step through this one function."""
    pos = np.asarray(pos, dtype=np.int64).reshape(-1, free.ndim)
    nxt = pos + table[np.asarray(actions, dtype=np.int64).reshape(-1)]
    n = free.shape[0]
    inside = ((nxt >= 0) & (nxt < n)).all(axis=1)
    ok = inside.copy()
    ok[inside] = free[tuple(nxt[inside].T)] != 0
    return np.where(ok[:, None], nxt, pos)


def step_rewards(reward: str, new_pos: np.ndarray, goals: np.ndarray, t: np.ndarray,
                 d_ch: np.ndarray, r_goal: float = R_GOAL) -> np.ndarray:
    """Per-step reward of Eq. 6 or Eq. 7 (see the module docstring), batched.

    ``t`` is the number of actions taken including this one, ``d_ch`` the Chebyshev
    distance from the episode's start to its goal.
    """
    dist = np.linalg.norm(np.asarray(goals, float) - np.asarray(new_pos, float), axis=-1)
    if reward == "simplified":
        return -dist
    if reward == "tailored":
        reached = dist == 0
        return -dist - (np.asarray(t) > np.asarray(d_ch)) + r_goal * reached
    raise InputError(f"unknown reward {reward!r}; allowed: {', '.join(REWARDS)}")


class GridNavEnv(gym.Env):
    """Navigate a grid arena to a goal with its moves (paper 2.3; ``dims`` 3: a volume).

    ``goal_conditioned=False`` (the paper's DQN): the goal is fixed for the environment's
    life (``goal``, default the centre cell) and the observation is (x, y).
    ``goal_conditioned=True``: each episode draws a goal uniformly among the free cells and
    the observation is (x, y, goal x, goal y). Starts are drawn uniformly among the free
    cells other than the goal. ``reset(options={"start": (x, y), "goal": (x, y)})`` fixes
    them for one episode ("goal" only when goal-conditioned).
    """

    metadata = {"render_modes": ["ansi"], "render_fps": 4}

    def __init__(self, size: int = 30, goal: tuple[int, int] | None = None,
                 goal_conditioned: bool = False, reward: str = "simplified",
                 obstacles: int = 0, obstacle_seed: int = 123,
                 arena: GridArena | None = None, max_steps: int = MAX_EPISODE_STEPS,
                 r_goal: float = R_GOAL, render_mode: str | None = None, dims: int = 2,
                 moves: str = "king") -> None:
        super().__init__()
        if reward not in REWARDS:
            raise InputError(f"unknown reward {reward!r}; allowed: {', '.join(REWARDS)}")
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise InputError(f"render_mode {render_mode!r} is not one of "
                             f"{self.metadata['render_modes']}")
        if isinstance(max_steps, bool) or int(max_steps) != max_steps or max_steps < 1:
            raise InputError(f"max_steps {max_steps!r} is not a positive integer")
        if arena is None:
            arena = (GridArena.with_obstacles(size, obstacles, obstacle_seed, dims, moves)
                     if obstacles else GridArena.empty(size, dims, moves))
        self.arena = arena
        self.size = arena.size
        self.free = arena.free
        self.free_cells = np.argwhere(self.free != 0)
        if len(self.free_cells) < 2:
            raise InputError("the arena has fewer than two free cells")
        self.goal_conditioned = bool(goal_conditioned)
        self.reward_name = reward
        self.max_steps = int(max_steps)
        self.r_goal = float(r_goal)
        self.render_mode = render_mode
        self.table = arena.move_table
        if goal is None:
            goal = (self.size // 2,) * arena.dims
        self.fixed_goal = self._check_cell(goal, "goal")
        n_obs = arena.dims * (2 if self.goal_conditioned else 1)
        self.observation_space = spaces.Box(-1.0, 1.0, shape=(n_obs,), dtype=np.float32)
        self.action_space = spaces.Discrete(arena.n_actions)
        self.pos = self.fixed_goal.copy()
        self.goal = self.fixed_goal.copy()
        self.start = self.fixed_goal.copy()
        self.t = 0
        self.d_ch = 0

    def _check_cell(self, cell, name: str) -> np.ndarray:
        c = np.asarray(cell, dtype=np.int64).reshape(-1)
        dims = self.arena.dims
        if c.shape != (dims,) or not self.arena.is_free(tuple(int(v) for v in c)):
            raise InputError(f"{name} {tuple(np.asarray(cell).tolist())} is not a free cell "
                             f"of the {' x '.join([str(self.size)] * dims)} arena")
        return c

    def _obs(self) -> np.ndarray:
        cells = np.concatenate([self.pos, self.goal]) if self.goal_conditioned else self.pos
        return scale_positions(cells, self.size)

    def _info(self) -> dict[str, Any]:
        return {"position": tuple(int(v) for v in self.pos),
                "goal": tuple(int(v) for v in self.goal), "steps": self.t,
                "is_success": bool((self.pos == self.goal).all())}

    def _random_cell(self, exclude: np.ndarray | None = None) -> np.ndarray:
        while True:
            c = self.free_cells[int(self.np_random.integers(len(self.free_cells)))].copy()
            if exclude is None or not (c == exclude).all():
                return c

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        super().reset(seed=seed)
        options = options or {}
        if "goal" in options:
            if not self.goal_conditioned:
                raise InputError("the fixed-goal environment takes its goal at construction")
            self.goal = self._check_cell(options["goal"], "goal")
        elif self.goal_conditioned:
            self.goal = self._random_cell()
        else:
            self.goal = self.fixed_goal.copy()
        if "start" in options:
            self.pos = self._check_cell(options["start"], "start")
        else:
            self.pos = self._random_cell(exclude=self.goal)
        self.start = self.pos.copy()
        self.t = 0
        self.d_ch = int(fewest_moves(self.start, self.goal, self.arena.moves))
        return self._obs(), self._info()

    def step(self, action):
        if not self.action_space.contains(action):
            raise InputError(f"action {action!r} is not in 0..{self.action_space.n - 1}")
        self.pos = apply_moves(self.free, self.pos, np.array([int(action)]), self.table)[0]
        self.t += 1
        reward = step_rewards(self.reward_name, self.pos[None], self.goal[None],
                              np.array([self.t]), np.array([self.d_ch]), self.r_goal)[0]
        terminated = bool((self.pos == self.goal).all())
        truncated = bool(not terminated and self.t >= self.max_steps)
        return self._obs(), float(reward), terminated, truncated, self._info()

    def render(self) -> str | None:
        if self.render_mode != "ansi":
            return None
        if self.arena.dims == 2:
            return self._layer(self.free, ()) + "\n"
        return "\n".join(f"z = {z}\n" + self._layer(self.free[:, :, z], (z,))  # the top first
                         for z in range(self.size - 1, -1, -1)) + "\n"

    def _layer(self, free: np.ndarray, z: tuple) -> str:
        """One horizontal layer (y up, x right): A the agent, G the goal, # blocked."""
        rows = []
        for y in range(self.size - 1, -1, -1):
            row = []
            for x in range(self.size):
                if (x, y, *z) == tuple(self.pos):
                    row.append("A")
                elif (x, y, *z) == tuple(self.goal):
                    row.append("G")
                else:
                    row.append("#" if free[x, y] == 0 else ".")
            rows.append("".join(row))
        return "\n".join(rows)

