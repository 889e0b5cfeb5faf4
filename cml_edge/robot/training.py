"""Training the CML on the robot: random walks with the local rule, one loop for every path.

Each walk starts at a uniformly random pose (position anywhere the robot fits, heading
uniform); each step takes a uniformly random *available* action (an action whose arc
would leave the arena is never drawn, as on the grid) and runs the local rule (Eqs. 1-3)
on the observations before and after it (:mod:`cml_edge.robot.observation`).

:func:`train_loop` states this once. The learner (:mod:`cml_edge.core.step`) and the
simulator (:mod:`cml_edge.robot.sim`) are plug-ins routed by type: compiled with the seam
learner and the kinematic simulator (``direct``), or as the loop's plain-Python
``py_func`` with the reference learner (``reference``, bit-identical) or the MuJoCo
simulator (either learner; physics-bound).

Randomness: walk starts on stream ``STREAM_ROBOT_START`` (counters 3w .. 3w + 2),
exploration on ``STREAM_ROBOT_EXPLORE`` (counter w x steps + t) (:mod:`cml_edge.protocol`).
The streams, the sizes (pose, actions) and the walk starts are the simulator's
(:class:`~cml_edge.robot.sim.RobotSim`), the observation the frame's, so the same loop
trains the drone (:mod:`cml_edge.drone`) on its own streams.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numba import njit

from cml_edge.core.cml import CML
from cml_edge.core.finite import check_weights
from cml_edge.core.learning import ReferenceLearner, check_walks, schedule_defers
from cml_edge.core.step import SeamLearner, begin_walk, end_walk, learn
from cml_edge.engine.stop import chunks
from cml_edge.errors import InputError
from cml_edge.jit.kernel import kernel
from cml_edge.jit.rng import stream_key, uniform
from cml_edge.robot.observation import RobotCMLSettings, observe
from cml_edge.robot.sim import (
    N_ROBOT_ACTIONS,
    RobotSim,
    nth_available,
    set_pose,
    sim_available,
    sim_reset,
    sim_step,
    sim_walk_start,
)

PATHS = ("direct", "reference")

EPOCH = 10
"""``on_walk`` is called every EPOCH walks and at the end."""


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


@njit(cache=True)
def explore_action(mask, count, key, counter):
    """A uniformly random available action (counter-based draw); -1 if none is."""
    if count == 0:
        return -1
    r = int(uniform(key, counter) * count)
    return nth_available(mask, min(r, count - 1))


def walk_work(n_i: int, pose_size: int = 3, n_actions: int = N_ROBOT_ACTIONS) -> tuple:
    """The training loop's work arrays: the start pose, the pose and the next one
    (``pose_size``), o_t and o_{t+1} (``n_i``), the available actions (``n_actions``), and
    an empty path (no trail kept)."""
    return (np.zeros(pose_size), np.zeros(pose_size), np.zeros(pose_size), np.zeros(n_i),
            np.zeros(n_i), np.zeros(n_actions, np.uint8), np.zeros((0, pose_size)))


@kernel
def train_loop(learner, sim, frame, keys, w0, w1, steps, errors, o_sq, work):
    """Walks w0..w1-1 (the module docstring): the mean training error of each walk in
    ``errors`` and its mean |o_{t+1}|^2 in ``o_sq``; ``work`` from :func:`walk_work`. A
    :func:`~cml_edge.jit.kernel.kernel`: no step pays reference counts. The vehicle is
    the simulator's and its observation the frame's (routed by type: the robot's, the
    drone's, :mod:`cml_edge.drone`)."""
    start, pose, new, o_t, o_1, mask, nopath = work
    n_i = o_t.shape[0]
    for w in range(w0, w1):
        sim_walk_start(sim, keys[0], w, start)
        sim_reset(sim, start, pose)
        begin_walk(learner)
        total = 0.0
        osum = 0.0
        done = 0
        for t in range(steps):
            count = sim_available(sim, pose, mask)
            a = explore_action(mask, count, keys[1], np.uint64(w) * np.uint64(steps)
                               + np.uint64(t))
            if a < 0:
                break
            sim_step(sim, pose, a, new, nopath)
            observe(frame, pose, pose, o_t)
            observe(frame, pose, new, o_1)
            total += learn(learner, o_t, o_1, a)
            for i in range(n_i):
                osum += o_1[i] * o_1[i]
            set_pose(pose, new)
            done += 1
        total += end_walk(learner)
        errors[w] = total / max(done, 1)
        o_sq[w] = osum / max(done, 1)


def train_robot(cml: CML, sim: RobotSim, settings: RobotCMLSettings, config: RobotTrainConfig,
                seed: int, path: str = "direct",
                on_walk: Callable[[int], None] | None = None) -> dict[str, Any]:
    """Train ``cml`` in place by random walks of the robot (module docstring).

    Returns the mean training error ||e_t|| of each walk and Eq. 3's per-walk gain
    lr_q x steps x mean |o_{t+1}|^2 (largest over the walks). Weights that end NaN or
    infinite raise :class:`~cml_edge.core.finite.NonFiniteError` (a failed run).
    """
    if path not in PATHS:
        raise InputError(f"unknown path {path!r}; allowed: {', '.join(PATHS)}")
    if cml.config.n_i != settings.n_i:
        raise InputError(f"the CML takes N_i = {cml.config.n_i} inputs, the "
                         f"{settings.observation} observation has {settings.n_i}")
    if cml.config.n_a != sim.n_actions:
        raise InputError(f"the CML has {cml.config.n_a} actions, the {sim.world} "
                         f"{sim.n_actions}")
    defer = schedule_defers(config.schedule)
    learner = ReferenceLearner(cml, defer) if path == "reference" else SeamLearner.of(cml, defer)
    compiled = path == "direct" and sim.compiled
    loop = train_loop if compiled else train_loop.py_func
    start_stream, explore_stream = sim.streams[:2]
    keys = np.array([stream_key(seed, start_stream), stream_key(seed, explore_stream)],
                    dtype=np.uint64)
    errors = np.zeros(config.walks)
    o_sq = np.zeros(config.walks)
    work = walk_work(settings.n_i, sim.pose_size, sim.n_actions)
    for e0 in range(0, config.walks, EPOCH):
        e1 = min(e0 + EPOCH, config.walks)
        for w0, w1 in chunks(e0, e1, config.steps):
            loop(learner, sim.plugin, settings.frame(), keys, w0, w1, config.steps, errors,
                 o_sq, work)
        if on_walk is not None:
            on_walk(e1)
    check_weights(cml, "training", seed)
    return {"train_error": errors, "eq3_gain": float(cml.config.lr_q * config.steps * o_sq.max()),
            "mean_o_sq": float(o_sq.mean())}
