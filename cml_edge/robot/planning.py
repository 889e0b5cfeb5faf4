"""Planning on the robot (paper 2.5, 3.5): WTA over utility x affordance among the available
actions, one loop for every path.

At each decision the robot reads its observation and the goal's
(:mod:`cml_edge.robot.observation`), scores every action by utility x affordance
(:mod:`cml_edge.core.step`) and drives the winner among the actions whose arc stays
inside the walls. The paper's stop rule: within ``radius`` = 0.25 m of the goal, checked
after each action (``stop="action"``; ``"step"`` checks at every 32 ms simulation step,
so passing through the circle counts), at most 100 actions.

:func:`plan_loop` states this once; the scorer and the simulator are plug-ins routed by
type: compiled with the seam scorer and the kinematic simulator (``direct``), or as the
loop's plain-Python ``py_func`` with the reference scorer (``reference``, bit-identical)
or the MuJoCo simulator.

Evaluation goals: uniform on [0.5, 29.5]^2, drawn on stream ``STREAM_ROBOT_GOALS``
(counters 2i, 2i + 1) of the evaluation seed (:mod:`cml_edge.protocol`).
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np
from numba import njit

from cml_edge.core.cml import CML, ReferenceScorer
from cml_edge.core.step import SeamScorer, prepare, scores, wta
from cml_edge.engine.stop import chunks
from cml_edge.errors import InputError
from cml_edge.jit.kernel import kernel
from cml_edge.jit.rng import stream_key, uniform
from cml_edge.protocol import STREAM_ROBOT_GOALS
from cml_edge.robot.observation import XY, RobotCMLSettings, observe, observe_goal
from cml_edge.robot.sim import (
    N_ROBOT_ACTIONS,
    KinematicSim,
    RobotConfig,
    RobotSim,
    set_pose,
    sim_available,
    sim_reset,
    sim_step,
    wrap_angle,
)

PATHS = ("direct", "reference")
STOPS = ("action", "step")
MAX_ACTIONS = 100
GOAL_RADIUS = 0.25
BASE_POSE = (2.0, 2.0, math.pi / 4)  # bottom left, facing the arena's centre
GOAL_MARGIN = 0.5  # goals are drawn in [0.5, 29.5]^2


class RobotPlanResult(NamedTuple):
    """Per trial: final pose, actions taken, reached (within the radius), path length (m,
    along the 32 ms simulation steps), the pose after each action, the actions, and, when
    kept, every simulation-step pose (``trails``, the first ``trail_len`` rows valid)."""

    final: np.ndarray  # (n, 3)
    steps: np.ndarray  # (n,)
    reached: np.ndarray  # (n,) bool
    length: np.ndarray  # (n,)
    poses: np.ndarray  # (n, max_actions + 1, 3), NaN after the last action
    actions: np.ndarray  # (n, max_actions), -1 after the last action
    trails: np.ndarray  # (n, max_actions x steps per action + 1, 3), or (n, 0, 3)
    trail_len: np.ndarray  # (n,)

    @property
    def paths(self) -> list[np.ndarray] | None:
        """Per trial, the simulation-step poses driven (None unless kept)."""
        if self.trails.shape[1] == 0:
            return None
        return [self.trails[i, : self.trail_len[i]] for i in range(len(self.trails))]


@njit(cache=True)
def polyline_length(path):
    """Length of the (n, 3) pose path's (x, y) polyline, summed in order."""
    total = 0.0
    for i in range(1, path.shape[0]):
        dx = path[i, 0] - path[i - 1, 0]
        dy = path[i, 1] - path[i - 1, 1]
        total += math.sqrt(dx * dx + dy * dy)
    return total


@njit(cache=True)
def first_within(path, gx, gy, radius):
    """The first simulation step of ``path`` (after its start) within ``radius`` of the goal,
    -1 if none."""
    for i in range(1, path.shape[0]):
        if math.hypot(path[i, 0] - gx, path[i, 1] - gy) <= radius:
            return i
    return -1


def drive_work(n_i: int) -> tuple:
    """The planning loop's work arrays: u and the scores, the pose and the next one, o, o*
    and o* - o (``n_i``), the available actions."""
    return (np.zeros(N_ROBOT_ACTIONS), np.zeros(N_ROBOT_ACTIONS), np.zeros(3), np.zeros(3),
            np.zeros(n_i), np.zeros(n_i), np.zeros(n_i), np.zeros(N_ROBOT_ACTIONS, np.uint8))


@kernel
def plan_loop(scorer, sim, frame, normalize, starts, goals, t0, t1, max_actions, radius,
              stop_each_step, sub, work, res):
    """Drive (start, goal) pairs ``t0 .. t1 - 1`` (the module docstring), for any scorer and
    simulator;
    ``sub`` ((steps per action + 1, 3)) receives each action's simulation steps, ``work``
    is :func:`drive_work`'s. A :func:`~cml_edge.jit.kernel.kernel`: no decision pays
    reference counts."""
    n_i = 2 if frame.mode == XY else 4
    if t0 == 0:
        prepare(scorer, normalize, False)  # W_v's columns, read once per batch
    final, steps, reached, lengths, poses, actions, trails, trail_len = res
    keep = trails.shape[1] > 0
    u, score, pose, new, o, o_star, dgo, mask = work
    for trial in range(t0, t1):
        sim_reset(sim, starts[trial], pose)
        gx = goals[trial, 0]
        gy = goals[trial, 1]
        set_pose(poses[trial, 0], pose)
        if keep:
            set_pose(trails[trial, 0], pose)
        kept = 1
        taken = 0
        length = 0.0
        while taken < max_actions:
            if math.hypot(pose[0] - gx, pose[1] - gy) <= radius:
                break
            if sim_available(sim, pose, mask) == 0:
                break
            observe(frame, pose, pose, o)
            observe_goal(frame, pose, gx, gy, o_star)
            for i in range(n_i):
                dgo[i] = o_star[i] - o[i]
            scores(scorer, o, dgo, u, score)
            a = wta(score, mask)
            sim_step(sim, pose, a, new, sub)
            end = first_within(sub, gx, gy, radius) if stop_each_step else -1
            last = sub.shape[0] - 1
            if end >= 0:  # the simulation halts inside the goal circle, mid-action
                last = end
                new[0] = sub[end, 0]
                new[1] = sub[end, 1]
                new[2] = wrap_angle(sub[end, 2])
            length += polyline_length(sub[: last + 1])
            if keep:
                for i in range(1, last + 1):
                    set_pose(trails[trial, kept], sub[i])
                    kept += 1
            set_pose(pose, new)
            actions[trial, taken] = a
            taken += 1
            set_pose(poses[trial, taken], pose)
        set_pose(final[trial], pose)
        steps[trial] = taken
        reached[trial] = math.hypot(pose[0] - gx, pose[1] - gy) <= radius
        lengths[trial] = length
        trail_len[trial] = kept


def plan_robot(cml: CML, sim: RobotSim, settings: RobotCMLSettings, starts, goals,
               max_actions: int = MAX_ACTIONS, radius: float = GOAL_RADIUS,
               path: str = "direct", keep_paths: bool = False,
               stop: str = "action") -> RobotPlanResult:
    """Drive the robot from each start pose (x, y, theta) to each goal (x, y)."""
    if path not in PATHS:
        raise InputError(f"unknown path {path!r}; allowed: {', '.join(PATHS)}")
    starts = np.ascontiguousarray(starts, dtype=np.float64).reshape(-1, 3)
    goals = np.ascontiguousarray(goals, dtype=np.float64).reshape(-1, 2)
    if len(starts) != len(goals):
        raise InputError(f"{len(starts)} starts but {len(goals)} goals")
    if isinstance(max_actions, bool) or int(max_actions) != max_actions or max_actions < 1:
        raise InputError(f"max actions {max_actions!r} is not a positive integer")
    if not math.isfinite(radius) or radius <= 0:
        raise InputError(f"goal radius {radius!r} is not a finite number > 0")
    if stop not in STOPS:
        raise InputError(f"unknown stop check {stop!r}; allowed: {', '.join(STOPS)}")
    max_actions = int(max_actions)
    n = len(starts)
    kept = max_actions * sim.config.steps_per_action + 1 if keep_paths else 0
    res = RobotPlanResult(np.zeros((n, 3)), np.zeros(n, np.int64), np.zeros(n, bool),
                          np.zeros(n), np.full((n, max_actions + 1, 3), np.nan),
                          np.full((n, max_actions), -1, np.int64), np.zeros((n, kept, 3)),
                          np.zeros(n, np.int64))
    scorer = ReferenceScorer(cml) if path == "reference" else SeamScorer.of(cml)
    compiled = path == "direct" and isinstance(sim, KinematicSim)
    loop = plan_loop if compiled else plan_loop.py_func
    sub = np.zeros((sim.config.steps_per_action + 1, 3))
    work = drive_work(settings.n_i)
    for t0, t1 in chunks(0, n, max_actions * sim.config.steps_per_action):
        loop(scorer, sim.plugin, settings.frame(), cml.config.utility == "normalized", starts,
             goals, t0, t1, max_actions, float(radius), stop == "step", sub, work, res)
    return res


# evaluation ---------------------------------------------------------------------------
def draw_goals(config: RobotConfig, trials: int, seed: int,
               margin: float = GOAL_MARGIN) -> np.ndarray:
    """``trials`` goals uniform on [margin, arena - margin]^2 from the evaluation ``seed``."""
    if isinstance(trials, bool) or int(trials) != trials or trials < 1:
        raise InputError(f"trials {trials!r} is not a positive integer")
    key = stream_key(int(seed), STREAM_ROBOT_GOALS)
    lo, hi = margin, config.arena - margin
    return np.array([[lo + (hi - lo) * uniform(key, 2 * i),
                      lo + (hi - lo) * uniform(key, 2 * i + 1)] for i in range(int(trials))])


def summarize_robot(res: RobotPlanResult, starts: np.ndarray, goals: np.ndarray) -> dict[str, Any]:
    """success_rate (within the radius), mean_actions and path_ratio (path length over the
    straight start-goal distance) over the successful trials, e_pos (Eq. 8) over all."""
    e_pos = np.hypot(*(res.final[:, :2] - goals).T)
    straight = np.hypot(*(goals - starts[:, :2]).T)
    ok = res.reached
    ratio = res.length[ok] / np.maximum(straight[ok], 1e-12)
    return {
        "trials": int(len(goals)),
        "success_rate": float(ok.mean()),
        "mean_actions": float(res.steps[ok].mean()) if ok.any() else None,
        "mean_actions_all": float(res.steps.mean()),
        "path_ratio": float(ratio.mean()) if ok.any() else None,
        "path_ratio_median": float(np.median(ratio)) if ok.any() else None,
        "e_pos_mean": float(e_pos.mean()),
        "e_pos_median": float(np.median(e_pos)),
    }
