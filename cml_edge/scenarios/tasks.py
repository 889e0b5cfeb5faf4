"""The sweep tasks of the scenarios: one trained model (a run of a scenario, one seed) and
its parts (:mod:`cml_edge.scenarios.registry`), measured against the float64 twin.

Both tasks run on the direct compiled path (the arrays count every operation there, as
in ``cml-edge emulate``) and return JSON: per part, the per-trial outcomes (pooled over
seeds by the runner), the summary, and the fidelity record of
:mod:`cml_edge.core.fidelity`. Both take a ``chip``: the chip seed of the arrays' device
streams (:mod:`cml_edge.grid.chips`; None: the model seed's chip). The float64 twin is
the model seed's whatever the chip (a float64 array draws nothing), as in ``cml-edge
emulate --chips``.

Grid parts (:func:`grid_task`): each part plans a copy of the trained model after
``idle_s + age_s`` seconds idle from the end of training (``elapse`` on each array: the
ages are cumulative from programming, each from the just-trained state, not one after
another). A part with ``relearn_walks`` K > 0 evaluates the model after K walks of
in-situ relearning (schedule step, walks ``walks`` .. ``walks + K - 1`` of the seed's
streams, :func:`cml_edge.grid.training.train`'s ``first_walk``) on the aged copy; the
parts of one age share it, relearning cumulatively in increasing K, and the twin is
trained on the same extra walks. Its ``relearn`` record holds what the relearning cost
the arrays: the counters' difference, pulses, cells written and energy
(:func:`cml_edge.costs.ledger.energy_pj`).
"""

from __future__ import annotations

import copy
from typing import Any

import numpy as np

from cml_edge.core.cml import CML, CMLConfig
from cml_edge.costs.ledger import cost_model, energy_pj, technology
from cml_edge.experiments.common import _eval_setting
from cml_edge.grid.arena import GridArena
from cml_edge.grid.evaluation import Evaluation, Training, train_seed
from cml_edge.grid.fidelity import float_twin, seed_fidelity
from cml_edge.grid.metrics import summarize
from cml_edge.grid.training import TrainConfig, train

PATH = "direct"
RELEARN_SCHEDULE = "step"
WRITE_COUNTERS = ("devices_written", "cells_changed")
"""The counter of cells written: a crossbar's devices, a digital array's cells."""


def relearn_cost(cml: CML, before: dict[str, int], after: dict[str, int]) -> dict[str, Any]:
    """What the arrays did between two counter readings: the difference, the write pulses
    (the pulse counters of the device's cost model), the cells written and the energy (uJ;
    None where the technology is not costed)."""
    diff = {k: after[k] - before.get(k, 0) for k in after}
    model = cost_model(cml)
    pulses = sum(diff.get(k, 0) for k in model.pulse_counters)
    writes = next((diff[k] for k in WRITE_COUNTERS if k in diff), 0)
    pj, _ = energy_pj(model, diff)
    return {"counters": diff, "pulses": int(pulses), "writes": int(writes),
            "energy_uJ": None if pj is None else pj * 1e-6, "technology": model.name}


def _trial_record(ev: Evaluation, res: Any) -> dict[str, Any]:
    pairs = ev.pairs
    return {"final": res.final.tolist(), "steps": res.steps.tolist(),
            "starts": pairs.starts.tolist(), "goals": pairs.goals.tolist(),
            "chebyshev": pairs.chebyshev.tolist(), "geodesic": pairs.geodesic.tolist()}


def _measure(seed: int, cml: CML, twin: CML, spec: dict[str, Any], arena: int
             ) -> dict[str, Any]:
    ev_arena, pairs, budget = _eval_setting(spec, arena)
    ev = Evaluation(ev_arena, pairs, budget, spec["planner"])
    res = ev.plan(cml, PATH)
    return {**spec, "max_steps": budget, "eval_arena": ev_arena.size,
            **summarize(res.final, res.steps, pairs), **_trial_record(ev, res),
            **seed_fidelity(seed, cml, twin, ev_arena, pairs.goals, res, spec["planner"],
                            budget)}


def grid_task(seed: int, backend: str, backend_options: dict[str, Any], arena: int,
              walks: int, steps: int, schedule: str, parts: list[dict[str, Any]],
              idle_s: float = 0.0, chip: int | None = None) -> dict[str, Any]:
    """Train model ``seed`` on the empty ``arena`` and measure each part (module
    docstring); ``chip``: on the chip of that chip seed (None: of the model seed)."""
    config = TrainConfig(walks, steps, "random", schedule)
    cml_config = CMLConfig.for_arena(arena)
    train_arena = GridArena.empty(arena)
    run = train_seed(seed, Training(train_arena, config, cml_config, backend,
                                    backend_options, PATH, chip=chip))
    twin = float_twin(seed, train_arena, config, cml_config)
    out = []
    # age -> (relearning model, its twin, walks relearnt, the counters before relearning)
    by_age: dict[float, tuple[CML, CML, int, dict[str, int]]] = {}
    for spec in sorted(parts, key=lambda p: (p["age_s"], p["relearn_walks"])):
        age, k = float(spec["age_s"]), int(spec["relearn_walks"])
        if age not in by_age:
            aged = copy.deepcopy(run.cml)
            for arr in aged.arrays:
                arr.elapse(idle_s + age)
            by_age[age] = (aged, copy.deepcopy(twin), 0, aged.counters())
        model, model_twin, done, base = by_age[age]
        record: dict[str, Any] = {}
        if k > done:
            more = TrainConfig(k - done, steps, "random", RELEARN_SCHEDULE)
            train(model, train_arena, more, seed, path=PATH, epoch=k - done,
                  first_walk=walks + done)
            float_twin(seed, train_arena, more, cml_config, first_walk=walks + done,
                       twin=model_twin)
            by_age[age] = (model, model_twin, k, base)
        if k > 0:  # all K walks, from the aged model
            record["relearn"] = relearn_cost(model, base, model.counters())
        out.append({**_measure(seed, copy.deepcopy(model), model_twin, spec, arena), **record})
    order = {p["name"]: i for i, p in enumerate(parts)}
    out.sort(key=lambda r: order[r["name"]])
    return {"seed": int(seed), "backend": backend, "path": PATH,
            "train_error": run.train_error.tolist(), "train_counters": run.train_counters,
            "technology": technology(run.cml), "parts": out}


def robot_task(seed: int, backend: str, backend_options: dict[str, Any], walks: int,
               steps: int, trials: int, eval_seed: int, idle_s: float = 0.0,
               chip: int | None = None) -> dict[str, Any]:
    """Train robot model ``seed`` on the kinematic simulator (the defaults of ``cml-edge
    robot train``) on the chip of chip seed ``chip`` (None: of the model seed), let
    ``idle_s`` pass, drive to ``trials`` goals from the base."""
    from cml_edge.robot.fidelity import robot_seed_fidelity, robot_twin
    from cml_edge.robot.observation import RobotCMLSettings
    from cml_edge.robot.planning import BASE_POSE, draw_goals, plan_robot, summarize_robot
    from cml_edge.robot.sim import RobotConfig, make_sim
    from cml_edge.robot.training import RobotTrainConfig, train_robot

    settings, robot = RobotCMLSettings(), RobotConfig()
    sim = make_sim("kinematic", robot)
    config = RobotTrainConfig(walks, steps)
    cml = CML.create(settings.cml_config(), backend, seed, chip, **backend_options)
    info = train_robot(cml, sim, settings, config, seed, path=PATH)
    train_counters = cml.counters()
    for arr in cml.arrays:
        arr.elapse(idle_s)
    goals = draw_goals(robot, trials, eval_seed)
    starts = np.tile(np.asarray(BASE_POSE, dtype=np.float64), (trials, 1))
    res = plan_robot(cml, sim, settings, starts, goals, path=PATH)
    twin = robot_twin(seed, sim, settings, config, settings.cml_config())
    summary = summarize_robot(res, starts, goals)
    part = {"name": "robot", "trials": trials, "eval_seed": eval_seed, **summary,
            "overhead_mean": summary["path_ratio"],
            "reached": res.reached.tolist(), "length": res.length.tolist(),
            "steps": res.steps.tolist(), "final": res.final.tolist(),
            "starts": starts.tolist(), "goals": goals.tolist(),
            **robot_seed_fidelity(seed, cml, twin, sim, settings, goals, res)}
    return {"seed": int(seed), "backend": backend, "path": PATH,
            "train_error": info["train_error"].tolist(), "train_counters": train_counters,
            "technology": technology(cml), "parts": [part]}
