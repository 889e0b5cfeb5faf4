"""Build the hardware-budget report: run the protocol per synaptic array, ledger it, write it.

Read top to bottom: :func:`build_report` trains and evaluates each system (one CML per
seed on the paper's protocol), measures one extra model per system operation by
operation (its counters while training and while planning, priced by its device's cost
model), adds the DQN baseline from its results file, runs the precision sweeps and the
scorecard, and returns one JSON-ready dict. The systems, sweeps and break points are
those the devices declare (:func:`cml_edge.backends.report_systems`,
:func:`~cml_edge.backends.report_sweeps`, :mod:`cml_edge.report.scorecard`).
:func:`write_report` renders ``report.md``, ``report.html`` and the figures from that dict
alone (:mod:`cml_edge.report.render`), so every number on the pages is a number of
``report.json``; it writes everything into a temporary folder and renames it into place,
so an interrupted report leaves no half-written files. :func:`render_report` renders a
report folder again from its ``report.json`` (``cml-edge report --render``).
"""

from __future__ import annotations

import os
import platform
import time
from collections.abc import Callable
from dataclasses import replace
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

import numpy as np

from cml_edge import __version__
from cml_edge.backends import BACKENDS, report_sweeps, report_systems
from cml_edge.baselines import load_results
from cml_edge.baselines.settings import RESULTS_PATH
from cml_edge.core.finite import dumps
from cml_edge.costs import dqn as dqn_costs
from cml_edge.costs import ledger
from cml_edge.engine.runs import RUN_FILE
from cml_edge.engine.sweep import Task
from cml_edge.engine.timings import stage
from cml_edge.engine.warmup import task_units, warm
from cml_edge.errors import InputError
from cml_edge.grid.arena import GridArena
from cml_edge.grid.metrics import convergence_index, draw_pairs
from cml_edge.grid.paths import default_path
from cml_edge.grid.protocol import PROTOCOL_TASK, Protocol, pool_protocol
from cml_edge.grid.seed_run import Evaluation, Training, cml_config_for, train_and_evaluate
from cml_edge.grid.training import TrainConfig
from cml_edge.io.files import atomic_folder, display_path, own_folder
from cml_edge.protocol import EVAL_SEED
from cml_edge.report.batch import Batch
from cml_edge.report.figures import FIGURE_FILES
from cml_edge.report.scorecard import (
    TARGET,
    ScorecardPlan,
    build_scorecard,
    scorecard_tasks,
)
from cml_edge.scenarios.registry import BUDGETS

SCHEMA_VERSION = 2
"""2: the scorecard, break points and recovery curves (and, added, the 3-D section
``space``)."""
SPACE = (3, "king")
"""The report's third dimension: the N x N x N volume with the 26 king moves."""
SPACE_KEYS = ("parameters", "parameter_bytes", "train_bytes_direct",
              "update_bytes_per_run_direct", "device_pulses_per_run", "energy_per_action_nj",
              "energy_per_run_uj", "steps_to_converge", "success_rate", "decision_agreement")
"""The figures the 3-D section sets beside the plane's, with their ratio."""
N_EXAMPLES = 3

def _profile(quick: bool) -> dict[str, int]:
    """Every section's budget (:data:`cml_edge.scenarios.registry.BUDGETS`): the paper's
    protocol on 10 seeds (5 per sweep point), or the quick budget on 2."""
    b = BUDGETS["quick" if quick else "full"]
    return {"walks": b.walks, "steps": b.steps, "trials": b.trials,
            **({"seeds": 2, "sweep_seeds": 2} if quick else {"seeds": 10, "sweep_seeds": 5})}


def measure_operations(backend: str, options: dict[str, Any], explore: str = "random",
                       trials: int = 100, walks: int = 100, steps: int = 900,
                       dims: int = 2, moves: str = "king") -> dict[str, Any]:
    """One model trained (``walks`` x ``steps``) and planned (``trials`` pairs) operation by
    operation: counters per phase, priced by the device's cost model (a sweep task: JSON
    in, JSON out); on the 30 x 30 arena, or in ``dims`` 3 the 30 x 30 x 30 volume, with
    the ``moves`` set."""
    arena = GridArena.empty(30, dims, moves)
    config = TrainConfig(walks, steps, explore=explore)
    training = Training(arena, config, cml_config_for(arena), backend, options,
                        default_path(backend, config.schedule, options, counted=True))
    run = train_and_evaluate(0, training, [Evaluation(arena, draw_pairs(arena, trials,
                                                                        EVAL_SEED))])
    cml, (res,) = run.cml, run.results
    steps = int(res.steps.sum())
    examples = [res.paths[i, : res.steps[i] + 1].tolist() for i in range(N_EXAMPLES)]
    model = ledger.cost_model(cml)
    e_train, e_sources = ledger.energy_pj(model, run.train_counters)
    e_plan, _ = ledger.energy_pj(model, run.eval_counters)
    return {"example_paths": examples, "train_counters": run.train_counters,
            "plan_counters": run.eval_counters,
            "train_steps": config.walks * config.steps, "plan_steps": steps,
            "train_wall_s": run.wall_s[-1], "energy_train_pj": e_train,
            "energy_plan_pj": e_plan, "energy_sources": e_sources,
            "counted_macs": ledger.counted_macs(model, run.eval_counters),
            "memory": ledger.cml_memory(cml, explore, 30, dims),
            "factored": ledger.cml_factored_traffic(cml, config.walks, config.steps),
            "parameters": cml.parameter_count(),
            "inference_flops_formula": cml.inference_flops()}


OPERATIONS_TASK = "cml_edge.report.build:measure_operations"


def system_protocol(backend: str, options: dict[str, Any], prof: dict[str, int],
                    dims: int = 2, moves: str = "king") -> Protocol:
    """The protocol a system of the report is scored on: the paper's at the budget of
    :func:`_profile` ``prof``, a curve point every walk; in ``dims`` dimensions with the
    ``moves`` set (the 3-D section)."""
    return Protocol(backend, range(prof["seeds"]), prof["trials"],
                    train=TrainConfig(prof["walks"], prof["steps"]), epoch=1,
                    backend_options=options, dims=dims, moves=moves)


def protocol_tasks(prefix: str, protocol: Protocol) -> list[Task]:
    """One task per seed of ``protocol`` (:func:`cml_edge.grid.protocol.protocol_task`)."""
    spec = protocol.to_dict()
    return [Task(f"{prefix}-s{seed}", PROTOCOL_TASK, {"protocol": spec, "seed": seed})
            for seed in protocol.seeds]


def protocol_result(prefix: str, protocol: Protocol,
                    results: dict[str, dict[str, Any]]) -> dict[str, Any]:
    """:func:`~cml_edge.grid.protocol.pool_protocol` of the tasks of
    :func:`protocol_tasks`; its ``wall_time_s`` is the seeds' own, summed."""
    records = [results[t.key] for t in protocol_tasks(prefix, protocol)]
    return pool_protocol(protocol, records, sum(r["wall_s"] for r in records))


def cml_row(label: str, backend: str, options: dict[str, Any], acc: dict[str, Any],
            ops: dict[str, Any]) -> dict[str, Any]:
    """Accuracy on the protocol (``acc``, :func:`protocol_result`) and the ledger
    (``ops``, :func:`measure_operations`) of one CML system."""
    e_train, e_plan = ops["energy_train_pj"], ops["energy_plan_pj"]
    tc = ops["train_counters"]
    return {
        "label": label, "backend": backend, "options": options, "kind": "cml",
        **{k: acc[k] for k in ("seeds", "trials", "success_rate", "e_pos_mean",
                               "e_pos_median", "overhead_mean", "overhead_median")},
        "curve_e_pos_mean": acc["curve_e_pos_mean"],
        "epoch_steps": acc["epoch_walks"] * acc["steps"],
        "parameters": ops["parameters"],
        "inference_flops_formula": ops["inference_flops_formula"],
        "inference_flops_counted": counted_flops(ops["counted_macs"], ops["plan_steps"]),
        **ops["memory"],
        "train_steps": ops["train_steps"],
        "update_bytes_per_run_direct": tc.get("bytes_read", 0) + tc.get("bytes_written", 0),
        "update_bytes_per_step_direct": (tc.get("bytes_read", 0) + tc.get("bytes_written", 0))
        / ops["train_steps"],
        "update_bytes_per_run_factored": ops["factored"]["bytes_per_run"],
        "cells_changed_per_run": tc.get("cells_changed", tc.get("devices_written", 0)),
        "device_pulses_per_run": tc.get("device_pulses"),
        "coincidences_per_run": tc.get("coincidences"),
        "energy_per_run_uj": None if e_train is None else e_train / 1e6,
        "energy_per_action_nj": None if e_plan is None else e_plan / ops["plan_steps"] / 1e3,
        "energy_sources": ops["energy_sources"],
        "train_wall_s": ops["train_wall_s"],
        "protocol_wall_s": acc["wall_time_s"],
        "train_counters": tc,
        "plan_counters": ops["plan_counters"],
        "plan_steps": ops["plan_steps"],
        "example_paths": ops["example_paths"],
        "steps_to_converge": steps_to_converge(acc["curve_e_pos_mean"],
                                               acc["epoch_walks"] * acc["steps"]),
    }


def space_row(plane: dict[str, Any], plane_acc: dict[str, Any], space: dict[str, Any],
              space_acc: dict[str, Any]) -> dict[str, Any]:
    """One device of the 3-D section: its :data:`SPACE_KEYS` on the plane (``plane``, its
    :func:`cml_row`, and ``plane_acc``, its protocol's result) and in the volume
    (``space``, ``space_acc``), and each 3-D / 2-D ratio (None where either is n/a or
    the plane's is 0); the 3-D system's whole row under ``system``."""
    def figures(row: dict[str, Any], acc: dict[str, Any]) -> dict[str, Any]:
        agreement = acc.get("decision_agreement")
        return {**{k: row.get(k) for k in SPACE_KEYS if k != "decision_agreement"},
                "decision_agreement": None if agreement is None else agreement["mean"]}

    two, three = figures(plane, plane_acc), figures(space, space_acc)
    return {"label": plane["label"], "backend": plane["backend"], "options": plane["options"],
            "dims": SPACE[0], "moves": SPACE[1], "plane": two, "space": three,
            "ratio": {k: None if two[k] in (None, 0) or three[k] is None
                      else three[k] / two[k] for k in SPACE_KEYS},
            "system": space}


def counted_flops(macs: int, steps: int) -> float:
    """Counted FLOPs per planning step: two per multiply-accumulate."""
    return ledger.FLOPS_PER_MAC * macs / max(steps, 1)


def steps_to_converge(curve: list[float], epoch_steps: int) -> int | None:
    """Training steps until the evaluation e_pos (one point every ``epoch_steps``) stays
    within half a cell of its final value: :func:`cml_edge.grid.metrics.convergence_index`,
    the criterion ``cml-edge dqn evaluate`` applies to the DQN."""
    if not curve:
        return None
    return (convergence_index(curve) + 1) * epoch_steps


DQN_VARIANTS = (("DQN-simplified", "simplified", False), ("DQN-tailored", "tailored", False),
                ("DQN-goal-conditioned", "tailored", True))


def dqn_rows(path: Path = RESULTS_PATH) -> tuple[list[dict[str, Any]], dict[str, Any] | None]:
    """The DQN baselines: the ledger from each network's real layer sizes and training
    settings, accuracy and times from the results file ``cml-edge dqn`` wrote, if any."""
    results = load_results(path)
    evaluations = (results or {}).get("evaluations", {}).values()
    rows = []
    for label, reward, goal_conditioned in DQN_VARIANTS:
        ev = next((e for e in evaluations if e["reward"] == reward
                   and e["goal_conditioned"] == goal_conditioned), {})
        settings = dqn_costs.DQNSettings(n_in=4 if goal_conditioned else 2)
        steps = int(ev.get("train_steps", 100_000 if reward == "simplified" else 200_000))
        traffic = dqn_costs.dqn_training_traffic(settings, steps)
        energy, sources = dqn_costs.dqn_energy_pj(traffic)
        mem = dqn_costs.dqn_memory(settings)
        macs_per_action = dqn_costs.dqn_inference_flops(settings) / ledger.FLOPS_PER_MAC
        rows.append({
            "label": label, "kind": "dqn",
            "pairs": "protocol" if goal_conditioned else "fixed goal per seed",
            **{k: ev.get(k) for k in ("seeds", "trials", "success_rate", "e_pos_mean",
                                      "e_pos_median", "overhead_mean", "overhead_median")},
            "parameters": dqn_costs.dqn_parameter_count(settings),
            "inference_flops_formula": dqn_costs.dqn_inference_flops(settings),
            "inference_flops_counted": None,
            "weight_bits": 32, "parameter_bytes": mem["parameter_bytes"],
            "train_bytes_direct": mem["train_bytes"], "memory": mem,
            "train_steps": steps,
            "update_bytes_per_run_direct": traffic["replay_bytes"] + traffic["weight_bytes"],
            "update_bytes_per_step_direct": (traffic["replay_bytes"] + traffic["weight_bytes"])
            / steps,
            "update_bytes_per_run_factored": None,
            "energy_per_run_uj": energy / 1e6,
            "energy_per_action_nj": macs_per_action * ledger.COSTS["fp32_mac"].pj / 1e3,
            "energy_sources": sources, "traffic": traffic,
            "train_wall_s": ev.get("train_wall_s_mean"),
            "steps_to_converge": (ev.get("convergence") or {}).get("step"),
            "curve_steps": ev.get("curve_steps"),
            "curve_e_pos_mean": ev.get("curve_e_pos_mean"),
        })
    return rows, results


def build_report(quick: bool = False, command: str = "cml-edge report",
                 progress: Callable[[str, int, int], None] | None = None,
                 systems: list[tuple[str, str, dict[str, Any]]] | None = None,
                 sweeps: list[tuple[str, str, str, dict[str, Any]]] | None = None,
                 dqn_results: str | Path = RESULTS_PATH,
                 scorecard: ScorecardPlan | None = None, folder: str | Path | None = None,
                 workers: int | None = None, scheduler: str | None = None,
                 restart: bool = False, space: bool = True) -> dict[str, Any]:
    """Everything the report shows, as one JSON-ready dict; the DQN's accuracy and times
    come from ``dqn_results`` (what ``cml-edge dqn`` wrote), n/a if it does not exist.
    ``scorecard``: what the scorecard runs (default :meth:`ScorecardPlan.of` ``quick``;
    :mod:`cml_edge.report.scorecard`).

    Every model is a task of one :class:`~cml_edge.report.batch.Batch` on ``workers``
    processes (default: the scorecard plan's, else one per core) or the Dask
    ``scheduler``, kept in run folder ``folder`` as it ends (None: a temporary folder), so
    a report run again into the same folder resumes (``restart``: starts it over). On a
    local pool, the kernels of every kind of task are first compiled on every core, each
    task made tiny (:func:`~cml_edge.engine.warmup.task_units`; the stage ``compile``).
    The stages: the systems' protocol seeds and operation counts, the precision sweeps
    and the scorecard's models in one batch, then the break points' bisections in
    lockstep. ``progress(stage, done, total)`` counts each stage's tasks. With ``space``
    (the default), the 3-D section ``space``: every system again in the 30 x 30 x 30
    volume (:data:`SPACE`; the protocol and the operation counts, :func:`space_row`), the
    scorecard's 3-D scenarios (:attr:`ScorecardPlan.space`) and the break points again in
    the volume (:func:`~cml_edge.report.scorecard.space_breakpoints`); the plane's sections are
    the same with or without it."""
    t0 = time.perf_counter()
    prof = _profile(quick)
    systems = [s for s in (report_systems() if systems is None else systems) if s[1] in BACKENDS]
    sweeps = [s for s in (report_sweeps() if sweeps is None else sweeps) if s[2] in BACKENDS]
    plan = scorecard or ScorecardPlan.of(quick)
    settings = {"run": "report", "quick": quick, "systems": systems, "sweeps": sweeps}
    sys_protocols = [(f"system-{label}", system_protocol(backend, opts, prof))
                     for label, backend, opts in systems]
    sweep_protocols = [(f"sweep-{label}", Protocol(
        backend, range(prof["sweep_seeds"]), prof["trials"],
        train=TrainConfig(prof["walks"], prof["steps"]), backend_options=opts))
        for _, label, backend, opts in sweeps]
    ops_tasks = [Task(f"operations-{label}", OPERATIONS_TASK,
                      {"backend": backend, "options": opts, "trials": prof["trials"],
                       "walks": prof["walks"], "steps": prof["steps"]})
                 for label, backend, opts in systems]
    space_protocols = [(f"space-{label}", system_protocol(backend, opts, prof, *SPACE))
                       for label, backend, opts in systems] if space else []
    space_ops = [Task(f"space-operations-{label}", OPERATIONS_TASK,
                      {"backend": backend, "options": opts, "trials": prof["trials"],
                       "walks": prof["walks"], "steps": prof["steps"], "dims": SPACE[0],
                       "moves": SPACE[1]})
                 for label, backend, opts in systems] if space else []
    if not space:
        plan = replace(plan, space=())
    if scheduler is None:  # the kernels of every task first, on every core
        warm(task_units([t for prefix, p in sys_protocols + sweep_protocols + space_protocols
                         for t in protocol_tasks(prefix, p)[:1]] + ops_tasks + space_ops
                        + [t for ts in scorecard_tasks(plan).values() for t in ts]),
             workers or plan.workers,
             progress and (lambda done, total, what: progress("compile", done, total)))
    with Batch(workers or plan.workers, scheduler, folder, settings, progress,
               restart) as batch:
        done = batch.run("systems", [t for prefix, p in sys_protocols + sweep_protocols
                                     + space_protocols for t in protocol_tasks(prefix, p)]
                         + ops_tasks + space_ops)
        card = build_scorecard(plan, batch)
    accs = [protocol_result(prefix, p, done) for prefix, p in sys_protocols]
    rows = [cml_row(label, backend, opts, acc, done[f"operations-{label}"])
            for (label, backend, opts), acc in zip(systems, accs)]
    space_rows = []
    for (label, backend, opts), row, acc, (prefix, p) in zip(systems, rows, accs,
                                                             space_protocols):
        acc3 = protocol_result(prefix, p, done)
        space_rows.append(space_row(row, acc, cml_row(
            label, backend, opts, acc3, done[f"space-operations-{label}"]), acc3))
    space_card = card.pop("space_scorecard", None)
    space_bps = card.pop("space_breakpoints", None)
    dqn, dqn_data = dqn_rows(Path(dqn_results))
    sweep_rows = []
    for (figure, label, backend, opts), (prefix, p) in zip(sweeps, sweep_protocols):
        r = protocol_result(prefix, p, done)
        sweep_rows.append({"figure": figure, "label": label, "backend": backend,
                           "options": opts, **{k: r[k] for k in (
                               "seeds", "success_rate", "e_pos_mean", "overhead_mean")}})
    return {
        "schema_version": SCHEMA_VERSION,
        "title": "cml-edge hardware-budget report",
        "quick": quick,
        "command": command,
        "generated": datetime.now(timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
        "versions": _versions(),
        "machine": {"platform": platform.platform(), "cpus": os.cpu_count()},
        "protocol": {"arena": 30, "walks": prof["walks"], "steps": prof["steps"],
                     "seeds": prof["seeds"],
                     "trials": prof["trials"], "eval_seed": EVAL_SEED, "max_steps": 100},
        "systems": rows + dqn,
        "dqn_results_file": display_path(dqn_results) if dqn_data is not None else None,
        "dqn_runs": {k: {"seeds_done": sorted((v.get("seeds") or {}).keys(), key=int),
                         "steps": v.get("steps")}
                     for k, v in (dqn_data or {}).get("runs", {}).items()},
        "sweeps": sweep_rows,
        "costs": ledger.costs_table(),
        **card,
        **({"space": {"dims": SPACE[0], "moves": SPACE[1], "arena": 30,
                      "systems": space_rows, "scorecard": space_card or [],
                      "breakpoints": space_bps or [],
                      "scorecard_plan": {"seeds": plan.seeds, "budget": plan.budget,
                                         "target": TARGET, "scenarios": list(plan.space),
                                         "devices": [d[0] for d in plan.devices]}}}
           if space else {}),
        "wall_time_s": time.perf_counter() - t0,
    }


def _versions() -> dict[str, str]:
    import matplotlib
    import numba
    import scipy

    return {"cml_edge": __version__, "python": platform.python_version(),
            "numpy": np.__version__, "numba": numba.__version__, "scipy": scipy.__version__,
            "matplotlib": matplotlib.__version__}


def load_report(folder: str | Path, flag: str = "--render") -> dict[str, Any]:
    """The report.json of report folder ``folder`` (InputError naming ``flag`` where there
    is none, or it is not a report of this schema)."""
    import json

    path = Path(folder) / "report.json"
    try:
        report = json.loads(path.read_text())
    except (OSError, ValueError) as exc:
        raise InputError(f"{flag} {str(folder)!r}: no readable report.json there "
                         f"({exc.__class__.__name__})") from None
    if not isinstance(report, dict) or report.get("schema_version") != SCHEMA_VERSION:
        raise InputError(f"{flag} {str(folder)!r}: report.json is not a report of schema "
                         f"{SCHEMA_VERSION} (cml-edge report writes one)")
    return report


REPORT_NAMES = frozenset({"report.json", "report.md", "report.html", RUN_FILE, "tasks",
                          *FIGURE_FILES})
"""What a report folder holds: the pages, the figures and, while the report runs, its run
files. :func:`write_report` replaces the folder whole."""


def check_report_folder(folder: str | Path, flag: str) -> None:
    """Refuse (before any work) a folder that holds anything a report does not write:
    the finished report replaces it whole."""
    own_folder(Path(folder), set(REPORT_NAMES), flag)


def write_report(report: dict[str, Any], out: str | Path,
                 old: tuple[dict[str, Any], str] | None = None) -> Path:
    """Write report.json, report.md, report.html and the figures into ``out``, all or
    nothing (:func:`~cml_edge.io.files.atomic_folder`); ``old``: (an older report, its
    folder) whose differences the pages show."""
    from cml_edge.report import render

    def write(folder: Path) -> None:
        with stage("figures"):
            figures = render.render_figures(report, folder)
        with stage("write"):
            (folder / "report.json").write_text(dumps(report, indent=1, sort_keys=True))
            (folder / "report.md").write_text(render.render_markdown(report, figures, old))
            (folder / "report.html").write_text(render.render_html(report, folder, figures,
                                                                   old))

    return atomic_folder(out, write)


def render_report(folder: str | Path, old: tuple[dict[str, Any], str] | None = None) -> Path:
    """Render report folder ``folder`` again from its report.json alone (nothing runs):
    report.md, report.html and the figures, in place; the JSON is kept as it was."""
    return write_report(load_report(folder), folder, old)
