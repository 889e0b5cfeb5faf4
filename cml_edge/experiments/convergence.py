"""Convergence (the paper's Figure 4B): training error and evaluation e_pos against steps.

    cml-edge sweep convergence

Ten seeds per exploration strategy, 100 walks x 900 steps on the empty 30 x 30 arena
(float64 array, factored path); every 2 walks (1,800 steps) the model plans 100 fixed
pairs on the training arena. The paper: the training error keeps falling after 90 K
steps while e_pos converges after about 20 K steps.
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
    mean_curve,
    reject,
    summary_rows,
)
from cml_edge.io.figures import save_png

NAME = "convergence"
CLAIM = ("training error keeps decreasing after 90 K steps; the planning error e_pos "
         "converges after about 20 K steps (Figure 4B)")
DIMS = (2, 3)
"""The dimensions it runs in (``cml-edge sweep convergence --dims 3``: the N x N x N volume)."""
COLUMNS = ("explore", "e_pos_at_9k", "e_pos_at_18k", "e_pos_at_27k", "e_pos_at_45k",
           "e_pos_mean", "success_rate", "train_error_first", "train_error_last")
EPOCH = 2


def tasks(seeds: int = DEFAULT_SEEDS, planner: str | None = None, map: str | None = None,
          scen: str | None = None) -> list[Task]:
    reject(NAME, map=map, scen=scen)
    configs = [(f"explore-{e}", {"explore": e, "curve": True, "epoch": EPOCH,
                                 "evals": [eval_spec("final", planner=planner or "paper")]})
               for e in ("random", "mixed")]
    return make_tasks(configs, seeds)


def rows(results: dict[str, dict[str, Any]]) -> list[dict[str, Any]]:
    out = []
    for row in summary_rows(results, ("explore",)):
        xs, ys = mean_curve(results, row["config"], "e_pos_mean")
        errs = np.mean([r["train_error"] for k, r in results.items()
                        if k.startswith(row["config"] + "-s")], axis=0)
        at = dict(zip(xs, ys))
        row.update({f"e_pos_at_{s // 1000}k": at.get(s) for s in (9000, 18000, 27000, 45000)})
        row["train_error_first"] = float(errs[0])
        row["train_error_last"] = float(errs[-1])
        out.append(row)
    return out


def plot(rows_: list[dict[str, Any]], results: dict[str, dict[str, Any]], path) -> None:
    plt = figure()
    fig, ax = plt.subplots(figsize=(6.5, 4))
    ax2 = ax.twinx()
    for row, color in zip(rows_, ("tab:green", "tab:purple")):
        cid = row["config"]
        errs = [r["train_error"] for k, r in results.items() if k.startswith(cid + "-s")]
        steps = 900 * (np.arange(len(errs[0])) + 1)
        m, sd = np.mean(errs, 0), np.std(errs, 0)
        ax.plot(steps, m, color=color, alpha=0.5, label=f"training error ({row['explore']})")
        ax.fill_between(steps, m - sd, m + sd, color=color, alpha=0.15)
        xs, ys = mean_curve(results, cid, "e_pos_mean")
        ax2.plot(xs, ys, "-o", color=color, markersize=3,
                 label=f"evaluation e_pos ({row['explore']})")
    ax.set_xlabel("training steps")
    ax.set_ylabel("training error ||e_t|| (mean per walk)")
    ax2.set_ylabel("evaluation e_pos mean (grid cells)")
    ax.set_title(f"Convergence, {arena_title(results)}, {rows_[0]['seeds']} seeds "
                 "(cf. paper Fig. 4B)")
    h1, l1 = ax.get_legend_handles_labels()
    h2, l2 = ax2.get_legend_handles_labels()
    ax2.legend(h1 + h2, l1 + l2, fontsize=7, loc="upper right")
    save_png(fig, path)
    plt.close(fig)

