"""The robot's CML against its float64 twin: weight error, decision agreement, read SNR.

The metrics are defined in :mod:`cml_edge.core.fidelity`. What is the robot's:

- the twin (:func:`robot_twin`): ``CML.create(config, "float", seed)`` trained by
  :func:`cml_edge.robot.training.train_robot` with the same settings, simulator,
  :class:`~cml_edge.robot.training.RobotTrainConfig` and seed (the walks do not read the
  weights, so they are the device's walks), on the direct float64 path;
- decision agreement (:func:`robot_decision_agreement`): at each pose the device decided
  at (the poses :func:`~cml_edge.robot.planning.plan_robot` records after every action),
  the twin scores the actions (the factored scorer) and takes the WTA winner among the
  actions the simulator allows there; counted where it equals the device's action;
- read SNR: the sampled states are ``SNR_SAMPLES`` of those decisions (o and o* - o in
  the robot's frame), from the generator keyed [seed, ``STREAM_FIDELITY``].
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numba import njit

from cml_edge.core.cml import CML, CMLConfig
from cml_edge.core.fidelity import read_snr, sample_indices, weight_error
from cml_edge.core.step import FactoredScorer, prepare, scores, wta
from cml_edge.protocol import STREAM_FIDELITY
from cml_edge.robot.observation import RobotCMLSettings, observe, observe_goal
from cml_edge.robot.planning import RobotPlanResult
from cml_edge.robot.sim import RobotSim, sim_available
from cml_edge.robot.training import RobotTrainConfig, train_robot


def robot_twin(seed: int, sim: RobotSim, settings: RobotCMLSettings, config: RobotTrainConfig,
               cml_config: CMLConfig) -> CML:
    """The float64 twin of the robot model of ``seed`` (module docstring)."""
    twin = CML.create(cml_config, "float", seed)
    train_robot(twin, sim, settings, config, seed, path="direct")
    return twin


@njit(cache=True)
def robot_replay_loop(scorer, sim, frame, normalize, goals, poses, actions, steps, agree, n_i,
                      n_a):
    """Per trial, how many of the device's decisions (``poses``, ``actions``) the scorer's
    WTA among the available actions repeats, in ``agree`` (``n_i`` inputs, ``n_a``
    actions: the robot's or the drone's)."""
    prepare(scorer, normalize, False)
    u = np.zeros(n_a)
    score = np.zeros(n_a)
    o = np.zeros(n_i)
    o_star = np.zeros(n_i)
    dgo = np.zeros(n_i)
    mask = np.zeros(n_a, np.uint8)
    for trial in range(goals.shape[0]):
        same = 0
        for t in range(steps[trial]):
            pose = poses[trial, t]
            sim_available(sim, pose, mask)
            observe(frame, pose, pose, o)
            observe_goal(frame, pose, goals[trial], o_star)
            for i in range(n_i):
                dgo[i] = o_star[i] - o[i]
            scores(scorer, o, dgo, u, score)
            if wta(score, mask) == actions[trial, t]:
                same += 1
        agree[trial] = same


def robot_states(settings: RobotCMLSettings, goals: np.ndarray, result: RobotPlanResult,
                 seed: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """(o, o* - o) of a seeded sample of the poses the device decided at."""
    frame = settings.frame()
    cells = [(trial, t) for trial in range(len(goals)) for t in range(int(result.steps[trial]))]
    out = []
    for i in sample_indices(len(cells), seed, STREAM_FIDELITY):
        trial, t = cells[i]
        pose = np.ascontiguousarray(result.poses[trial, t])
        o, o_star = np.zeros(settings.n_i), np.zeros(settings.n_i)
        observe(frame, pose, pose, o)
        observe_goal(frame, pose, np.ascontiguousarray(goals[trial]), o_star)
        out.append((o, o_star - o))
    return out


def robot_seed_fidelity(seed: int, cml: CML, twin: CML, sim: RobotSim,
                        settings: RobotCMLSettings, goals: np.ndarray,
                        result: RobotPlanResult) -> dict[str, Any]:
    """One robot model's weight error, decision agreement and read SNR (and the counts)."""
    goals = np.ascontiguousarray(goals, dtype=np.float64)
    agree = np.zeros(len(goals), np.int64)
    # a Python simulator (MuJoCo) runs the loop's plain-Python body (cml_edge.jit.routing)
    loop = robot_replay_loop if sim.compiled else robot_replay_loop.py_func
    loop(FactoredScorer.of(twin), sim.plugin, settings.frame(),
         twin.config.utility == "normalized", goals, result.poses, result.actions,
         np.ascontiguousarray(result.steps, dtype=np.int64), agree, settings.n_i,
         sim.n_actions)
    total, same = int(result.steps.sum()), int(agree.sum())
    return {"weight_error": weight_error(cml, twin),
            "decision_agreement": same / total if total else None,
            "decisions": total, "decisions_agreed": same,
            "read_snr": read_snr(cml, robot_states(settings, goals, result, seed))}
