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
"""

from __future__ import annotations

import math
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
from cml_edge.protocol import STREAM_ROBOT_EXPLORE, STREAM_ROBOT_START
from cml_edge.robot.observation import XY, RobotCMLSettings, observe
from cml_edge.robot.sim import (
    N_ROBOT_ACTIONS,
    KinematicSim,
    RobotSim,
    nth_available,
    set_pose,
    sim_available,
    sim_reset,
    sim_step,
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


def walk_work(n_i: int) -> tuple:
    """The training loop's work arrays: the start pose, the pose and the next one, o_t and
    o_{t+1} (``n_i``), the available actions, and an empty path (no trail kept)."""
    return (np.zeros(3), np.zeros(3), np.zeros(3), np.zeros(n_i), np.zeros(n_i),
            np.zeros(N_ROBOT_ACTIONS, np.uint8), np.zeros((0, 3)))


@kernel
def train_loop(learner, sim, frame, keys, lo, hi, w0, w1, steps, errors, o_sq, work):
    """Walks w0..w1-1 (the module docstring): the mean training error of each walk in
    ``errors`` and its mean |o_{t+1}|^2 in ``o_sq``; ``work`` from :func:`walk_work`. A
    :func:`~cml_edge.jit.kernel.kernel`: no step pays reference counts."""
    n_i = 2 if frame.mode == XY else 4
    start, pose, new, o_t, o_1, mask, nopath = work
    for w in range(w0, w1):
        walk_start(keys[0], w, lo, hi, start)
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
    if cml.config.n_a != N_ROBOT_ACTIONS:
        raise InputError(f"the CML has {cml.config.n_a} actions, the robot {N_ROBOT_ACTIONS}")
    defer = schedule_defers(config.schedule)
    learner = ReferenceLearner(cml, defer) if path == "reference" else SeamLearner.of(cml, defer)
    compiled = path == "direct" and isinstance(sim, KinematicSim)
    loop = train_loop if compiled else train_loop.py_func
    keys = np.array([stream_key(seed, STREAM_ROBOT_START), stream_key(seed, STREAM_ROBOT_EXPLORE)],
                    dtype=np.uint64)
    errors = np.zeros(config.walks)
    o_sq = np.zeros(config.walks)
    rc = sim.config
    work = walk_work(settings.n_i)
    for e0 in range(0, config.walks, EPOCH):
        e1 = min(e0 + EPOCH, config.walks)
        for w0, w1 in chunks(e0, e1, config.steps):
            loop(learner, sim.plugin, settings.frame(), keys, rc.lo, rc.hi, w0, w1,
                 config.steps, errors, o_sq, work)
        if on_walk is not None:
            on_walk(e1)
    check_weights(cml, "training", seed)
    return {"train_error": errors, "eq3_gain": float(cml.config.lr_q * config.steps * o_sq.max()),
            "mean_o_sq": float(o_sq.mean())}
