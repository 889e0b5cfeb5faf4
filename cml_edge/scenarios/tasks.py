"""The sweep task of the scenarios: one trained model (a run of a scenario, one seed) and
its parts (:mod:`cml_edge.scenarios.registry`), measured against the float64 twin.

:func:`scenario_task` runs any world through its :class:`~cml_edge.core.world.World`
(the grid, the robot) on the direct compiled path (the arrays count every operation
there, as in ``cml-edge emulate``) and returns JSON: per part, the world's record (the
per-trial outcomes, pooled over seeds by the runner, the summary, and the fidelity record
of :mod:`cml_edge.core.fidelity`). It takes a ``chip``: the chip seed of the arrays'
device streams (:mod:`cml_edge.grid.chips`; None: the model seed's chip). The float64 twin
is the model seed's whatever the chip (a float64 array draws nothing), as in ``cml-edge
emulate --chips``.

Each part plans a copy of the trained model after ``idle_s + age_s`` seconds idle from
the end of training (``elapse`` on each array: the ages are cumulative from programming,
each from the just-trained state, not one after another). A part with ``relearn_walks``
K > 0 evaluates the model after K walks of in-situ relearning
(:meth:`~cml_edge.core.world.World.relearn`) on the aged copy; the parts of one age share
it, relearning cumulatively in increasing K, and the twin relearns the same walks. Its
``relearn`` record holds what the relearning cost the arrays: the counters' difference,
pulses, cells written and energy (:func:`cml_edge.costs.ledger.energy_pj`).
"""

from __future__ import annotations

import copy
from typing import Any

from cml_edge.core.cml import CML
from cml_edge.core.finite import check_weights
from cml_edge.core.world import PATH, get_world
from cml_edge.costs.ledger import cost_model, energy_pj, technology
from cml_edge.engine.timings import stage

TASK_FN = "cml_edge.scenarios.tasks:scenario_task"
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


def scenario_task(world: str, seed: int, backend: str, backend_options: dict[str, Any],
                  run: dict[str, Any], parts: list[dict[str, Any]], idle_s: float = 0.0,
                  chip: int | None = None) -> dict[str, Any]:
    """Train model ``seed`` in ``world`` (a name of :data:`~cml_edge.core.world.WORLDS`)
    as ``run`` says and measure each of ``parts`` (module docstring); ``chip``: on the
    chip of that chip seed (None: of the model seed)."""
    w = get_world(world)
    with stage("train"):
        cml, train_error = w.train(seed, run, backend, backend_options, chip)
    train_counters = cml.counters()
    with stage("twin"):
        twin = w.twin(seed, run)
    out = []
    # age -> (relearning model, its twin, walks relearnt, the counters before relearning)
    by_age: dict[float, tuple[CML, CML, int, dict[str, int]]] = {}
    for part in sorted(parts, key=lambda p: (p["age_s"], p["relearn_walks"])):
        age, k = float(part["age_s"]), int(part["relearn_walks"])
        if age not in by_age:
            aged = copy.deepcopy(cml)
            for arr in aged.arrays:
                arr.elapse(idle_s + age)
            check_weights(aged, "drift", seed)
            by_age[age] = (aged, copy.deepcopy(twin), 0, aged.counters())
        model, model_twin, done, base = by_age[age]
        record: dict[str, Any] = {}
        if k > done:
            with stage("relearn"):
                w.relearn(model, model_twin, seed, run, k - done, done)
            by_age[age] = (model, model_twin, k, base)
        if k > 0:  # all K walks, from the aged model
            record["relearn"] = relearn_cost(model, base, model.counters())
        evaluated = copy.deepcopy(model)  # the part's reads leave the shared model as it is
        with stage("evaluate"):
            planned = w.plan(evaluated, part, run)
        with stage("replay"):  # the part's record: its fidelity replays the plans
            out.append({**w.summarise(seed, evaluated, model_twin, part, planned), **record})
    order = {p["name"]: i for i, p in enumerate(parts)}
    out.sort(key=lambda r: order[r["name"]])
    return {"seed": int(seed), "backend": backend, "path": PATH,
            "train_error": train_error.tolist(), "train_counters": train_counters,
            "technology": technology(cml), "parts": out}
