"""Exploration strategies (the paper's Figure 6): random walks against mixed novelty.

    cml-edge sweep exploration

100 walks x 900 steps, random or mixed (Eqs. 4-5), empty 30 x 30 arena (or the map of
``--map``, trained in the empty arena of its size), float64 array, factored path,
10 seeds x 100 pairs; also a short training (100 walks x 100 steps), where the float
models are not yet perfect and the strategies can differ at all. The paper: similar
e_pos, mixed slightly better; mixed shortens the paths (lower overhead).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from cml_edge.engine.sweep import Task
from cml_edge.errors import InputError
from cml_edge.experiments.common import (
    DEFAULT_SEEDS,
    eval_spec,
    figure,
    make_tasks,
    summary_rows,
)
from cml_edge.grid.maps import load_map, resolve_map
from cml_edge.io.figures import save_png

# the paper's training, and a short one (100 x 100 steps) where the float models are
# still imperfect, so that the strategies can differ at all
TRAININGS = {"paper": (100, 900), "short": (100, 100)}
NAME = "exploration"
CLAIM = "mixed exploration shortens the paths (lower overhead) at similar e_pos (Figure 6)"
DIMS = (2, 3)
"""The dimensions it runs in (``cml-edge sweep exploration --dims 3``: the N x N x N volume)."""
COLUMNS = ("walks", "steps", "explore", "eval", "success_rate", "e_pos_mean", "e_pos_median",
           "overhead_mean", "overhead_median", "overhead_geodesic_mean")


def tasks(seeds: int = DEFAULT_SEEDS, planner: str | None = None, map: str | None = None,
          scen: str | None = None) -> list[Task]:
    if scen and not map:
        raise InputError("--scen needs --map")
    arena = 30
    spec = eval_spec("arena30", planner=planner or "paper")
    if map:
        arena = load_map(resolve_map(map)).side
        spec = eval_spec(f"map-{resolve_map(map).stem}", map=str(resolve_map(map)), scen=scen,
                         planner=planner or "paper")
    configs = [(f"{t}-{e}", {"explore": e, "arena": arena, "walks": w, "steps": st,
                             "evals": [spec]})
               for t, (w, st) in TRAININGS.items() for e in ("random", "mixed")]
    return make_tasks(configs, seeds)


def rows(results: dict[str, dict[str, Any]]) -> list[dict[str, Any]]:
    return summary_rows(results, ("explore", "walks", "steps"))


def per_trial(results: dict[str, dict[str, Any]], cid: str, eval_name: str, field: str):
    """Per-trial e_pos, or overhead over successful trials, pooled over seeds."""
    vals = []
    for key, res in results.items():
        if not key.startswith(cid + "-s"):
            continue
        for ev in res["evals"]:
            if ev["name"] != eval_name:
                continue
            final, goals = np.asarray(ev["final"]), np.asarray(ev["goals"])
            err = np.linalg.norm(final - goals, axis=1)
            if field == "e_pos":
                vals.extend(err.tolist())
            else:
                ok = err == 0
                vals.extend((np.asarray(ev["steps"])[ok] / np.asarray(ev["chebyshev"])[ok])
                            .tolist())
    return vals


def plot(rows_: list[dict[str, Any]], results: dict[str, dict[str, Any]], path) -> None:
    plt = figure()
    fig, axes = plt.subplots(1, 2, figsize=(8, 3.6))
    labels = [f"{r['explore']}\n{r['walks']}x{r['steps']}" for r in rows_]
    for ax, field, title in zip(axes, ("e_pos", "overhead"),
                                ("final position error e_pos", "path overhead (successes)")):
        data = [per_trial(results, r["config"], r["eval"], field) or [np.nan] for r in rows_]
        ax.boxplot(data, showmeans=True)
        ax.set_xticks(range(1, len(labels) + 1), labels)
        ax.set_title(title)
    fig.suptitle(f"Exploration, {rows_[0]['eval']}, {rows_[0]['seeds']} seeds x "
                 f"{rows_[0]['trials'] // max(rows_[0]['seeds'], 1)} pairs (cf. paper Fig. 6)")
    save_png(fig, path)
    plt.close(fig)

