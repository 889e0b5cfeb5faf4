"""A Gymnasium environment of the drone (:mod:`cml_edge.drone.sim`), for DQN-style agents.

Needs gymnasium (the ``robot`` or ``dqn`` extra); the core package never imports this
module. ``import cml_edge`` registers ``cml_edge/DroneNav-v0`` (:data:`cml_edge.GYMNASIUM_ENVS`)::

    import cml_edge
    import gymnasium as gym

    env = gym.make("cml_edge/DroneNav-v0", goal_conditioned=True)

The robot's environment (:class:`cml_edge.robot.env.RobotNavEnv`) in three dimensions,
its step and rewards inherited. Dynamics: the drone, volume and 26 velocity commands of
:mod:`cml_edge.drone.sim`, on the ``kinematic`` (default) or ``mujoco`` simulator; one
environment step is one action (45 simulation steps, 2.25 s). An action whose trajectory
would leave the volume is *unavailable*: taking it leaves the drone where it is (the
step is spent and rewarded like any other), so the action space stays fixed;
``info["action_mask"]`` lists the available actions. An episode ends (``terminated``)
when the drone ends an action within ``radius`` (0.6 m) of the goal, and is truncated
after ``max_steps`` (100) actions.

Observation (float32, in [-1, 1]): the position scaled as 2 p / S - 1; with actions that
end moving (``ends="moving"``) also the velocity over the speed; goal-conditioned
environments append the goal's scaled position. Starts: the base (2, 2, 2) m at rest by
default, or (``start="random"``) a uniform position at rest. Goals: fixed (``goal``,
default the volume's centre) or, goal-conditioned, uniform on [0.5, S - 0.5]^3 per
episode.

Rewards per action t (distances in metres): ``simplified`` (Eq. 6) r_t = -||p_goal - p(t)||;
``tailored`` (Eq. 7) adds -1 for every action beyond n_min and R_goal = 100 on arrival,
where n_min = ceil(max(d_0 - radius, 0) / 1 m), the fewest 1 m actions that cover the
initial distance d_0.
"""

from __future__ import annotations

import math
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from cml_edge.drone.models import BASE, GOAL_MARGIN, GOAL_RADIUS, MAX_ACTIONS, base_state
from cml_edge.drone.sim import N_DRONE_ACTIONS, DroneConfig, make_drone_sim
from cml_edge.errors import InputError
from cml_edge.protocol import REWARDS
from cml_edge.robot.env import RobotNavEnv

ENV_ID = "cml_edge/DroneNav-v0"


class DroneNavEnv(RobotNavEnv):
    """Fly the drone to a goal with 26 velocity commands."""

    metadata = {"render_modes": ["ansi"], "render_fps": 4}

    def __init__(self, sim: str = "kinematic", goal: tuple[float, float, float] | None = None,
                 goal_conditioned: bool = False, start: str = "base",
                 reward: str = "simplified", max_steps: int = MAX_ACTIONS,
                 radius: float = GOAL_RADIUS, drone: DroneConfig | None = None,
                 render_mode: str | None = None, **sim_options: Any) -> None:
        gym.Env.__init__(self)
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
        self.drone = drone or DroneConfig()
        self.sim = make_drone_sim(sim, self.drone, **sim_options)
        self.goal_conditioned = bool(goal_conditioned)
        self.start_mode = start
        self.reward_name = reward
        self.max_steps = int(max_steps)
        self.radius = float(radius)
        self.render_mode = render_mode
        S = self.drone.arena
        self.fixed_goal = self._check_goal(goal if goal is not None else (S / 2,) * 3)
        self.forward = self.drone.step_length
        self.moving = self.drone.ends == "moving"
        n = 3 + 3 * self.moving + 3 * self.goal_conditioned
        self.observation_space = spaces.Box(-1.0, 1.0, shape=(n,), dtype=np.float32)
        self.action_space = spaces.Discrete(N_DRONE_ACTIONS)
        self.goal = self.fixed_goal.copy()
        self.t = 0
        self.n_min = 0
        self.mask = np.ones(N_DRONE_ACTIONS, np.uint8)

    def _check_goal(self, goal) -> np.ndarray:
        g = np.asarray(goal, dtype=np.float64).reshape(-1)
        S = self.drone.arena
        if g.shape != (3,) or not np.all(np.isfinite(g)) or not np.all((g >= 0) & (g <= S)):
            raise InputError(f"goal {goal!r} is not a point of the {S:g} m volume")
        return g

    def _distance(self) -> float:
        return float(np.sqrt(((self.sim.pose[:3] - self.goal) ** 2).sum()))

    def _obs(self) -> np.ndarray:
        p = self.sim.pose
        S = self.drone.arena
        parts = [2.0 * p[:3] / S - 1.0]
        if self.moving:
            parts.append(p[3:] / self.drone.speed)
        if self.goal_conditioned:
            parts.append(2.0 * self.goal / S - 1.0)
        return np.clip(np.concatenate(parts).astype(np.float32), -1.0, 1.0)

    def _info(self) -> dict[str, Any]:
        d = self._distance()
        return {"state": tuple(float(v) for v in self.sim.pose),
                "goal": tuple(float(v) for v in self.goal), "steps": self.t, "distance": d,
                "is_success": d <= self.radius, "action_mask": self.mask.copy()}

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        gym.Env.reset(self, seed=seed)
        options = options or {}
        c = self.drone
        if "goal" in options:
            if not self.goal_conditioned:
                raise InputError("the fixed-goal environment takes its goal at construction")
            self.goal = self._check_goal(options["goal"])
        elif self.goal_conditioned:
            self.goal = self.np_random.uniform(GOAL_MARGIN, c.arena - GOAL_MARGIN, size=3)
        else:
            self.goal = self.fixed_goal.copy()
        if "start" in options:
            start = np.asarray(options["start"], dtype=np.float64)
        elif self.start_mode == "base":
            start = base_state(BASE)
        else:
            start = base_state(self.np_random.uniform(c.lo, c.hi, size=3))
        self.sim.reset(start)
        self.t = 0
        self.n_min = int(math.ceil(max(self._distance() - self.radius, 0.0) / self.forward))
        self.mask = self.sim.available()
        return self._obs(), self._info()

    def render(self) -> str | None:
        if self.render_mode != "ansi":
            return None
        p = self.sim.pose
        return (f"t={self.t} position=({p[0]:.2f}, {p[1]:.2f}, {p[2]:.2f}) goal="
                f"({self.goal[0]:.2f}, {self.goal[1]:.2f}, {self.goal[2]:.2f}) "
                f"distance={self._distance():.2f}")
