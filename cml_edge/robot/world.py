"""The wheeled robot as a world of the scenarios (:class:`cml_edge.core.world.World`).

The defaults of ``cml-edge robot train``: the kinematic simulator
(:mod:`cml_edge.robot.sim`), the heading observation and raw utility
(:class:`~cml_edge.robot.observation.RobotCMLSettings`). A run (``run``: ``walks``,
``steps``) trains by random walks with per-walk updates
(:func:`cml_edge.robot.training.train_robot`); the twin is
:func:`cml_edge.robot.fidelity.robot_twin`. A part drives from the base pose to ``trials``
goals drawn from ``eval_seed`` (:func:`cml_edge.robot.planning.draw_goals`); its record is
:func:`cml_edge.robot.planning.summarize_robot` with ``overhead_mean``, the driven path
over the straight distance (``path_ratio``), the per-trial outcomes and
:func:`cml_edge.robot.fidelity.robot_seed_fidelity`. The robot does not relearn in situ.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from types import SimpleNamespace
from typing import Any, NamedTuple

import numpy as np

from cml_edge.core.cml import CML
from cml_edge.core.world import PATH, Trained
from cml_edge.errors import InputError
from cml_edge.robot.fidelity import robot_seed_fidelity, robot_twin
from cml_edge.robot.observation import RobotCMLSettings
from cml_edge.robot.planning import (
    BASE_POSE,
    RobotPlanResult,
    draw_goals,
    plan_robot,
    summarize_robot,
)
from cml_edge.robot.sim import RobotConfig, RobotSim, make_sim
from cml_edge.robot.training import RobotTrainConfig, train_robot


class RobotPlan(NamedTuple):
    """What :meth:`RobotWorld.plan` drove: the start poses, the goals and the result."""

    starts: np.ndarray
    goals: np.ndarray
    result: RobotPlanResult


def _setting() -> tuple[RobotSim, RobotCMLSettings]:
    """The simulator and the CML's observation settings of every robot run."""
    return make_sim("kinematic", RobotConfig()), RobotCMLSettings()


class RobotWorld:
    """The robot world (module docstring). The drone's world
    (:class:`cml_edge.drone.world.DroneWorld`) is this one with its own setting, goals
    and start."""

    name = "robot"

    def setting(self) -> tuple[RobotSim, Any]:
        """The simulator and the CML's observation settings of every run."""
        return _setting()

    def problems(self, sim: RobotSim, trials: int, eval_seed: int
                 ) -> tuple[np.ndarray, np.ndarray]:
        """(start poses, goals) of a part's ``trials`` from ``eval_seed``."""
        goals = draw_goals(sim.config, trials, eval_seed)
        return np.tile(np.asarray(BASE_POSE, dtype=np.float64), (trials, 1)), goals

    def train(self, seed: int, run: Mapping[str, Any], backend: str,
              backend_options: Mapping[str, Any], chip: int | None) -> Trained:
        sim, settings = self.setting()
        cml = CML.create(settings.cml_config(), backend, seed, chip, **backend_options)
        info = train_robot(cml, sim, settings, RobotTrainConfig(run["walks"], run["steps"]),
                           seed, path=PATH)
        return Trained(cml, info["train_error"])

    def twin(self, seed: int, run: Mapping[str, Any]) -> CML:
        sim, settings = self.setting()
        return robot_twin(seed, sim, settings, RobotTrainConfig(run["walks"], run["steps"]),
                          settings.cml_config())

    def relearn(self, cml: CML, twin: CML, seed: int, run: Mapping[str, Any], walks: int,
                done: int) -> None:
        raise InputError(f"the {self.name} does not relearn in situ (relearn_walks {done + walks}; "
                         f"allowed: 0)")

    def plan(self, cml: CML, part: Mapping[str, Any], run: Mapping[str, Any]) -> RobotPlan:
        sim, settings = self.setting()
        starts, goals = self.problems(sim, part["trials"], part["eval_seed"])
        return RobotPlan(starts, goals, plan_robot(cml, sim, settings, starts, goals,
                                                   path=PATH))

    def summarise(self, seed: int, cml: CML, twin: CML, part: Mapping[str, Any],
                  planned: RobotPlan) -> dict[str, Any]:
        sim, settings = self.setting()
        starts, goals, res = planned
        summary = summarize_robot(res, starts, goals)
        return {"name": part["name"], "trials": part["trials"], "eval_seed": part["eval_seed"],
                **summary, "overhead_mean": summary["path_ratio"],
                "reached": res.reached.tolist(), "length": res.length.tolist(),
                "steps": res.steps.tolist(), "final": res.final.tolist(),
                "starts": starts.tolist(), "goals": goals.tolist(),
                **robot_seed_fidelity(seed, cml, twin, sim, settings, goals, res)}

    def pool(self, records: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
        cat = {k: np.concatenate([np.asarray(r[k], float) for r in records])
               for k in ("final", "length", "starts", "goals")}
        res = SimpleNamespace(final=cat["final"], length=cat["length"],
                              reached=np.concatenate([np.asarray(r["reached"], bool)
                                                      for r in records]),
                              steps=np.concatenate([np.asarray(r["steps"]) for r in records]))
        summary = summarize_robot(res, cat["starts"], cat["goals"])
        return {**summary, "overhead_mean": summary["path_ratio"]}


ROBOT = RobotWorld()
