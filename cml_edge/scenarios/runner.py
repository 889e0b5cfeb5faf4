"""Run a scenario on a device through the sweep engine, and pool its seeds.

:func:`run_scenario` makes one :class:`~cml_edge.engine.sweep.Task` per (run x seed) of the
scenario (:mod:`cml_edge.scenarios.registry`; task key ``RUN-sSEED``), runs them with
:func:`cml_edge.engine.sweep.run_sweep` (in-process, a local pool or Dask; each result written
atomically to ``OUT/tasks/``, a rerun into the same ``out`` resumes) and pools each part
over the seeds:

- ``success_rate``, ``overhead_mean`` and the rest of the world's summary over all
  seeds x trials (:meth:`cml_edge.core.world.World.pool`: on the grid
  :func:`cml_edge.grid.metrics.summarize`, on the robot
  :func:`cml_edge.robot.planning.summarize_robot`, ``overhead_mean`` its path ratio), and
  ``success_rate_seeds`` / ``overhead_mean_seeds``, the per-seed values' mean and spread;
- ``weight_error``, ``decision_agreement``, ``read_snr``: seed means and spreads
  (:func:`cml_edge.core.fidelity.pool_seeds`);
- for relearning parts, ``pulses``, ``writes`` and ``energy_uJ`` (seed means and
  spreads) of the relearning walks.

The recovery scenario adds ``dqn_retrain`` (:mod:`cml_edge.costs.dqn`).

**Many chips** (``chips``; :mod:`cml_edge.grid.chips`): every (run x seed) runs
on each chip seed ``first_chip`` .. ``first_chip + chips - 1`` (task key
``RUN-cCHIP-sSEED``, so a rerun resumes, and a run without chips keeps its keys
``RUN-sSEED`` and its JSON). The part's keys above are then pooled over all chips x seeds
(``seeds`` stays the number of model seeds; ``per_seed`` has one entry per chip x seed,
each with its ``chip``), and each part gains ``chips`` (the distribution over chips of
every per-seed metric, each chip's mean over its seeds, by
:func:`cml_edge.grid.chips.pool_chips`), ``yield`` and ``yield_target``; a chip's
success rate is pooled over its seeds' trials.
"""

from __future__ import annotations

import tempfile
import time
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

from cml_edge import __version__
from cml_edge.backends import backend_spec
from cml_edge.core.cml import CML
from cml_edge.core.fidelity import TWIN, pool_seeds, seed_stats
from cml_edge.core.finite import dumps
from cml_edge.core.world import World, get_world
from cml_edge.engine.sweep import Task, run_sweep
from cml_edge.engine.timings import stage
from cml_edge.errors import InputError
from cml_edge.grid.chips import DEFAULT_YIELD_TARGET, check_chips, pool_chips
from cml_edge.io.files import atomic_write_text
from cml_edge.scenarios.registry import BUDGETS, PLANE, get
from cml_edge.scenarios.tasks import TASK_FN

PART_KEYS = ("size", "obstacles", "map", "scen", "planner", "max_steps", "eval_arena",
             "age_s", "relearn_walks")


def scenario_tasks(name: str, backend: str, options: dict[str, Any], seeds: int,
                   budget: str = "full", idle_s: float = 0.0,
                   chips: Sequence[int] | None = None, prefix: str = "",
                   dims: int | None = None, moves: str = "king") -> list[Task]:
    """The (run x seed) tasks of scenario ``name`` on the device (checked here); with
    ``chips`` (chip seeds), the (chip x run x seed) tasks; ``prefix`` starts every key
    (tasks of several scenarios or devices in one run folder); in ``dims`` dimensions
    with the ``moves`` set (None: the scenario's default;
    :meth:`~cml_edge.scenarios.registry.Scenario.runs`)."""
    scenario = get(name)
    scenario.space(dims, moves)
    if budget not in BUDGETS:
        raise InputError(f"unknown budget {budget!r}; allowed: {', '.join(BUDGETS)}")
    if isinstance(seeds, bool) or int(seeds) != seeds or seeds < 1:
        raise InputError(f"seeds {seeds!r} is not an integer >= 1")
    backend_spec(backend)
    CML.create(backend=backend, **options)  # a bad option fails now, before any task
    base = {"world": scenario.world, "backend": backend, "backend_options": dict(options)}
    if idle_s:
        base["idle_s"] = float(idle_s)
    on = [("", {})] if chips is None else [(f"-c{c}", {"chip": int(c)}) for c in chips]
    return [Task(f"{prefix}{run}{tag}-s{seed}", TASK_FN, {**base, **params, **chip, "seed": seed})
            for tag, chip in on for run, params in scenario.runs(BUDGETS[budget], dims, moves)
            for seed in range(int(seeds))]


def in_space(name: str, dims: int | None, moves: str) -> dict[str, Any]:
    """``dims`` and ``moves`` of a scenario run off the plane's king moves, for its
    settings and its result (the plane's say neither, as before a third dimension)."""
    space = get(name).space(dims, moves)
    return {} if space == PLANE else {"dims": space[0], "moves": space[1]}


def run_settings(name: str, backend: str, options: dict[str, Any], budget: str,
                 idle_s: float, dims: int | None = None, moves: str = "king"
                 ) -> dict[str, Any]:
    """What every task of a scenario run shares (its run folder's settings)."""
    return {"run": "scenario", "scenario": name, "world": get(name).world, "backend": backend,
            "backend_options": dict(options), "budget": budget, "idle_s": float(idle_s),
            **in_space(name, dims, moves)}


def _spread(values: list[Any]) -> dict[str, Any]:
    """Seed mean and spread of values where a seed may have none (no success: no
    overhead), over the seeds that have one."""
    return seed_stats([v for v in values if v is not None])


def pool_part(world: World, records: list[dict[str, Any]]) -> dict[str, Any]:
    """One part over its seeds' records (module docstring)."""
    first = records[0]
    out: dict[str, Any] = {"part": first["name"],
                           **{k: first[k] for k in PART_KEYS if k in first},
                           **world.pool(records),
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


def chip_record(record: dict[str, Any]) -> dict[str, Any]:
    """A part record's per-seed metrics, for :func:`~cml_edge.grid.chips.pool_chips`: the
    record without the part's settings (and of the relearning cost, its pulses, writes
    and energy)."""
    out = {k: v for k, v in record.items() if k not in (*PART_KEYS, "trials", "eval_seed")}
    if "relearn" in record:
        out["relearn"] = {k: record["relearn"][k] for k in ("pulses", "writes", "energy_uJ")}
    return out


def pool_part_chips(world: World, entries: list[tuple[int, dict[str, Any]]],
                    yield_target: float) -> dict[str, Any]:
    """``chips``, ``yield`` and ``yield_target`` of one part from its (chip, record)
    entries (module docstring)."""
    by_chip: dict[int, list[dict[str, Any]]] = {}
    for chip, record in entries:
        by_chip.setdefault(chip, []).append(record)
    return pool_chips([{"chip": chip, "success_rate": world.pool(recs)["success_rate"],
                        "per_seed": [chip_record(r) for r in recs]}
                       for chip, recs in by_chip.items()], yield_target)


def run_scenario(name: str, backend: str = "float", options: dict[str, Any] | None = None,
                 seeds: int = 10, budget: str = "full", out: str | Path | None = None,
                 workers: int | None = None, scheduler: str | None = None,
                 progress: Callable[[int, int], None] | None = None, idle_s: float = 0.0,
                 command: str | None = None, chips: int | None = None, first_chip: int = 0,
                 yield_target: float = DEFAULT_YIELD_TARGET,
                 restart: bool = False, dims: int | None = None,
                 moves: str = "king") -> dict[str, Any]:
    """Run scenario ``name`` on ``backend`` with ``options`` (the device's config fields,
    e.g. ``{"preset": "pcm"}``) for model seeds 0..``seeds``-1 at ``budget`` (a key of
    :data:`~cml_edge.scenarios.registry.BUDGETS`); ``idle_s`` more seconds idle before
    every evaluation (the drift-time knob of ``cml-edge breakpoint``). With ``out``, the
    tasks are kept under ``out/tasks`` (resumable) and the result is written to
    ``out/results.json``; without, they go to a temporary folder. With ``chips``, on
    chip seeds ``first_chip`` .. ``first_chip + chips - 1``, each part with its yield at
    ``yield_target``. ``out`` is a run folder of the scenario, device, its options, the
    budget and ``idle_s`` (:mod:`cml_edge.engine.runs`: other settings are refused unless
    ``restart``; more seeds or chips resume it). ``dims`` and ``moves``: the world's
    dimensions and move set (None: the scenario's default; the result then says them, off
    the plane's king moves). Returns the JSON-ready result (module docstring)."""
    options = dict(options or {})
    chip_seeds = None
    if chips is not None:
        check_chips(chips, yield_target, first_chip)
        chip_seeds = list(range(first_chip, first_chip + chips))
    tasks = scenario_tasks(name, backend, options, seeds, budget, idle_s, chip_seeds,
                           dims=dims, moves=moves)
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="cml-edge-scenario-") as tmp:
        results = run_sweep(tasks, out or tmp, workers=workers, scheduler=scheduler,
                            progress=progress, resumable=out is not None,
                            settings=run_settings(name, backend, options, budget, idle_s,
                                                  dims, moves),
                            restart=restart)
    result = scenario_result(name, backend, options, seeds, budget, idle_s, tasks, results,
                             yield_target)
    result.update({"wall_time_s": time.perf_counter() - t0, "command": command,
                   "cml_edge_version": __version__})
    if out is not None:
        with stage("write"):
            atomic_write_text(Path(out) / "results.json", dumps(result, indent=1))
        result["out"] = str(out)
    return result


def scenario_result(name: str, backend: str, options: dict[str, Any], seeds: int,
                    budget: str, idle_s: float, tasks: Sequence[Task],
                    results: Mapping[str, dict[str, Any]],
                    yield_target: float = DEFAULT_YIELD_TARGET) -> dict[str, Any]:
    """The result of scenario ``name`` from its tasks (:func:`scenario_tasks`) and their
    results by key: each part pooled over the seeds (and chips, when the tasks have
    them; module docstring)."""
    scenario = get(name)
    world = get_world(scenario.world)
    chip_seeds = sorted({t.params["chip"] for t in tasks if "chip" in t.params}) or None
    parts: dict[str, list[tuple[dict[str, Any], int, int | None]]] = {}
    for task in tasks:  # (record, model seed, chip seed) of each part
        res = results[task.key]
        for rec in res["parts"]:
            parts.setdefault(rec["name"], []).append((rec, res["seed"],
                                                      task.params.get("chip")))
    pooled = []
    for entries in parts.values():
        row = pool_part(world, [rec for rec, _, _ in entries])
        for entry, (_, seed, chip) in zip(row["per_seed"], entries):
            entry["seed"] = seed
            if chip is not None:
                entry["chip"] = chip
        if chip_seeds is not None:
            row["seeds"] = int(seeds)
            row.update(pool_part_chips(world, [(chip, rec) for rec, _, chip in entries],
                                       yield_target))
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
    if chip_seeds is not None:
        result["chip_seeds"] = chip_seeds
    run = tasks[0].params.get("run", {}) if tasks else {}
    if "dims" in run:  # off the plane's king moves (:func:`in_space`)
        result.update({"dims": run["dims"], "moves": run["moves"]})
    else:  # a world of one dimensionality (the drone's space) says its own, as a break
        result.update(in_space(name, None, "king"))  # point's result does
    if name == "recovery":
        from cml_edge.costs.dqn import dqn_retrain_estimate

        result["dqn_retrain"] = dqn_retrain_estimate()
    return result


def shared_training(tasks: Sequence[Task]) -> tuple[list[Task], dict[str, str]]:
    """One task per trained model: tasks that train the same model (the same world,
    device, training run, seed, chip and idle time; parts aside) become one task
    evaluating all their parts, so the model and its twin are trained once (the paper,
    retention, clutter and recovery scenarios all start from the paper's training).
    Returns the tasks to run and, per given task's key, the key of the task that runs it
    (:func:`shared_result` takes its result apart). A part reads and ages a copy of the
    model (:mod:`cml_edge.scenarios.tasks`), so every part's numbers are those of its own
    scenario's task; the part names of a merged task must differ."""
    groups: dict[str, list[Task]] = {}
    for task in tasks:
        same = dumps({k: v for k, v in task.params.items() if k != "parts"}, sort_keys=True)
        groups.setdefault(task.fn + same, []).append(task)
    merged, owner = [], {}
    for group in groups.values():
        if len(group) == 1:
            merged.append(group[0])
            owner[group[0].key] = group[0].key
            continue
        parts = [p for t in group for p in t.params["parts"]]
        names = [p["name"] for p in parts]
        if len(set(names)) != len(names):
            raise ValueError(f"tasks {[t.key for t in group]} share part names")
        key = "+".join(t.key for t in group)
        merged.append(Task(key, group[0].fn, {**group[0].params, "parts": parts}))
        owner.update({t.key: key for t in group})
    return merged, owner


def shared_result(task: Task, result: dict[str, Any]) -> dict[str, Any]:
    """``task``'s result out of the result of the task that ran it
    (:func:`shared_training`): its own parts, in its order."""
    by_name = {p["name"]: p for p in result["parts"]}
    return {**result, "parts": [by_name[p["name"]] for p in task.params["parts"]]}
