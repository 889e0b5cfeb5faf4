"""The CML driving the continuous robot (paper 2.5, 3.5): observations, training, planning.

The CML is the package's (:mod:`cml_edge.core.cml`), unchanged; its arrays are read and
updated through the synaptic-array seam, so any backend runs here. What this module
adds is how the robot's pose becomes an observation o, and the loops.

Observations (``observation``; the pose is (x, y, theta), p = (x, y), c = 15 m the
arena centre, S = 30 m its side, as the grid scales its cells):

- ``xy`` (the paper's, N_i = 2): o = (p - c) / S in the world frame.
- ``heading`` (N_i = 4): the robot observes (x, y, cos theta, sin theta) and reads every
  observation of a decision in the frame of its heading at that moment (as wheel
  odometry and a compass give it): o = (R(-theta_t) (p - c) / S, h cos(theta - theta_t),
  h sin(theta - theta_t)), with h = ``heading_scale``. At step t, o_t and o_{t+1} are
  both read in the frame of theta_t; in planning, o and o* in the frame of the current
  heading. Why: Table 1's actions are arcs relative to the heading, so in any fixed
  frame an action's displacement o_{t+1} - o_t depends on theta, and the CML's model
  s_{t+1} = s_t + W_v a_t (one fixed vector per action, with s = W_q o linear) can only
  learn its average over headings, which is ~0. Read in the heading's frame, the
  displacement of action a is the same for every pose (its chord and its turn), and the
  CML's model is exact.
- ``heading-world`` (N_i = 4): (x, y, h cos theta, h sin theta) in the world frame, the
  literal reading. Kept to measure the point above.

The goal (paper 2.1: o* is the goal's observation) has no heading. ``goal_heading``:

- ``bearing`` (default): o* carries the direction from the robot to the goal, re-read at
  every decision (the heading a straight drive would arrive with). Its heading part
  h (cos b - 1, sin b), b the goal's bearing in the robot's frame, rewards the actions
  that turn towards the goal; near the goal it dominates, so the robot faces the goal
  before the last moves.
- ``keep``: o* carries the robot's current heading, so the heading part of
  d = W_q (o* - o) is zero. Measured worse: a turning action's learned vector W_v a is
  mostly its turn, which then earns no utility (the normalised utility even divides it
  out), so the robot circles the goal at ~0.3 m (10 seeds x 100 goals: 0.07 success
  normalised, 0.64 raw, against 0.96 and 1.00 for ``bearing``).

Utility. The robot's default is the paper's ``raw`` inner product u = W_v^T d (the grid's
default divides by W_v's column norms). Measured on the robot (10 x 100, converged):
``raw`` 1.00 success, ``normalized`` 0.96. Near the goal the discrete arcs (0.41-0.60 m
chords) against the 0.25 m circle make 2-cycles; the normalised utility ranks actions
by direction alone and falls into them more often.

Scaling. o is centred on the arena and divided by its side, as the grid does; the
heading's unit vector is divided by the side too (h = 1/30), so one radian of turning
weighs about as much in the embedding as one metre of travel. Eq. 3's per-walk summed
update has gain lr_q x steps x E|o|^2 <= 0.001 x 900 x (0.5 + h^2) = 0.45 < 1 anywhere
in the arena; it is measured during training (``eq3_gain``, ~0.3 for 900 steps).

Training: random walks; each walk starts at a uniformly random pose (position anywhere
the robot fits, heading uniform); each step takes a uniformly random *available* action
(an action whose arc would leave the arena is never drawn, as on the grid); the local
rule (Eqs. 1-3) runs through :func:`cml_edge.learning.learn_step` (reference) or the
same reads and updates compiled (``direct``), bit-identical. Planning: WTA over
utility x affordance among the available actions, the paper's stop rule (within
``radius`` = 0.25 m of the goal, checked after each action, at most 100 actions).

Randomness: walk starts on stream :data:`STREAM_ROBOT_START` (counters 3w..3w+2),
exploration on :data:`STREAM_ROBOT_EXPLORE` (counter w x steps + t), evaluation goals on
:data:`STREAM_ROBOT_GOALS` (counters 2i, 2i + 1) of the evaluation seed.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import asdict, dataclass, fields
from typing import Any

import numpy as np
from numba import njit

from cml_edge.core.cml import CML, CMLConfig
from cml_edge.core.learning import check_walks, end_walk, learn_step, schedule_defers
from cml_edge.core.step import (
    learn_buffers,
    plan_buffers,
    seam_commit,
    seam_learn,
    seam_scores,
    seam_utility_norms,
    wta,
)
from cml_edge.errors import InputError
from cml_edge.protocol import STREAM_ROBOT_EXPLORE, STREAM_ROBOT_GOALS, STREAM_ROBOT_START
from cml_edge.rng import stream_key, uniform
from cml_edge.robot.sim import (
    N_ROBOT_ACTIONS,
    KinematicSim,
    RobotConfig,
    RobotSim,
    available_actions,
    drive,
    nth_available,
    wrap_angle,
)

OBSERVATIONS = ("xy", "heading", "heading-world")
XY, HEADING, HEADING_WORLD = 0, 1, 2
GOAL_HEADINGS = ("keep", "bearing")
KEEP, BEARING = 0, 1
PATHS = ("direct", "reference")
STOPS = ("action", "step")


DEFAULT_UTILITY = "raw"
MAX_ACTIONS = 100
GOAL_RADIUS = 0.25
BASE_POSE = (2.0, 2.0, math.pi / 4)  # bottom left, facing the arena's centre
GOAL_MARGIN = 0.5  # goals are drawn in [0.5, 29.5]^2


@dataclass(frozen=True)
class RobotCMLSettings:
    """How the robot's pose is observed (module docstring)."""

    observation: str = "heading"
    goal_heading: str = "bearing"
    heading_scale: float = 1.0 / 30.0
    origin: float = 15.0
    scale: float = 30.0

    def __post_init__(self) -> None:
        if self.observation not in OBSERVATIONS:
            raise InputError(f"unknown observation {self.observation!r}; allowed: "
                             f"{', '.join(OBSERVATIONS)}")
        if self.goal_heading not in GOAL_HEADINGS:
            raise InputError(f"unknown goal heading {self.goal_heading!r}; allowed: "
                             f"{', '.join(GOAL_HEADINGS)}")
        for name in ("heading_scale", "scale"):
            v = getattr(self, name)
            if not math.isfinite(v) or v <= 0:
                raise InputError(f"{name.replace('_', '-')} {v!r} is not a finite number > 0")
        if not math.isfinite(self.origin):
            raise InputError(f"origin {self.origin!r} is not finite")

    @property
    def mode(self) -> int:
        return OBSERVATIONS.index(self.observation)

    @property
    def goal_code(self) -> int:
        return GOAL_HEADINGS.index(self.goal_heading)

    @property
    def n_i(self) -> int:
        return 2 if self.observation == "xy" else 4

    def cml_config(self, **overrides: Any) -> CMLConfig:
        """The CML's configuration for this observation (N_i = 2 or 4, the same frame), with
        the robot's default utility, ``raw`` (module docstring)."""
        return CMLConfig(**{"n_i": self.n_i, "obs_scale": self.scale, "obs_origin": self.origin,
                            "utility": DEFAULT_UTILITY, **overrides})

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> RobotCMLSettings:
        known = {f.name for f in fields(cls)}
        unknown = set(d) - known
        if unknown:
            raise InputError(f"unknown robot CML settings: {', '.join(sorted(unknown))}")
        return cls(**d)


@dataclass(frozen=True)
class RobotTrainConfig:
    """Random-walk training. The paper does not give the robot's walks and steps; the
    default is its grid protocol, 100 walks x 900 steps (90,000 actions, 51 h of simulated
    driving at 2.048 s an action), by which W_v has converged (its initial value decays as
    (1 - lr_v)^(steps x walks / 8) = e^-11)."""

    walks: int = 100
    steps: int = 900
    schedule: str = "walk"

    def __post_init__(self) -> None:
        check_walks(self.walks, self.steps)
        schedule_defers(self.schedule)


# observations -------------------------------------------------------------------------
@njit(cache=True)
def observe(mode, ref, pose, origin, scale, hscale, out):
    """The observation of ``pose`` read in the frame of ``ref`` (module docstring)."""
    px = (pose[0] - origin) / scale
    py = (pose[1] - origin) / scale
    if mode == HEADING:
        c = math.cos(ref[2])
        s = math.sin(ref[2])
        out[0] = c * px + s * py
        out[1] = c * py - s * px
        d = pose[2] - ref[2]
        out[2] = hscale * math.cos(d)
        out[3] = hscale * math.sin(d)
    else:
        out[0] = px
        out[1] = py
        if mode == HEADING_WORLD:
            out[2] = hscale * math.cos(pose[2])
            out[3] = hscale * math.sin(pose[2])


@njit(cache=True)
def observe_goal(mode, goal_heading, ref, gx, gy, origin, scale, hscale, out):
    """o*: the goal (gx, gy) with the heading of ``goal_heading``, read from ``ref``."""
    th = ref[2]
    if goal_heading == BEARING:
        th = math.atan2(gy - ref[1], gx - ref[0])
    goal = np.empty(3)
    goal[0] = gx
    goal[1] = gy
    goal[2] = th
    observe(mode, ref, goal, origin, scale, hscale, out)


@njit(cache=True)
def walk_start(key, w, lo, hi, out):
    """Walk w's start pose: uniform over the positions the robot fits, uniform heading."""
    base = np.uint64(3) * np.uint64(w)
    out[0] = lo + (hi - lo) * uniform(key, base)
    out[1] = lo + (hi - lo) * uniform(key, base + np.uint64(1))
    out[2] = -math.pi + 2.0 * math.pi * uniform(key, base + np.uint64(2))


@njit(cache=True)
def explore_action(mask, count, key, counter):
    """A uniformly random available action (counter-based draw); -1 if none is."""
    if count == 0:
        return -1
    r = int(uniform(key, counter) * count)
    return nth_available(mask, min(r, count - 1))


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


# training -----------------------------------------------------------------------------
@njit(cache=True)
def train_kinematic(q, k, v, defer, twists, dt, n_sub, lo, hi, mode, origin, scale, hscale,
                    w0, w1, steps, lr_q, lr_k, lr_v, seed, errors, o_sq):
    """Walks w0..w1-1 on the kinematic robot, all compiled (the twin of
    :func:`train_driven` with the reference learner)."""
    start_key = stream_key(seed, STREAM_ROBOT_START)
    key = stream_key(seed, STREAM_ROBOT_EXPLORE)
    n_i = q[0].shape[1]
    pose = np.zeros(3)
    new = np.zeros(3)
    work = np.zeros(3)
    o_t = np.zeros(n_i)
    o_1 = np.zeros(n_i)
    buf = learn_buffers(q[0].shape[0], n_i, k[0].shape[0])
    mask = np.zeros(N_ROBOT_ACTIONS, np.uint8)
    nopath = np.zeros((0, 3))
    for w in range(w0, w1):
        walk_start(start_key, w, lo, hi, pose)
        total = 0.0
        osum = 0.0
        done = 0
        for t in range(steps):
            count = available_actions(pose, twists, dt, n_sub, lo, hi, mask, work, nopath)
            a = explore_action(mask, count, key, np.uint64(w) * np.uint64(steps) + np.uint64(t))
            if a < 0:
                break
            drive(pose, twists[a, 0], twists[a, 1], dt, n_sub, lo, hi, new, nopath)
            observe(mode, pose, pose, origin, scale, hscale, o_t)
            observe(mode, pose, new, origin, scale, hscale, o_1)
            total += math.sqrt(seam_learn(q, k, v, o_t, o_1, a, lr_q, lr_k, lr_v, defer, buf))
            for i in range(n_i):
                osum += o_1[i] * o_1[i]
            pose[:] = new
            done += 1
        if defer:
            seam_commit(q, k, v)
        errors[w] = total / max(done, 1)
        o_sq[w] = osum / max(done, 1)


def train_driven(cml: CML, sim: RobotSim, settings: RobotCMLSettings, config: RobotTrainConfig,
                 seed: int, w0: int, w1: int, errors: np.ndarray, o_sq: np.ndarray,
                 path: str = "reference") -> None:
    """Walks w0..w1-1 driven from Python, for any simulator: ``reference`` learns through
    the Python array calls (:func:`cml_edge.learning.learn_step`), ``direct`` through the
    compiled :func:`cml_edge.core.step.seam_learn`."""
    defer = schedule_defers(config.schedule)
    rc = sim.config
    c = cml.config
    # keys as uint64: a Python int above 2^63 must not meet an int64 specialisation
    start_key = np.uint64(stream_key(seed, STREAM_ROBOT_START))
    key = np.uint64(stream_key(seed, STREAM_ROBOT_EXPLORE))
    mode, origin, scale, hscale = (settings.mode, settings.origin, settings.scale,
                                   settings.heading_scale)
    o_t = np.zeros(c.n_i)
    o_1 = np.zeros(c.n_i)
    buf = learn_buffers(c.n_s, c.n_i, c.n_a)
    start = np.zeros(3)
    q, k, v = (arr.state for arr in cml.arrays)
    for w in range(w0, w1):
        walk_start(start_key, w, rc.lo, rc.hi, start)
        sim.reset(start)
        pose = sim.pose.copy()
        total = 0.0
        osum = 0.0
        done = 0
        for t in range(config.steps):
            mask = sim.available()
            a = explore_action(mask, int(mask.sum()), key, np.uint64(w * config.steps + t))
            if a < 0:
                break
            new = sim.step(a)
            observe(mode, pose, pose, origin, scale, hscale, o_t)
            observe(mode, pose, new, origin, scale, hscale, o_1)
            if path == "direct":
                total += math.sqrt(seam_learn(q, k, v, o_t, o_1, a, c.lr_q, c.lr_k, c.lr_v,
                                              defer, buf))
            else:
                total += learn_step(cml, o_t, o_1, a, defer)
            for x in o_1:
                osum += float(x) * float(x)
            pose = new
            done += 1
        if path == "direct":
            if defer:
                seam_commit(q, k, v)
        else:
            end_walk(cml, defer)
        errors[w] = total / max(done, 1)
        o_sq[w] = osum / max(done, 1)


def train_robot(cml: CML, sim: RobotSim, settings: RobotCMLSettings, config: RobotTrainConfig,
                seed: int, path: str = "direct",
                on_walk: Callable[[int], None] | None = None) -> dict[str, Any]:
    """Train ``cml`` in place by random walks of the robot (module docstring).

    Returns the mean training error ||e_t|| of each walk and Eq. 3's per-walk gain
    lr_q x steps x mean |o_{t+1}|^2 (largest over the walks).
    """
    if path not in PATHS:
        raise InputError(f"unknown path {path!r}; allowed: {', '.join(PATHS)}")
    if cml.config.n_i != settings.n_i:
        raise InputError(f"the CML takes N_i = {cml.config.n_i} inputs, the {settings.observation}"
                         f" observation has {settings.n_i}")
    if cml.config.n_a != N_ROBOT_ACTIONS:
        raise InputError(f"the CML has {cml.config.n_a} actions, the robot {N_ROBOT_ACTIONS}")
    defer = schedule_defers(config.schedule)
    errors = np.zeros(config.walks)
    o_sq = np.zeros(config.walks)
    c, rc = cml.config, sim.config
    chunk = 10
    for w0 in range(0, config.walks, chunk):
        w1 = min(w0 + chunk, config.walks)
        if path == "direct" and isinstance(sim, KinematicSim):
            q, k, v = (arr.state for arr in cml.arrays)
            train_kinematic(q, k, v, defer, sim.twists, rc.dt, rc.steps_per_action, rc.lo, rc.hi,
                            settings.mode, settings.origin, settings.scale,
                            settings.heading_scale, w0, w1, config.steps, c.lr_q, c.lr_k, c.lr_v,
                            int(seed), errors, o_sq)
        else:
            train_driven(cml, sim, settings, config, seed, w0, w1, errors, o_sq, path)
        if on_walk is not None:
            on_walk(w1)
    return {"train_error": errors, "eq3_gain": float(c.lr_q * config.steps * o_sq.max()),
            "mean_o_sq": float(o_sq.mean())}


# planning -----------------------------------------------------------------------------
@dataclass
class RobotPlanResult:
    """Per trial: final pose, actions taken, reached (within the radius), path length (m,
    along the 32 ms simulation steps), the pose after each action and the actions."""

    final: np.ndarray  # (n, 3)
    steps: np.ndarray  # (n,)
    reached: np.ndarray  # (n,) bool
    length: np.ndarray  # (n,)
    poses: np.ndarray  # (n, max_actions + 1, 3), NaN after the last action
    actions: np.ndarray  # (n, max_actions), -1 after the last action
    paths: list[np.ndarray] | None = None  # per trial, the simulation-step poses


@njit(cache=True)
def plan_kinematic(q, k, v, twists, dt, n_sub, lo, hi, mode, goal_heading, origin, scale, hscale,
                   normalize, starts, goals, max_actions, radius, stop_each_step, final, steps,
                   reached, lengths, poses, actions):
    """Plan every (start, goal) on the kinematic robot, compiled (twin of :func:`plan_driven`)."""
    n_i = q[0].shape[1]
    n_a = k[0].shape[0]
    norms = np.ones(n_a)
    seam_utility_norms(v, normalize, norms)
    buf = plan_buffers(q[0].shape[0], n_a)
    score = np.zeros(n_a)
    pose = np.zeros(3)
    new = np.zeros(3)
    work = np.zeros(3)
    sub = np.zeros((n_sub + 1, 3))
    o = np.zeros(n_i)
    o_star = np.zeros(n_i)
    dgo = np.zeros(n_i)
    mask = np.zeros(N_ROBOT_ACTIONS, np.uint8)
    nopath = np.zeros((0, 3))
    for trial in range(starts.shape[0]):
        pose[:] = starts[trial]
        gx = goals[trial, 0]
        gy = goals[trial, 1]
        poses[trial, 0] = pose
        taken = 0
        length = 0.0
        while taken < max_actions:
            if math.hypot(pose[0] - gx, pose[1] - gy) <= radius:
                break
            count = available_actions(pose, twists, dt, n_sub, lo, hi, mask, work, nopath)
            if count == 0:
                break
            observe(mode, pose, pose, origin, scale, hscale, o)
            observe_goal(mode, goal_heading, pose, gx, gy, origin, scale, hscale, o_star)
            for i in range(n_i):
                dgo[i] = o_star[i] - o[i]
            seam_scores(q, k, v, o, dgo, norms, score, buf)
            a = wta(score, mask)
            drive(pose, twists[a, 0], twists[a, 1], dt, n_sub, lo, hi, new, sub)
            end = first_within(sub, gx, gy, radius) if stop_each_step else -1
            if end >= 0:  # the simulation halts inside the goal circle, mid-action
                length += polyline_length(sub[: end + 1])
                new[0] = sub[end, 0]
                new[1] = sub[end, 1]
                new[2] = wrap_angle(sub[end, 2])
            else:
                length += polyline_length(sub)
            pose[:] = new
            actions[trial, taken] = a
            taken += 1
            poses[trial, taken] = pose
        final[trial] = pose
        steps[trial] = taken
        reached[trial] = math.hypot(pose[0] - gx, pose[1] - gy) <= radius
        lengths[trial] = length


def plan_driven(cml: CML, sim: RobotSim, settings: RobotCMLSettings, starts: np.ndarray,
                goals: np.ndarray, max_actions: int, radius: float, res: RobotPlanResult,
                path: str = "reference", keep_paths: bool = False,
                stop_each_step: bool = False) -> None:
    """Plan from Python, for any simulator: ``reference`` reads the arrays through the
    CML's Python methods, ``direct`` through the compiled
    :func:`cml_edge.core.step.seam_scores`."""
    c = cml.config
    q, k, v = (arr.state for arr in cml.arrays)
    mode, code = settings.mode, settings.goal_code
    origin, scale, hscale = settings.origin, settings.scale, settings.heading_scale
    if path == "direct":
        norms = np.ones(c.n_a)
        seam_utility_norms(v, c.utility == "normalized", norms)
        buf = plan_buffers(c.n_s, c.n_a)
        score = np.zeros(c.n_a)
    else:
        norms = cml.utility_norms()
    o = np.zeros(c.n_i)
    o_star = np.zeros(c.n_i)
    sub = np.zeros((sim.config.steps_per_action + 1, 3))
    if keep_paths:
        res.paths = []
    for trial in range(len(starts)):
        sim.reset(starts[trial])
        pose = sim.pose.copy()
        gx, gy = float(goals[trial, 0]), float(goals[trial, 1])
        res.poses[trial, 0] = pose
        trail = [pose[None].copy()]
        taken = 0
        length = 0.0
        while taken < max_actions:
            if math.hypot(pose[0] - gx, pose[1] - gy) <= radius:
                break
            mask = sim.available()
            if not mask.any():
                break
            observe(mode, pose, pose, origin, scale, hscale, o)
            observe_goal(mode, code, pose, gx, gy, origin, scale, hscale, o_star)
            dgo = o_star - o
            if path == "direct":
                seam_scores(q, k, v, o, dgo, norms, score, buf)
                a = wta(score, mask)
            else:
                u = cml.utility(cml.W_q.matvec(dgo), norms)  # W_v^T (s* - s), normalised
                score = u * cml.affordance(cml.embed(o))
                a = int(np.argmax(np.where(mask == 1, score, -np.inf)))
            pose = sim.step(a, sub)
            end = first_within(sub, gx, gy, radius) if stop_each_step else -1
            if end >= 0:  # the simulation halts inside the goal circle, mid-action
                length += polyline_length(sub[: end + 1])
                pose = sub[end].copy()
                pose[2] = wrap_angle(pose[2])
            else:
                length += polyline_length(sub)
            if keep_paths:
                trail.append(sub[1: (end + 1 if end >= 0 else None)].copy())
            res.actions[trial, taken] = a
            taken += 1
            res.poses[trial, taken] = pose
        res.final[trial] = pose
        res.steps[trial] = taken
        res.reached[trial] = math.hypot(pose[0] - gx, pose[1] - gy) <= radius
        res.length[trial] = length
        if keep_paths:
            res.paths.append(np.concatenate(trail))


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
    each = stop == "step"
    n = len(starts)
    res = RobotPlanResult(np.zeros((n, 3)), np.zeros(n, np.int64), np.zeros(n, bool),
                          np.zeros(n), np.full((n, max_actions + 1, 3), np.nan),
                          np.full((n, max_actions), -1, np.int64))
    if path == "direct" and isinstance(sim, KinematicSim):
        rc = sim.config
        q, k, v = (arr.state for arr in cml.arrays)
        plan_kinematic(q, k, v, sim.twists, rc.dt, rc.steps_per_action, rc.lo, rc.hi,
                       settings.mode, settings.goal_code, settings.origin, settings.scale,
                       settings.heading_scale, cml.config.utility == "normalized", starts, goals,
                       int(max_actions), float(radius), each, res.final, res.steps, res.reached,
                       res.length, res.poses, res.actions)
        if keep_paths:
            res.paths = [kinematic_trail(sim, res.poses[i], res.actions[i], goals[i], radius, each)
                         for i in range(n)]
    else:
        plan_driven(cml, sim, settings, starts, goals, int(max_actions), float(radius), res,
                    path, keep_paths, each)
    return res


def kinematic_trail(sim: KinematicSim, poses: np.ndarray, actions: np.ndarray, goal: np.ndarray,
                    radius: float, stop_each_step: bool) -> np.ndarray:
    """The simulation-step poses of a kinematic run, re-driven from its actions."""
    rc = sim.config
    out = [poses[None, 0]]
    sub = np.zeros((rc.steps_per_action + 1, 3))
    new = np.zeros(3)
    for i, a in enumerate(actions):
        if a < 0:
            break
        drive(poses[i], sim.twists[a, 0], sim.twists[a, 1], rc.dt, rc.steps_per_action, rc.lo,
              rc.hi, new, sub)
        end = first_within(sub, goal[0], goal[1], radius) if stop_each_step else -1
        out.append(sub[1: (end + 1 if end >= 0 else None)].copy())
    return np.concatenate(out)


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
