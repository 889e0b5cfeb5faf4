"""A Gymnasium environment of the continuous robot (paper 2.5, 3.5), for the DQN baseline.

Needs gymnasium (the ``robot`` or ``dqn`` extra); the core package never imports this
module. ``import cml_edge`` registers ``cml_edge/RobotNav-v0`` (:data:`cml_edge.GYMNASIUM_ENVS`)::

    import cml_edge
    import gymnasium as gym

    env = gym.make("cml_edge/RobotNav-v0", observation="heading", goal_conditioned=True)

Dynamics: the robot, arena and eight Table-1 actions of :mod:`cml_edge.robot.sim`, on the
``kinematic`` (default) or ``mujoco`` simulator; one environment step is one action
(64 simulation steps, 2.048 s). An action whose arc would leave the arena is
*unavailable*: taking it leaves the robot where it is (the step is spent and rewarded
like any other), as in the grid environment (:mod:`cml_edge.grid.env`), so the action
space stays fixed for a DQN; ``info["action_mask"]`` lists the available actions for
agents that can mask. An episode ends (``terminated``) when the robot ends an action
within ``radius`` (0.25 m) of the goal, and is truncated after ``max_steps`` (100)
actions.

Observation (float32, in [-1, 1]): ``xy`` gives (x, y) scaled as 2 p / S - 1; ``heading``
adds (cos theta, sin theta); goal-conditioned environments append the goal's scaled
(x, y). Starts: the base pose (2, 2, pi/4) by default, or (``start="random"``) a uniform
pose. Goals: fixed (``goal``, default the arena centre) or, goal-conditioned, uniform on
[0.5, S - 0.5]^2 per episode.

Rewards per action t (distances in metres): ``simplified`` (Eq. 6) r_t = -||p_goal - p(t)||;
``tailored`` (Eq. 7) adds -1 for every action beyond n_min and R_goal = 100 on arrival,
where n_min = ceil(max(d_0 - radius, 0) / 0.4986), the fewest forward actions
(0.4986 m each) that cover the initial distance d_0 (the continuous stand-in for the
grid's Chebyshev distance).
"""

from __future__ import annotations

import math
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from cml_edge.errors import InputError
from cml_edge.protocol import R_GOAL, REWARDS
from cml_edge.robot.planning import BASE_POSE, GOAL_MARGIN, GOAL_RADIUS, MAX_ACTIONS
from cml_edge.robot.sim import N_ROBOT_ACTIONS, RobotConfig, action_geometry, make_sim

ENV_ID = "cml_edge/RobotNav-v0"


class RobotNavEnv(gym.Env):
    """Drive the differential-drive robot to a goal with Table 1's eight actions."""

    metadata = {"render_modes": ["ansi"], "render_fps": 4}

    def __init__(self, observation: str = "xy", sim: str = "kinematic",
                 goal: tuple[float, float] | None = None, goal_conditioned: bool = False,
                 start: str = "base", reward: str = "simplified",
                 max_steps: int = MAX_ACTIONS, radius: float = GOAL_RADIUS,
                 robot: RobotConfig | None = None, render_mode: str | None = None,
                 **sim_options: Any) -> None:
        super().__init__()
        if observation not in ("xy", "heading"):
            raise InputError(f"unknown observation {observation!r}; allowed: xy, heading")
        if reward not in REWARDS:
            raise InputError(f"unknown reward {reward!r}; allowed: {', '.join(REWARDS)}")
        if start not in ("base", "random"):
            raise InputError(f"unknown start {start!r}; allowed: base, random")
        if isinstance(max_steps, bool) or int(max_steps) != max_steps or max_steps < 1:
            raise InputError(f"max_steps {max_steps!r} is not a positive integer")
        if not math.isfinite(radius) or radius <= 0:
            raise InputError(f"radius {radius!r} is not a finite number > 0")
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise InputError(f"render_mode {render_mode!r} is not one of "
                             f"{self.metadata['render_modes']}")
        self.robot = robot or RobotConfig()
        self.sim = make_sim(sim, self.robot, **sim_options)
        self.observation = observation
        self.goal_conditioned = bool(goal_conditioned)
        self.start_mode = start
        self.reward_name = reward
        self.max_steps = int(max_steps)
        self.radius = float(radius)
        self.render_mode = render_mode
        S = self.robot.arena
        self.fixed_goal = self._check_goal(goal if goal is not None else (S / 2, S / 2))
        self.forward = float(action_geometry(self.robot)["chord_length"][1])
        n = (2 if observation == "xy" else 4) + (2 if self.goal_conditioned else 0)
        self.observation_space = spaces.Box(-1.0, 1.0, shape=(n,), dtype=np.float32)
        self.action_space = spaces.Discrete(N_ROBOT_ACTIONS)
        self.goal = self.fixed_goal.copy()
        self.t = 0
        self.n_min = 0
        self.mask = np.ones(N_ROBOT_ACTIONS, np.uint8)

    def _check_goal(self, goal) -> np.ndarray:
        g = np.asarray(goal, dtype=np.float64).reshape(-1)
        S = self.robot.arena
        if g.shape != (2,) or not np.all(np.isfinite(g)) or not np.all((g >= 0) & (g <= S)):
            raise InputError(f"goal {goal!r} is not a point of the {S:g} x {S:g} m arena")
        return g

    def _distance(self) -> float:
        p = self.sim.pose
        return math.hypot(p[0] - self.goal[0], p[1] - self.goal[1])

    def _obs(self) -> np.ndarray:
        p = self.sim.pose
        S = self.robot.arena
        parts = [2.0 * p[0] / S - 1.0, 2.0 * p[1] / S - 1.0]
        if self.observation == "heading":
            parts += [math.cos(p[2]), math.sin(p[2])]
        if self.goal_conditioned:
            parts += [2.0 * self.goal[0] / S - 1.0, 2.0 * self.goal[1] / S - 1.0]
        return np.clip(np.array(parts, dtype=np.float32), -1.0, 1.0)

    def _info(self) -> dict[str, Any]:
        p = self.sim.pose
        return {"pose": (float(p[0]), float(p[1]), float(p[2])),
                "goal": (float(self.goal[0]), float(self.goal[1])), "steps": self.t,
                "distance": self._distance(), "is_success": self._distance() <= self.radius,
                "action_mask": self.mask.copy()}

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        super().reset(seed=seed)
        options = options or {}
        rc = self.robot
        if "goal" in options:
            if not self.goal_conditioned:
                raise InputError("the fixed-goal environment takes its goal at construction")
            self.goal = self._check_goal(options["goal"])
        elif self.goal_conditioned:
            self.goal = self.np_random.uniform(GOAL_MARGIN, rc.arena - GOAL_MARGIN, size=2)
        else:
            self.goal = self.fixed_goal.copy()
        if "start" in options:
            start = np.asarray(options["start"], dtype=np.float64)
        elif self.start_mode == "base":
            start = np.array(BASE_POSE)
        else:
            start = np.array([*self.np_random.uniform(rc.lo, rc.hi, size=2),
                              self.np_random.uniform(-math.pi, math.pi)])
        self.sim.reset(start)
        self.t = 0
        self.n_min = int(math.ceil(max(self._distance() - self.radius, 0.0) / self.forward))
        self.mask = self.sim.available()
        return self._obs(), self._info()

    def step(self, action):
        if not self.action_space.contains(action):
            raise InputError(f"action {action!r} is not in 0..{self.action_space.n - 1}")
        if self.mask[int(action)]:
            self.sim.step(int(action))
        self.t += 1
        dist = self._distance()
        reached = dist <= self.radius
        reward = -dist
        if self.reward_name == "tailored":
            reward += -float(self.t > self.n_min) + R_GOAL * reached
        self.mask = self.sim.available()
        terminated = bool(reached)
        truncated = bool(not terminated and self.t >= self.max_steps)
        return self._obs(), float(reward), terminated, truncated, self._info()

    def render(self) -> str | None:
        if self.render_mode != "ansi":
            return None
        p = self.sim.pose
        return (f"t={self.t} pose=({p[0]:.2f}, {p[1]:.2f}, {p[2]:.2f}) goal=({self.goal[0]:.2f}, "
                f"{self.goal[1]:.2f}) distance={self._distance():.2f}")

