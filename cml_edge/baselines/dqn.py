"""DQN baseline (paper 2.3, 3.1): train, evaluate, compare with the CML on the same pairs.

The network is the paper's: inputs -> 64 -> 64 -> 8 actions, ReLU (4,872 parameters
with (x, y) inputs; 9,472 FLOPs per action by the paper's formula; see
:mod:`cml_edge.baselines`). It is trained with stable-baselines3's DQN using the
hyperparameters of the original stable-baselines DQN ("the already tuned implementation
from Hill et al., 2018"), listed in
:data:`cml_edge.baselines.settings.HYPERPARAMS`. SB3's DQN is *vanilla* DQN: the
original stable-baselines also used Double-Q targets and a dueling head by default, which
SB3 does not implement. SB3's own defaults are Atari settings and did not learn this task.

Environments: :mod:`cml_edge.grid.env` (stay in place on a blocked move, goal ends the
episode, truncation at 100 steps, Eq. 6 or Eq. 7 rewards).

What is evaluated, on the empty 30 x 30 arena, with the CML's metrics
(:func:`cml_edge.grid.metrics.summarize`), ``predict(deterministic=True)``:

- **fixed-goal DQN** (the paper's: it sees only (x, y), so each trained network has one
  goal). The goal of seed s is the goal of protocol pair s, i.e. of
  ``draw_pairs(arena, s + 1, eval_seed).goals[s]`` (evaluation seed 123), and it is
  evaluated from ``trials`` starts drawn uniformly among the other free cells by
  ``numpy.random.default_rng((eval_seed, s))`` (:func:`fixed_goal_pairs`). Training
  episodes start on uniformly random cells. The CML of seed s (trained by
  :func:`cml_edge.grid.training.train`, factored path) is evaluated on exactly these pairs.
- **goal-conditioned DQN** (inputs x, y, goal x, goal y; each training episode draws a
  goal): evaluated on the standard protocol pairs ``draw_pairs(arena, trials,
  eval_seed)``, as the CML is.

Convergence (for the training-time ratio). Every method's seed-mean evaluation e_pos
curve is sampled during training (DQN: every ``eval_every`` = 5,000 steps; CML: every
walk of 900 steps). Its convergence point is the first evaluation from which the curve
stays within :data:`CONVERGENCE_TOL` = 0.5 cells (half a grid cell) of its final value.
Time to convergence is the seed-mean training time up to that point, evaluation time
excluded (wall-clock and process CPU time both recorded; CPU time is the steadier figure
while other jobs share the machine).

Results go to one JSON file (default ``hw_reports/baselines/dqn_results.json``) written
atomically after every seed, with provenance; ``train`` skips seeds already in it, so an
interrupted run resumes. Models (SB3 zips) go to ``--models`` (``cml-edge dqn train``
requires it; :func:`train_runs` keeps them in ``runs/dqn`` unless told).
"""

from __future__ import annotations

import datetime as _dt
import fcntl
import os
import platform
import time
import warnings
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np

from cml_edge import __version__
from cml_edge.baselines import (
    RESULTS_FORMAT,
    RESULTS_VERSION,
    load_results,
    mlp_inference_flops,
    mlp_parameter_count,
)
from cml_edge.baselines.settings import (  # noqa: F401 - all re-exported
    DEFAULT_STEPS,
    EVAL_EVERY,
    GOAL_CONDITIONED_LAYERS,
    HYPERPARAMS,
    MODELS_DIR,
    NET_ARCH,
    PAPER_LAYERS,
    RESULTS_PATH,
    DQNRun,
)
from cml_edge.core.finite import dumps
from cml_edge.errors import InputError
from cml_edge.grid.arena import GridArena, chebyshev
from cml_edge.grid.metrics import (
    CONVERGENCE_TOL,
    Pairs,
    convergence_index,
    draw_pairs,
    geodesic_distances,
    summarize,
)
from cml_edge.io.files import atomic_write_text
from cml_edge.protocol import EVAL_SEED

EXTRA_HINT = ("the DQN needs the optional extra: pip install torch==2.13.0 && "
              "pip install -e '.[dqn]'")


# pairs -------------------------------------------------------------------------------
def fixed_goal(arena: GridArena, seed: int, eval_seed: int = EVAL_SEED) -> np.ndarray:
    """The goal of fixed-goal DQN seed ``seed``: the goal of protocol pair ``seed``."""
    return draw_pairs(arena, seed + 1, eval_seed).goals[seed].copy()


def fixed_goal_pairs(arena: GridArena, trials: int, seed: int,
                     eval_seed: int = EVAL_SEED) -> Pairs:
    """``trials`` starts drawn uniformly among the free cells other than the goal of
    ``seed`` (by ``default_rng((eval_seed, seed))``), all to that goal."""
    goal = fixed_goal(arena, seed, eval_seed)
    free = np.argwhere(~arena.blocked)
    free = free[~(free == goal).all(axis=1)]
    rng = np.random.default_rng((eval_seed, seed))
    starts = free[rng.integers(len(free), size=trials)].astype(np.int64)
    goals = np.repeat(goal[None].astype(np.int64), trials, axis=0)
    return Pairs(starts, goals, chebyshev(starts, goals),
                 geodesic_distances(arena, starts, goals))


def run_pairs(run: DQNRun, arena: GridArena, seed: int) -> tuple[np.ndarray | None, Pairs]:
    """(fixed goal or None, evaluation pairs) of one seed of ``run``."""
    if run.goal_conditioned:
        return None, draw_pairs(arena, run.trials, run.eval_seed)
    return fixed_goal(arena, seed, run.eval_seed), fixed_goal_pairs(arena, run.trials, seed,
                                                                     run.eval_seed)


def pool(pairs_list: Sequence[Pairs], finals: Sequence[np.ndarray],
         steps: Sequence[np.ndarray]) -> dict[str, Any]:
    """The protocol's metrics pooled over seeds x trials."""
    pooled = Pairs(*(np.concatenate([getattr(p, f) for p in pairs_list])
                     for f in ("starts", "goals", "chebyshev", "geodesic")))
    return summarize(np.concatenate(finals), np.concatenate(steps), pooled)


# convergence -----------------------------------------------------------------------
def curve_convergence(steps: Sequence[int], curves: Sequence[Sequence[float]],
                      wall: Sequence[Sequence[float]], cpu: Sequence[Sequence[float]],
                      tol: float = CONVERGENCE_TOL) -> dict[str, Any]:
    """Convergence of the seed-mean curve; times are seed means at that point."""
    mean = np.mean(np.asarray(curves, float), axis=0)
    i = convergence_index(mean, tol)
    return {"tolerance_cells": tol, "index": i, "step": int(steps[i]),
            "e_pos_mean_at": float(mean[i]), "e_pos_mean_final": float(mean[-1]),
            "wall_s": float(np.mean(np.asarray(wall, float)[:, i])),
            "cpu_s": float(np.mean(np.asarray(cpu, float)[:, i]))}


# results file ----------------------------------------------------------------------
def _provenance(command: str) -> dict[str, Any]:
    prov = {"date": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
            "command": command, "cml_edge": __version__, "python": platform.python_version(),
            "numpy": np.__version__, "machine": platform.machine(), "cpu": _cpu_name(),
            "cpu_count": _cpu_count(), "nice": os.nice(0)}
    try:
        from cml_edge.baselines import dqn_sb3

        prov.update(dqn_sb3.versions())
    except ImportError:
        pass
    return prov


def _cpu_name() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor()


def _cpu_count() -> int | None:
    return os.cpu_count()


def _empty_results() -> dict[str, Any]:
    return {"format": RESULTS_FORMAT, "format_version": RESULTS_VERSION,
            "network": network_figures(), "hyperparameters": HYPERPARAMS,
            "implementation": "stable-baselines3 DQN (vanilla: no Double-Q, no dueling head)",
            "runs": {}, "evaluations": {}}


def read_results(path: str | Path) -> dict[str, Any]:
    data = load_results(path)
    if data is None:
        return _empty_results()
    if data.get("format_version") != RESULTS_VERSION:
        raise InputError(f"{str(path)!r} has DQN results version {data.get('format_version')}, "
                         f"this cml-edge writes version {RESULTS_VERSION}")
    return data


def write_results(path: str | Path, data: dict[str, Any]) -> None:
    atomic_write_text(path, dumps(data, indent=1) + "\n")


@contextmanager
def updating_results(path: str | Path) -> Iterator[dict[str, Any]]:
    """Read, modify and write the results file under an exclusive lock (``<file>.lock``),
    so trainers of different configurations running at once never drop each other's seeds."""
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    with open(f"{path}.lock", "a") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        data = read_results(path)
        yield data
        write_results(path, data)


def network_figures() -> dict[str, Any]:
    """Parameter counts and FLOPs by formula (the trained networks' own counts are in each
    seed record, read off the torch module)."""
    return {
        "layers": list(PAPER_LAYERS),
        "parameters": mlp_parameter_count(PAPER_LAYERS),
        "parameters_paper_printed": 4874,
        "parameters_note": "the paper's formula adds 1 x N_i input biases (2) that a dense "
                           "layer does not have",
        "inference_flops": mlp_inference_flops(PAPER_LAYERS),
        "goal_conditioned_layers": list(GOAL_CONDITIONED_LAYERS),
        "goal_conditioned_parameters": mlp_parameter_count(GOAL_CONDITIONED_LAYERS),
        "goal_conditioned_inference_flops": mlp_inference_flops(GOAL_CONDITIONED_LAYERS),
    }


def _sb3():
    try:
        from cml_edge.baselines import dqn_sb3
    except ImportError as exc:
        raise InputError(f"{EXTRA_HINT} ({exc})") from None
    return dqn_sb3


def _model_path(models: str | Path, run: DQNRun, seed: int) -> Path:
    return Path(models) / run.key / f"seed_{seed}.zip"


# train -----------------------------------------------------------------------------
def train_runs(run: DQNRun, seeds: Sequence[int], results: str | Path = RESULTS_PATH,
               models: str | Path | None = MODELS_DIR, command: str = "",
               progress=None) -> dict[str, Any]:
    """Train every seed of ``seeds`` not yet in ``results``; write after each seed."""
    sb3 = _sb3()
    arena = GridArena.empty(run.arena)
    data = read_results(results)
    entry = data["runs"].setdefault(run.key, {
        "name": run.name, "reward": run.reward, "goal_conditioned": run.goal_conditioned,
        "steps": run.steps, "arena": run.arena, "trials": run.trials,
        "eval_seed": run.eval_seed, "eval_every": run.eval_every, "seeds": {},
        "provenance": []})
    trained, skipped = [], []
    t0 = time.perf_counter()
    for n, seed in enumerate(seeds):
        if str(seed) in entry["seeds"]:
            skipped.append(int(seed))
            continue
        goal, pairs = run_pairs(run, arena, seed)
        path = None if models is None else _model_path(models, run, seed)
        record = sb3.train_seed(run, seed, goal, arena, pairs, summarize, path)
        record["date"] = _provenance("")["date"]
        with updating_results(results) as data:  # keep anything written meanwhile
            entry = data["runs"].setdefault(run.key, entry)
            entry["seeds"][str(seed)] = record
            if not trained:
                entry["provenance"].append(_provenance(command))
        trained.append(int(seed))
        if progress is not None:
            progress(n + 1, len(seeds))
    records = [entry["seeds"][str(s)] for s in seeds]
    out = {"command": "dqn train", "config": run.name, "key": run.key, "reward": run.reward,
           "goal_conditioned": run.goal_conditioned, "steps": run.steps,
           "seeds": len(seeds), "trained": trained, "skipped": skipped,
           "results_file": str(results),
           "parameters": records[0]["parameters"] if records else None,
           "inference_flops": mlp_inference_flops(run.layers),
           "wall_time_s": time.perf_counter() - t0,
           "train_wall_s_mean": float(np.mean([r["train_wall_s"] for r in records])),
           "train_cpu_s_mean": float(np.mean([r["train_cpu_s"] for r in records]))}
    out.update(_pooled_from_records(run, arena, seeds, records))
    plot_results(data, Path(results).with_name("dqn_curves.png"))
    return out


def _pooled_from_records(run: DQNRun, arena: GridArena, seeds: Sequence[int],
                         records: Sequence[dict[str, Any]]) -> dict[str, Any]:
    pairs = [run_pairs(run, arena, s)[1] for s in seeds]
    return pool(pairs, [np.asarray(r["final"]) for r in records],
                [np.asarray(r["final_steps"]) for r in records])


# evaluate --------------------------------------------------------------------------
def cml_on_pairs(seeds: Sequence[int], pairs_of, arena: GridArena, path: str,
                 walks: int = 100, steps: int = 900,
                 curves_from: dict[str, Any] | None = None) -> dict[str, Any]:
    """Train the CML of each seed (the protocol's 100 x 900 random walks, per-walk
    updates, float64; :func:`cml_edge.grid.seed_run.train_and_evaluate`) and plan that
    seed's pairs (``pairs_of(seed)``) at the end. The evaluation curve is the mean e_pos
    on the pairs after every walk (step 0 = untrained); the training time at every point
    excludes the evaluation. With ``curves_from`` (the result of another path on the same
    seeds) the curve is taken from it instead of planned again: the factored and direct
    paths give the same weights to rounding (tests/core/test_paths.py), so only the timing is
    new."""
    from cml_edge.core.cml import CML, CMLConfig
    from cml_edge.grid.planning import plan
    from cml_edge.grid.seed_run import Evaluation, Training, train_and_evaluate
    from cml_edge.grid.training import TrainConfig, train

    training = Training(arena, TrainConfig(walks, steps), CMLConfig.for_arena(arena.size),
                        "float", {}, path, epoch=1)
    warm = CML.create(training.cml_config, "float", 0)  # compile (or load) the kernels untimed
    train(warm, arena, TrainConfig(2, 10), 0, path=path, epoch=1)
    plan(warm, arena, np.array([[0, 0]]), np.array([[1, 1]]), path=path)
    finals, stps, pairs_list, curves, walls, cpus = [], [], [], [], [], []
    for n, seed in enumerate(seeds):
        evaluation = Evaluation(arena, pairs_of(seed))
        run = train_and_evaluate(seed, training, [evaluation],
                                 curve=evaluation if curves_from is None else None,
                                 curve_at_start=True)
        finals.append(run.results[0].final)
        stps.append(run.results[0].steps)
        pairs_list.append(evaluation.pairs)
        curves.append([p["e_pos_mean"] for p in run.curve] if curves_from is None
                      else curves_from["curves_per_seed"][n])
        walls.append(run.wall_s)
        cpus.append(run.cpu_s)
    curve_steps = [w * steps for w in range(walks + 1)]
    return {"path": path, "walks": walks, "steps_per_walk": steps, "explore": "random",
            "seeds": len(seeds), **pool(pairs_list, finals, stps),
            "train_wall_s_mean": float(np.mean([w[-1] for w in walls])),
            "train_cpu_s_mean": float(np.mean([c[-1] for c in cpus])),
            "curve_steps": curve_steps,
            "curve_e_pos_mean": np.mean(curves, axis=0).tolist(),
            "curve_planned_with": path if curves_from is None else curves_from["path"],
            "curves_per_seed": curves,
            "convergence": curve_convergence(curve_steps, curves, walls, cpus)}


def evaluate_runs(run: DQNRun, seeds: Sequence[int], results: str | Path = RESULTS_PATH,
                  command: str = "", with_cml: bool = True) -> dict[str, Any]:
    """Evaluate the trained seeds (from their saved models when present, else from the
    evaluation recorded at the end of training), the CML on the same pairs, and the
    training-time-to-convergence ratio; store the result under ``evaluations``."""
    data = read_results(results)
    entry = data["runs"].get(run.key)
    if entry is None:
        raise InputError(f"no trained DQN {run.key!r} in {str(results)!r}; run "
                         f"'cml-edge dqn train' with the same options first")
    missing = [s for s in seeds if str(s) not in entry["seeds"]]
    if missing:
        raise InputError(f"seeds {missing} of {run.key!r} are not trained yet in "
                         f"{str(results)!r} (trained: {sorted(map(int, entry['seeds']))})")
    arena = GridArena.empty(run.arena)
    records = [entry["seeds"][str(s)] for s in seeds]
    finals, stps, pairs_list, sources = [], [], [], []
    sb3 = None
    for seed, rec in zip(seeds, records):
        _, pairs = run_pairs(run, arena, seed)
        model_file = rec.get("model_file")
        if model_file and Path(model_file).is_file():
            sb3 = sb3 or _sb3()
            final, steps = sb3.rollout(sb3.load_model(model_file), arena, pairs,
                                       run.goal_conditioned)
            sources.append("model")
        else:
            final, steps = np.asarray(rec["final"]), np.asarray(rec["final_steps"])
            sources.append("training record")
        finals.append(final)
        stps.append(steps)
        pairs_list.append(pairs)
    dqn = {"backend": "dqn", "config": run.name, "reward": run.reward,
           "goal_conditioned": run.goal_conditioned, "train_steps": run.steps,
           "seeds": len(seeds), "seed_list": [int(s) for s in seeds],
           **pool(pairs_list, finals, stps), "trials": run.trials,
           "evaluated_from": sorted(set(sources)),
           "parameters": records[0]["parameters"],
           "inference_flops": mlp_inference_flops(run.layers),
           "train_wall_s_mean": float(np.mean([r["train_wall_s"] for r in records])),
           "train_cpu_s_mean": float(np.mean([r["train_cpu_s"] for r in records]))}
    curve_steps = [p["step"] for p in records[0]["curve"]]
    dqn["curve_steps"] = curve_steps
    dqn["curve_e_pos_mean"] = np.mean([[p["e_pos_mean"] for p in r["curve"]]
                                       for r in records], axis=0).tolist()
    dqn["convergence"] = curve_convergence(
        curve_steps, [[p["e_pos_mean"] for p in r["curve"]] for r in records],
        [[p["train_wall_s"] for p in r["curve"]] for r in records],
        [[p["train_cpu_s"] for p in r["curve"]] for r in records])
    out: dict[str, Any] = {**dqn}
    if with_cml:
        def pairs_of(seed: int) -> Pairs:
            return run_pairs(run, arena, seed)[1]

        factored = cml_on_pairs(seeds, pairs_of, arena, "factored")
        cml = {"factored": factored,
               "direct": cml_on_pairs(seeds, pairs_of, arena, "direct", curves_from=factored)}
        out["cml"] = cml
        out["convergence_ratio"] = {
            p: {"wall": _ratio(dqn["convergence"]["wall_s"], c["convergence"]["wall_s"]),
                "cpu": _ratio(dqn["convergence"]["cpu_s"], c["convergence"]["cpu_s"]),
                "steps": _ratio(dqn["convergence"]["step"], c["convergence"]["step"])}
            for p, c in cml.items()}
    out["provenance"] = _provenance(command)
    with updating_results(results) as data:
        data["evaluations"][run.key] = out
    plot_results(data, Path(results).with_name("dqn_curves.png"))
    return out


def _ratio(a: float, b: float) -> float | None:
    return float(a / b) if b > 0 else None


# figure ----------------------------------------------------------------------------
def plot_results(data: dict[str, Any], path: str | Path) -> None:
    """Figure 4A-like PNG: mean episode return and evaluation e_pos against training
    steps (mean and standard deviation over seeds), the CML's e_pos when evaluated."""
    from cml_edge.io.figures import pyplot, save_png

    plt = pyplot()
    fig, (ax_r, ax_e) = plt.subplots(1, 2, figsize=(11, 4))
    for _key, entry in sorted(data["runs"].items()):
        recs = list(entry["seeds"].values())
        if not recs:
            continue
        n = min(len(r["curve"]) for r in recs)
        steps = np.array([p["step"] for p in recs[0]["curve"][:n]])
        label = f"DQN {entry['name']} ({len(recs)} seeds)"
        ret = np.array([[np.nan if p["return_mean"] is None else p["return_mean"]
                         for p in r["curve"][:n]] for r in recs])
        err = np.array([[p["e_pos_mean"] for p in r["curve"][:n]] for r in recs])
        for ax, y in ((ax_r, ret), (ax_e, err)):
            with warnings.catch_warnings():  # no episode ended before a point: NaN
                warnings.simplefilter("ignore", RuntimeWarning)
                m, s = np.nanmean(y, axis=0), np.nanstd(y, axis=0)
            keep = steps > 0 if ax is ax_e else steps >= 0  # log axis: no step 0
            (line,) = ax.plot(steps[keep], m[keep], label=label)
            ax.fill_between(steps[keep], (m - s)[keep], (m + s)[keep], alpha=0.2,
                            color=line.get_color())
    seen = set()
    for ev in data.get("evaluations", {}).values():
        for p, c in ev.get("cml", {}).items():
            if p != "factored" or ev["goal_conditioned"] in seen:
                continue
            seen.add(ev["goal_conditioned"])
            pairs = "protocol pairs" if ev["goal_conditioned"] else "fixed-goal pairs"
            ax_e.plot(c["curve_steps"], c["curve_e_pos_mean"], "--",
                      label=f"CML random walks, {pairs} ({c['seeds']} seeds)")
    ax_r.set_xlabel("training steps")
    ax_r.set_ylabel("mean episode return")
    ax_r.set_title("DQN episode return (Eq. 6 / Eq. 7)")
    ax_e.set_xlabel("training steps")
    ax_e.set_ylabel("mean e_pos on the evaluation pairs (cells)")
    ax_e.set_title("evaluation error (greedy policy / CML plan)")
    ax_e.set_xscale("log")  # the CML converges within ~10^4 steps, the DQN over 10^5
    from matplotlib.ticker import FuncFormatter

    for ax in (ax_r, ax_e):
        ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v / 1000:g}k"))
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    save_png(fig, path)
    plt.close(fig)
