"""Hyper-parameters (the paper's Figure 5): steps per walk and number of walks.

    cml-edge sweep hyperparams

(A) 100 walks of 900, 600, 300 or 100 steps; (B) 900-step walks, 100, 75, 50 or 25 of
them. Random exploration, empty 30 x 30 arena, float64 array, factored path, 10 seeds;
e_pos and path overhead on 100 fixed pairs after every 10 walks and at the end. The
paper reads overfitting into its curves (300-step walks and 50 walks best, a "sweet
spot" near 45 K steps).
"""

from __future__ import annotations

from typing import Any

from cml_edge.engine.sweep import Task
from cml_edge.experiments.common import (
    DEFAULT_SEEDS,
    arena_title,
    eval_spec,
    figure,
    make_tasks,
    mean_curve,
    reject,
    summary_rows,
)
from cml_edge.io.figures import save_png

NAME = "hyperparams"
CLAIM = ("more steps per walk or more walks do not monotonically lower e_pos or the "
         "overhead (300-step walks and 50 walks best; a sweet spot near 45 K steps, Figure 5)")
DIMS = (2, 3)
"""The dimensions it runs in (``cml-edge sweep hyperparams --dims 3``: the N x N x N volume)."""
COLUMNS = ("walks", "steps", "train_steps", "success_rate", "e_pos_mean", "e_pos_median",
           "overhead_mean", "overhead_median")
STEPS = (900, 600, 300, 100)
WALKS = (100, 75, 50, 25)


def tasks(seeds: int = DEFAULT_SEEDS, planner: str | None = None, map: str | None = None,
          scen: str | None = None) -> list[Task]:
    reject(NAME, map=map, scen=scen)
    grid = sorted({(100, s) for s in STEPS} | {(w, 900) for w in WALKS}, reverse=True)
    configs = [(f"walks{w}-steps{s}", {"walks": w, "steps": s, "curve": True, "epoch": 10,
                                       "evals": [eval_spec("final",
                                                           planner=planner or "paper")]})
               for w, s in grid]
    return make_tasks(configs, seeds)


def rows(results: dict[str, dict[str, Any]]) -> list[dict[str, Any]]:
    out = summary_rows(results, ("walks", "steps"))
    for row in out:
        row["train_steps"] = row["walks"] * row["steps"]
    return sorted(out, key=lambda r: (-r["walks"], -r["steps"]))


def plot(rows_: list[dict[str, Any]], results: dict[str, dict[str, Any]], path) -> None:
    plt = figure()
    fig, axes = plt.subplots(2, 2, figsize=(10, 7), sharex="col")
    for col, (label, sel) in enumerate((
            ("100 walks, steps per walk", lambda r: r["walks"] == 100),
            ("900 steps per walk, walks", lambda r: r["steps"] == 900))):
        for row in filter(sel, rows_):
            tag = str(row["steps"] if col == 0 else row["walks"])
            for ax, field in zip(axes[:, col], ("e_pos_mean", "overhead_mean")):
                xs, ys = mean_curve(results, row["config"], field)
                ax.plot(xs, ys, "-o", markersize=3, label=tag)
        axes[0, col].set_title(f"({'AB'[col]}) {label}")
        axes[0, col].set_ylabel("e_pos mean")
        axes[1, col].set_ylabel("path overhead mean (successes)")
        axes[1, col].set_xlabel("training steps")
        axes[0, col].legend(fontsize=8)
    fig.suptitle(f"Hyper-parameters, {arena_title(results)}, random exploration, "
                 f"{rows_[0]['seeds']} seeds (cf. paper Fig. 5)")
    save_png(fig, path)
    plt.close(fig)

