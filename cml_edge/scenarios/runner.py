"""Run a scenario on a device through the sweep engine, and pool its seeds.

:func:`run_scenario` makes one :class:`~cml_edge.sweep.Task` per (run x seed) of the
scenario (:mod:`cml_edge.scenarios.registry`; task key ``RUN-sSEED``), runs them with
:func:`cml_edge.sweep.run_sweep` (in-process, a local pool or Dask; each result written
atomically to ``OUT/tasks/``, a rerun into the same ``out`` resumes) and pools each part
over the seeds:

- ``success_rate``, ``overhead_mean`` and the rest of
  :func:`cml_edge.grid.metrics.summarize` over all seeds x trials (the robot:
  :func:`cml_edge.robot.planning.summarize_robot`, ``overhead_mean`` its path ratio), and
  ``success_rate_seeds`` / ``overhead_mean_seeds``, the per-seed values' mean and spread;
- ``weight_error``, ``decision_agreement``, ``read_snr``: seed means and spreads
  (:func:`cml_edge.core.fidelity.pool_seeds`);
- for relearning parts, ``pulses``, ``writes`` and ``energy_uJ`` (seed means and
  spreads) of the relearning walks.

The recovery scenario adds ``dqn_retrain`` (:mod:`cml_edge.scenarios.dqn_cost`).
"""

from __future__ import annotations

import json
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np

from cml_edge import __version__
from cml_edge.backends import backend_spec
from cml_edge.core.cml import CML
from cml_edge.core.fidelity import TWIN, pool_seeds, seed_stats
from cml_edge.errors import InputError
from cml_edge.experiments.common import pool
from cml_edge.scenarios.registry import BUDGETS, get
from cml_edge.storage import atomic_write_text
from cml_edge.sweep import Task, run_sweep

TASK_FNS = {"grid": "cml_edge.scenarios.tasks:grid_task",
            "robot": "cml_edge.scenarios.tasks:robot_task"}
GRID_KEYS = ("success_rate", "success_rate_connected", "overhead_mean", "overhead_median",
             "overhead_geodesic_mean", "e_pos_mean", "e_pos_median", "connected_pairs",
             "trials")
PART_KEYS = ("size", "obstacles", "map", "scen", "planner", "max_steps", "eval_arena",
             "age_s", "relearn_walks")


def scenario_tasks(name: str, backend: str, options: dict[str, Any], seeds: int,
                   budget: str = "full", idle_s: float = 0.0) -> list[Task]:
    """The (run x seed) tasks of scenario ``name`` on the device (checked here)."""
    scenario = get(name)
    if budget not in BUDGETS:
        raise InputError(f"unknown budget {budget!r}; allowed: {', '.join(BUDGETS)}")
    if isinstance(seeds, bool) or int(seeds) != seeds or seeds < 1:
        raise InputError(f"seeds {seeds!r} is not an integer >= 1")
    backend_spec(backend)
    CML.create(backend=backend, **options)  # a bad option fails now, before any task
    base = {"backend": backend, "backend_options": dict(options)}
    if idle_s:
        base["idle_s"] = float(idle_s)
    return [Task(f"{run}-s{seed}", TASK_FNS[scenario.world], {**base, **params, "seed": seed})
            for run, params in scenario.runs(BUDGETS[budget]) for seed in range(int(seeds))]


def _pool_trials(world: str, records: list[dict[str, Any]]) -> dict[str, Any]:
    if world == "grid":
        pooled = pool(records)
        return {k: pooled[k] for k in GRID_KEYS}
    from cml_edge.robot.planning import summarize_robot

    cat = {k: np.concatenate([np.asarray(r[k], float) for r in records])
           for k in ("final", "length", "starts", "goals")}
    res = SimpleNamespace(final=cat["final"], length=cat["length"],
                          reached=np.concatenate([np.asarray(r["reached"], bool)
                                                  for r in records]),
                          steps=np.concatenate([np.asarray(r["steps"]) for r in records]))
    summary = summarize_robot(res, cat["starts"], cat["goals"])
    return {**summary, "overhead_mean": summary["path_ratio"]}


def _spread(values: list[Any]) -> dict[str, Any]:
    """Seed mean and spread of values where a seed may have none (no success: no
    overhead), over the seeds that have one."""
    return seed_stats([v for v in values if v is not None])


def pool_part(world: str, records: list[dict[str, Any]]) -> dict[str, Any]:
    """One part over its seeds' records (module docstring)."""
    first = records[0]
    out: dict[str, Any] = {"part": first["name"],
                           **{k: first[k] for k in PART_KEYS if k in first},
                           **_pool_trials(world, records),
                           "success_rate_seeds": _spread([r["success_rate"] for r in records]),
                           "overhead_mean_seeds": _spread([r["overhead_mean"]
                                                           for r in records]),
                           **pool_seeds(records),
                           "decisions": int(sum(r["decisions"] for r in records)),
                           "seeds": len(records)}
    if "relearn" in first:
        for key in ("pulses", "writes", "energy_uJ"):
            out[key] = _spread([r["relearn"][key] for r in records])
    elif first.get("relearn_walks") == 0:
        out.update({key: _spread([0]) for key in ("pulses", "writes")})
        out["energy_uJ"] = _spread([0.0])
    out["per_seed"] = [{"seed": None, "success_rate": r["success_rate"],
                        "overhead_mean": r["overhead_mean"],
                        "decision_agreement": r["decision_agreement"],
                        "weight_error": r["weight_error"]["matrix_mean"]} for r in records]
    return out


def run_scenario(name: str, backend: str = "float", options: dict[str, Any] | None = None,
                 seeds: int = 10, budget: str = "full", out: str | Path | None = None,
                 workers: int | None = None, scheduler: str | None = None,
                 progress: Callable[[int, int], None] | None = None, idle_s: float = 0.0,
                 command: str | None = None) -> dict[str, Any]:
    """Run scenario ``name`` on ``backend`` with ``options`` (the device's config fields,
    e.g. ``{"preset": "pcm"}``) for model seeds 0..``seeds``-1 at ``budget`` (a key of
    :data:`~cml_edge.scenarios.registry.BUDGETS`); ``idle_s`` more seconds idle before
    every evaluation (the drift-time knob of ``cml-edge breakpoint``). With ``out``, the
    tasks are kept under ``out/tasks`` (resumable) and the result is written to
    ``out/results.json``; without, they go to a temporary folder. Returns the JSON-ready
    result (module docstring)."""
    options = dict(options or {})
    scenario = get(name)
    tasks = scenario_tasks(name, backend, options, seeds, budget, idle_s)
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="cml-edge-scenario-") as tmp:
        results = run_sweep(tasks, out or tmp, workers=workers, scheduler=scheduler,
                            progress=progress)
    parts: dict[str, list[dict[str, Any]]] = {}
    seeds_of: dict[str, list[int]] = {}
    for res in results.values():
        for rec in res["parts"]:
            parts.setdefault(rec["name"], []).append(rec)
            seeds_of.setdefault(rec["name"], []).append(res["seed"])
    pooled = []
    for part_name, records in parts.items():
        row = pool_part(scenario.world, records)
        for entry, seed in zip(row["per_seed"], seeds_of[part_name]):
            entry["seed"] = seed
        pooled.append(row)
    b = BUDGETS[budget]
    result: dict[str, Any] = {
        "scenario": name, "description": scenario.doc, "world": scenario.world,
        "backend": backend, "backend_options": options, "technology": next(
            iter(results.values()))["technology"],
        "seeds": int(seeds), "seed_list": list(range(int(seeds))), "budget": budget,
        "walks": b.walks, "steps": b.steps, "trials": b.trials, "idle_s": float(idle_s),
        "compute_path": "direct", "fidelity_twin": TWIN, "tasks": len(tasks),
        "parts": pooled}
    if name == "recovery":
        from cml_edge.scenarios.dqn_cost import dqn_retrain_estimate

        result["dqn_retrain"] = dqn_retrain_estimate()
    result.update({"wall_time_s": time.perf_counter() - t0, "command": command,
                   "cml_edge_version": __version__})
    if out is not None:
        atomic_write_text(Path(out) / "results.json", json.dumps(result, indent=1))
        result["out"] = str(out)
    return result
