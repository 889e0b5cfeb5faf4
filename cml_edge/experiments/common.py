"""What every experiment shares: one task (train one seed, evaluate it), pooling, output.

A task trains one CML in an empty arena (the paper's protocol: 100 walks x 900 steps,
per-walk updates, seed = model seed) and evaluates it under a list of evaluation
conditions (an arena, obstacles, a map and its scenarios, a planner, a step budget),
all on pairs drawn from the evaluation seed, so every configuration sees the same
pairs. It returns per-trial finals and steps, so the pooled metrics over seeds
(:func:`~cml_edge.grid.metrics.pool_records`) are the exact ones of
:func:`cml_edge.grid.metrics.summarize` over all seeds x trials, whatever ran the tasks.

An experiment module defines ``NAME``, ``CLAIM`` (the paper's qualitative claim it
checks), ``tasks(**options) -> list[Task]``, ``rows(results) -> list[dict]`` (usually
:func:`summary_rows`) and ``plot(rows, results, path)``; :func:`run_experiment` does the
rest (sweep, ``results.json``, ``results.csv``, ``figure.png``).

In space (``cml-edge sweep NAME --dims 3``, ``--moves face``): a module whose ``DIMS``
holds 3 runs its tasks in the N x N x N volume (every task trains in the cube of its arena
side and evaluates its conditions there; :func:`space_tasks`); one without (the MovingAI
plane maps') is refused before any work. The plane's king moves leave every task, key and
result as it was.
"""

from __future__ import annotations

import csv
import io
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from cml_edge.core.finite import dumps
from cml_edge.engine.sweep import Task, run_sweep
from cml_edge.engine.timings import stage
from cml_edge.errors import InputError
from cml_edge.grid.arena import DIMS, MOVE_SETS, GridArena
from cml_edge.grid.condition import Condition
from cml_edge.grid.metrics import draw_pairs, pool_records
from cml_edge.grid.seed_run import Evaluation, Training, cml_config_for, train_and_evaluate
from cml_edge.grid.sensors import Sensors
from cml_edge.grid.training import TrainConfig
from cml_edge.io.figures import pyplot
from cml_edge.io.files import atomic_write_text
from cml_edge.protocol import EVAL_SEED

TASK_FN = "cml_edge.experiments.common:train_eval"
PLANE = (2, "king")
DEFAULT_SEEDS = 10
OUT_ROOT = Path("runs") / "experiments"
METRICS = ("success_rate", "success_rate_connected", "e_pos_mean", "e_pos_median",
           "overhead_mean", "overhead_median", "overhead_geodesic_mean", "connected_pairs",
           "trials")


def eval_spec(name: str, *, size: int | None = None, obstacles: int = 0,
              map: str | None = None, scen: str | None = None, planner: str = "paper",
              max_steps: int | None = None, trials: int = 100,
              eval_seed: int = EVAL_SEED) -> dict[str, Any]:
    """One evaluation condition as JSON (:class:`~cml_edge.grid.condition.Condition`, checked;
    ``max_steps`` None: the arena's :func:`~cml_edge.grid.maps.step_budget`)."""
    return Condition(name, size, obstacles, map, scen, planner, max_steps, trials,
                     eval_seed).to_dict()


def train_eval(seed: int, evals: list[dict[str, Any]], arena: int = 30, walks: int = 100,
               steps: int = 900, explore: str = "random", backend: str = "float",
               backend_options: dict[str, Any] | None = None, path: str | None = None,
               epoch: int = 10, curve: bool = False, curve_trials: int = 100,
               eval_seed: int = EVAL_SEED,
               cml_options: dict[str, Any] | None = None,
               sensors: dict[str, Any] | None = None, dims: int = 2,
               moves: str = "king") -> dict[str, Any]:
    """The task of every experiment: train model ``seed``, then run each of ``evals``
    (:func:`cml_edge.grid.seed_run.train_and_evaluate`; ``path`` None: its default).
    ``cml_options``: fields of the CML's config that differ from the defaults
    (:meth:`cml_edge.core.cml.CMLConfig.for_arena`). ``sensors``: range sensors
    (:class:`~cml_edge.grid.sensors.Sensors` as JSON), read in training, on its arena
    with obstacles, and in every evaluation; None: the paper's empty training arena.
    ``dims`` and ``moves``: the arena's dimensions and move set (the result then says
    them, off the plane's king moves).

    With ``curve``, the model is evaluated on the empty training arena every ``epoch``
    walks (the paper's Figure 4B / 5 curves: e_pos mean, success, overhead mean).
    """
    sensed = Sensors.from_dict(sensors) if sensors is not None else None
    train_arena = (GridArena.sensed(sensed, arena) if sensed
                   else GridArena.empty(arena, dims, moves))
    training = Training(train_arena, TrainConfig(walks, steps, explore),
                        cml_config_for(train_arena, **(cml_options or {})), backend,
                        backend_options or {}, path, epoch)
    evaluations = [Condition.from_dict(spec).evaluation(arena, dims, moves, sensors=sensed)
                   for spec in evals]
    curve_eval = (Evaluation(train_arena, draw_pairs(train_arena, curve_trials, eval_seed))
                  if curve else None)
    run = train_and_evaluate(seed, training, evaluations, curve=curve_eval)
    points = [{"walks": p["walks"], "train_steps": p["walks"] * steps,
               **{k: p[k] for k in ("e_pos_mean", "success_rate", "overhead_mean")}}
              for p in run.curve]
    out_evals = []
    for spec, ev, res, summary in zip(evals, evaluations, run.results, run.summaries):
        pairs = ev.pairs
        out_evals.append({**spec, "max_steps": ev.max_steps, "eval_arena": ev.arena.size,
                          **summary,
                          "final": res.final.tolist(), "steps": res.steps.tolist(),
                          "starts": pairs.starts.tolist(), "goals": pairs.goals.tolist(),
                          "chebyshev": pairs.chebyshev.tolist(),
                          "geodesic": pairs.geodesic.tolist()})
    space = {} if (dims, moves) == PLANE else {"dims": dims, "moves": moves}
    return {"seed": int(seed), "backend": backend, "path": run.path,
            "train_error": run.train_error.tolist(), "curve": points, "evals": out_evals,
            **space}


def make_tasks(configs: list[tuple[str, dict[str, Any]]], seeds: int) -> list[Task]:
    """The (configuration x seed) grid: one task per pair, key ``CONFIG-sSEED``."""
    if isinstance(seeds, bool) or int(seeds) != seeds or seeds < 1:
        raise InputError(f"seeds {seeds!r} is not an integer >= 1")
    return [Task(f"{cid}-s{seed}", TASK_FN, {**params, "seed": seed})
            for cid, params in configs for seed in range(seeds)]


def space_tasks(module: Any, tasks: list[Task], dims: int = 2,
                moves: str = "king") -> list[Task]:
    """``tasks`` of experiment ``module`` in ``dims`` dimensions with the ``moves`` set
    (module docstring); InputError for a module whose ``DIMS`` does not hold ``dims``."""
    if dims not in DIMS:
        raise InputError(f"dims {dims!r} is not allowed (allowed: 2, 3)")
    if moves not in MOVE_SETS:
        raise InputError(f"unknown moves {moves!r}; allowed: {', '.join(MOVE_SETS)}")
    if dims not in getattr(module, "DIMS", (2,)):
        raise InputError(f"experiment {module.NAME!r} runs on the plane only, not in "
                         f"{dims}-D{getattr(module, 'PLANE_ONLY', '')}")
    if (dims, moves) == PLANE:
        return tasks
    return [Task(t.key, t.fn, {**t.params, "dims": dims, "moves": moves}) for t in tasks]


def reject(name: str, **given: Any) -> None:
    """InputError naming the options experiment ``name`` does not take."""
    bad = [k for k, v in given.items() if v]
    if bad:
        raise InputError(f"experiment {name!r} does not take --{bad[0]}")


def config_id(key: str) -> str:
    return key.rsplit("-s", 1)[0]


def summary_rows(results: dict[str, dict[str, Any]], config_fields: tuple[str, ...]
                 ) -> list[dict[str, Any]]:
    """One row per (configuration, evaluation): pooled metrics over the seeds."""
    groups: dict[tuple[str, str], list[dict[str, Any]]] = {}
    params: dict[str, dict[str, Any]] = {}
    for key, res in results.items():
        cid = config_id(key)
        for ev in res["evals"]:
            groups.setdefault((cid, ev["name"]), []).append(ev)
        params[cid] = res
    rows = []
    for (cid, ename), recs in groups.items():
        first = recs[0]
        row = {"config": cid, "eval": ename,
               **{f: params[cid]["_config"].get(f) for f in config_fields},
               "eval_arena": first["eval_arena"], "obstacles": first["obstacles"],
               "map": first["map"], "planner": first["planner"],
               "max_steps": first["max_steps"], "seeds": len(recs)}
        pooled = pool_records(recs)
        row.update({k: pooled[k] for k in METRICS})
        rows.append(row)
    return rows


def mean_curve(results: dict[str, dict[str, Any]], cid: str, field: str) -> tuple[list, list]:
    """(training steps, mean over seeds of ``field``) of configuration ``cid``'s curves."""
    curves = [r["curve"] for k, r in results.items() if config_id(k) == cid]
    xs = [p["train_steps"] for p in curves[0]]
    ys = []
    for i in range(len(xs)):
        vals = [c[i][field] for c in curves if c[i][field] is not None]
        ys.append(float(np.mean(vals)) if vals else float("nan"))
    return xs, ys


# output -----------------------------------------------------------------------------
def write_csv(path: Path, rows: list[dict[str, Any]]) -> None:
    if not rows:
        return
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=list(rows[0]))
    writer.writeheader()
    for row in rows:
        writer.writerow({k: ("" if v is None else v) for k, v in row.items()})
    atomic_write_text(path, buf.getvalue())


def markdown_table(rows: list[dict[str, Any]], columns: tuple[str, ...]) -> str:
    def cell(v: Any) -> str:
        if v is None:
            return "n/a"
        return f"{v:.3f}" if isinstance(v, float) else str(v)

    lines = ["| " + " | ".join(columns) + " |", "|" + "---|" * len(columns)]
    lines += ["| " + " | ".join(cell(r.get(c)) for c in columns) + " |" for r in rows]
    return "\n".join(lines)


def figure():
    return pyplot()


def arena_title(results: dict[str, dict[str, Any]], side: int = 30) -> str:
    """The training arena of ``results`` as a figure says it: ``30 x 30``, or
    ``30 x 30 x 30`` in the volume (the results' ``dims``), with ``, face moves`` off the
    king moves."""
    first = next(iter(results.values()))
    moves = first.get("moves", "king")
    return (" x ".join([str(side)] * first.get("dims", 2))
            + (f", {moves} moves" if moves != "king" else ""))


def run_experiment(module: Any, out: str | Path | None = None, workers: int | None = None,
                   scheduler: str | None = None,
                   progress: Callable[[int, int], None] | None = None,
                   restart: bool = False, **options: Any) -> dict[str, Any]:
    """Sweep ``module``'s tasks into ``out`` and write results.json / .csv / figure.png.
    ``out`` is a run folder of the experiment and its options but the seeds
    (:mod:`cml_edge.engine.runs`; ``restart`` starts it over)."""
    out = Path(out) if out else OUT_ROOT / module.NAME
    space = {k: options.pop(k) for k in ("dims", "moves") if k in options}
    tasks = space_tasks(module, module.tasks(**options), **space)
    if (space.get("dims", 2), space.get("moves", "king")) != PLANE:
        options.update(space)  # the run folder's settings and the summary say them
    settings = {"run": "experiment", "experiment": module.NAME,
                **{k: v for k, v in options.items() if k != "seeds"}}
    results = run_sweep(tasks, out, workers=workers, scheduler=scheduler, progress=progress,
                        settings=settings, restart=restart)
    configs = {config_id(t.key): {k: v for k, v in t.params.items() if k not in ("seed",)}
               for t in tasks}
    for key, res in results.items():
        res["_config"] = configs[config_id(key)]
    rows = module.rows(results)
    for res in results.values():
        res.pop("_config", None)
    summary = {"experiment": module.NAME, "claim": module.CLAIM, "tasks": len(tasks),
               "seeds": options.get("seeds", DEFAULT_SEEDS), "options": options,
               "rows": rows}
    with stage("write"):
        atomic_write_text(out / "results.json", dumps(summary, indent=1))
        write_csv(out / "results.csv", rows)
    with stage("figures"):
        module.plot(rows, results, out / "figure.png")
    summary["out"] = str(out)
    return summary
