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
from cml_edge.robot.observation import RobotCMLSettings, observe, observe_goal
from cml_edge.robot.sim import (
    N_ROBOT_ACTIONS,
    RobotConfig,
    RobotSim,
    set_pose,
    sim_available,
    sim_pose_at,
    sim_reset,
    sim_step,
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
def polyline_length(path, dims):
    """Length of the pose path's polyline in its first ``dims`` coordinates (the robot's
    (x, y), the drone's (x, y, z)), summed in order."""
    total = 0.0
    for i in range(1, path.shape[0]):
        sq = 0.0
        for k in range(dims):
            d = path[i, k] - path[i - 1, k]
            sq += d * d
        total += math.sqrt(sq)
    return total


@njit(cache=True)
def distance(pose, goal):
    """Distance from the pose's position to the goal (a plane's by ``math.hypot``)."""
    if goal.shape[0] == 2:
        return math.hypot(pose[0] - goal[0], pose[1] - goal[1])
    sq = 0.0
    for k in range(goal.shape[0]):
        d = pose[k] - goal[k]
        sq += d * d
    return math.sqrt(sq)


@njit(cache=True)
def first_within(path, goal, radius):
    """The first simulation step of ``path`` (after its start) within ``radius`` of the goal,
    -1 if none."""
    for i in range(1, path.shape[0]):
        if distance(path[i], goal) <= radius:
            return i
    return -1


def drive_work(n_i: int, pose_size: int = 3, n_actions: int = N_ROBOT_ACTIONS) -> tuple:
    """The planning loop's work arrays: u and the scores (``n_actions``), the pose and the
    next one (``pose_size``), o, o* and o* - o (``n_i``), the available actions."""
    return (np.zeros(n_actions), np.zeros(n_actions), np.zeros(pose_size), np.zeros(pose_size),
            np.zeros(n_i), np.zeros(n_i), np.zeros(n_i), np.zeros(n_actions, np.uint8))


@kernel
def plan_loop(scorer, sim, frame, normalize, starts, goals, t0, t1, max_actions, radius,
              stop_each_step, sub, work, res):
    """Drive (start, goal) pairs ``t0 .. t1 - 1`` (the module docstring), for any scorer and
    simulator;
    ``sub`` ((steps per action + 1, 3)) receives each action's simulation steps, ``work``
    is :func:`drive_work`'s. A :func:`~cml_edge.jit.kernel.kernel`: no decision pays
    reference counts. The vehicle is the simulator's and its observation the frame's
    (routed by type); a goal is a position, ``goals.shape[1]`` coordinates."""
    if t0 == 0:
        prepare(scorer, normalize, False)  # W_v's columns, read once per batch
    final, steps, reached, lengths, poses, actions, trails, trail_len = res
    keep = trails.shape[1] > 0
    u, score, pose, new, o, o_star, dgo, mask = work
    n_i = o.shape[0]
    dims = goals.shape[1]
    for trial in range(t0, t1):
        sim_reset(sim, starts[trial], pose)
        goal = goals[trial]
        set_pose(poses[trial, 0], pose)
        if keep:
            set_pose(trails[trial, 0], pose)
        kept = 1
        taken = 0
        length = 0.0
        while taken < max_actions:
            if distance(pose, goal) <= radius:
                break
            if sim_available(sim, pose, mask) == 0:
                break
            observe(frame, pose, pose, o)
            observe_goal(frame, pose, goal, o_star)
            for i in range(n_i):
                dgo[i] = o_star[i] - o[i]
            scores(scorer, o, dgo, u, score)
            a = wta(score, mask)
            sim_step(sim, pose, a, new, sub)
            end = first_within(sub, goal, radius) if stop_each_step else -1
            last = sub.shape[0] - 1
            if end >= 0:  # the simulation halts inside the goal circle, mid-action
                last = end
                sim_pose_at(sim, sub[end], new)
            length += polyline_length(sub[: last + 1], dims)
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
        reached[trial] = distance(pose, goal) <= radius
        lengths[trial] = length
        trail_len[trial] = kept


def plan_robot(cml: CML, sim: RobotSim, settings: RobotCMLSettings, starts, goals,
               max_actions: int = MAX_ACTIONS, radius: float = GOAL_RADIUS,
               path: str = "direct", keep_paths: bool = False,
               stop: str = "action") -> RobotPlanResult:
    """Drive the robot from each start pose (x, y, theta) to each goal (x, y); any
    simulator's vehicle from its poses to its goals (:class:`~cml_edge.robot.sim.RobotSim`'s
    ``pose_size`` and ``goal_dims``)."""
    if path not in PATHS:
        raise InputError(f"unknown path {path!r}; allowed: {', '.join(PATHS)}")
    starts = np.ascontiguousarray(starts, dtype=np.float64).reshape(-1, sim.pose_size)
    goals = np.ascontiguousarray(goals, dtype=np.float64).reshape(-1, sim.goal_dims)
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
    size = sim.pose_size
    res = RobotPlanResult(np.zeros((n, size)), np.zeros(n, np.int64), np.zeros(n, bool),
                          np.zeros(n), np.full((n, max_actions + 1, size), np.nan),
                          np.full((n, max_actions), -1, np.int64), np.zeros((n, kept, size)),
                          np.zeros(n, np.int64))
    scorer = ReferenceScorer(cml) if path == "reference" else SeamScorer.of(cml)
    compiled = path == "direct" and sim.compiled
    loop = plan_loop if compiled else plan_loop.py_func
    sub = np.zeros((sim.config.steps_per_action + 1, size))
    work = drive_work(settings.n_i, size, sim.n_actions)
    for t0, t1 in chunks(0, n, max_actions * sim.config.steps_per_action):
        loop(scorer, sim.plugin, settings.frame(), cml.config.utility == "normalized", starts,
             goals, t0, t1, max_actions, float(radius), stop == "step", sub, work, res)
    return res


# evaluation ---------------------------------------------------------------------------
def draw_goals(config: RobotConfig, trials: int, seed: int,
               margin: float = GOAL_MARGIN, dims: int = 2,
               stream: int = STREAM_ROBOT_GOALS) -> np.ndarray:
    """``trials`` goals uniform on [margin, arena - margin]^dims from the evaluation
    ``seed`` (counters dims x i + k on ``stream``; the drone's goals: dims 3 on its own)."""
    if isinstance(trials, bool) or int(trials) != trials or trials < 1:
        raise InputError(f"trials {trials!r} is not a positive integer")
    key = stream_key(int(seed), stream)
    lo, hi = margin, config.arena - margin
    return np.array([[lo + (hi - lo) * uniform(key, dims * i + k) for k in range(dims)]
                     for i in range(int(trials))])


def distances(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row by row, the distance between positions (a plane's by ``np.hypot``)."""
    d = a - b
    return np.hypot(*d.T) if d.shape[1] == 2 else np.sqrt((d * d).sum(axis=1))


def summarize_robot(res: RobotPlanResult, starts: np.ndarray, goals: np.ndarray) -> dict[str, Any]:
    """success_rate (within the radius), mean_actions and path_ratio (path length over the
    straight start-goal distance) over the successful trials, e_pos (Eq. 8) over all."""
    dims = goals.shape[1]
    e_pos = distances(res.final[:, :dims], goals)
    straight = distances(goals, starts[:, :dims])
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
