"""Generalisation to larger arenas (the paper's Figure 7).

    cml-edge sweep generalization

Trained on the empty 30 x 30 arena (random or mixed, 10 seeds, float64, factored path),
evaluated on 100 fixed pairs of the empty 30 x 30, 60 x 60 and 120 x 120 arenas. The
observation frame stays the training one (o = (p - 14.5) / 30, so |o| reaches 3.5 on
120 x 120). Step budget: :func:`cml_edge.grid.maps.step_budget`, 100 x side / 30 actions
(100, 200, 400), so the longest pair stays within reach. The paper: mixed generalises
better (lower median e_pos and overhead on the larger arenas). Also with the short
training of :mod:`cml_edge.experiments.exploration` (100 walks x 100 steps).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from cml_edge.engine.sweep import Task
from cml_edge.experiments.common import (
    DEFAULT_SEEDS,
    arena_title,
    eval_spec,
    figure,
    make_tasks,
    reject,
    summary_rows,
)
from cml_edge.experiments.exploration import TRAININGS, per_trial
from cml_edge.io.figures import save_png

NAME = "generalization"
CLAIM = ("models trained with mixed exploration generalise better to 60 x 60 and 120 x 120 "
         "(lower median e_pos and path overhead, Figure 7)")
DIMS = (2, 3)
"""The dimensions it runs in (``cml-edge sweep generalization --dims 3``: the N x N x N volume)."""
COLUMNS = ("walks", "steps", "explore", "eval_arena", "max_steps", "success_rate",
           "e_pos_mean", "e_pos_median", "overhead_mean", "overhead_median")
SIZES = (30, 60, 120)


def tasks(seeds: int = DEFAULT_SEEDS, planner: str | None = None, map: str | None = None,
          scen: str | None = None) -> list[Task]:
    reject(NAME, map=map, scen=scen)
    evals = [eval_spec(f"arena{n}", size=n, planner=planner or "paper") for n in SIZES]
    configs = [(f"{t}-{e}", {"explore": e, "walks": w, "steps": st, "evals": evals})
               for t, (w, st) in TRAININGS.items() for e in ("random", "mixed")]
    return make_tasks(configs, seeds)


def rows(results: dict[str, dict[str, Any]]) -> list[dict[str, Any]]:
    return sorted(summary_rows(results, ("explore", "walks", "steps")),
                  key=lambda r: (-r["steps"], r["eval_arena"], r["explore"] != "random"))


def plot(rows_: list[dict[str, Any]], results: dict[str, dict[str, Any]], path) -> None:
    plt = figure()
    trainings = sorted({(r["walks"], r["steps"]) for r in rows_}, key=lambda t: -t[1])
    fig, axes = plt.subplots(len(trainings), 2, figsize=(10, 3.8 * len(trainings)),
                             squeeze=False)
    for ax, field, title, (walks, steps) in (
            (axes[i, j], f, f"{t} ({w} walks x {s} steps)", (w, s))
            for i, (w, s) in enumerate(trainings)
            for j, (f, t) in enumerate((("e_pos", "final position error e_pos"),
                                        ("overhead", "path overhead (successes)")))):
        data, labels, colors = [], [], []
        for row in (r for r in rows_ if (r["walks"], r["steps"]) == (walks, steps)):
            data.append(per_trial(results, row["config"], row["eval"], field) or [np.nan])
            labels.append(f"{row['eval_arena']}\n{row['explore']}")
            colors.append("tab:blue" if row["explore"] == "random" else "tab:orange")
        parts = ax.boxplot(data, showmeans=True, patch_artist=True)
        for patch, c in zip(parts["boxes"], colors):
            patch.set_facecolor(c)
            patch.set_alpha(0.4)
        ax.set_xticks(range(1, len(labels) + 1), labels, fontsize=8)
        ax.set_title(title)
        if field == "e_pos":
            ax.set_yscale("symlog", linthresh=1.0)
    fig.suptitle(f"Trained on {arena_title(results)}, evaluated on larger arenas, "
                 f"{rows_[0]['seeds']} seeds (cf. paper Fig. 7)")
    save_png(fig, path)
    plt.close(fig)

