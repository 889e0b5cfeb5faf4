"""The CML choices the paper leaves open, measured on the paper's protocol.

    cml-edge sweep choices

Each configuration changes one choice of :mod:`cml_edge.core.cml` against the defaults:
the observation frame (centred vs corner origin), the W_q initialisation scale, and the
planning utility (column-normalised vs raw), for both exploration strategies. Float64
array, factored path, 10 seeds x 100 pairs on the empty 30 x 30 arena, evaluation seed
123.
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
    reject,
    summary_rows,
)
from cml_edge.io.figures import save_png

NAME = "choices"
CLAIM = ("(not in the paper) each choice it leaves open, against its alternative: the "
         "centred frame, W_q ~ N(0, 1/256) and the normalised utility reach every goal")
DIMS = (2, 3)
"""The dimensions it runs in (``cml-edge sweep choices --dims 3``: the N x N x N volume)."""
COLUMNS = ("variant", "explore", "success_rate", "e_pos_mean", "overhead_mean",
           "overhead_median")
VARIANTS: dict[str, tuple[str, dict[str, Any]]] = {
    "defaults": ("defaults (centred frame, W_q ~ N(0, 1/256), normalised utility)", {}),
    "corner": ("corner frame: o = p / 30", {"obs_origin": 0.0}),
    "wq1": ("W_q ~ N(0, 1)", {"init_std_q": 1.0}),
    "corner-wq1": ("corner frame and W_q ~ N(0, 1)", {"obs_origin": 0.0, "init_std_q": 1.0}),
    "raw": ("raw utility", {"utility": "raw"}),
}
"""Configuration id -> (what it changes, the CML config fields it sets)."""


def tasks(seeds: int = DEFAULT_SEEDS, planner: str | None = None, map: str | None = None,
          scen: str | None = None) -> list[Task]:
    reject(NAME, planner=planner, map=map, scen=scen)
    configs = [(f"{cid}-{explore}", {"explore": explore, "path": "factored",
                                     "cml_options": options,
                                     "evals": [eval_spec("arena30")]})
               for cid, (_, options) in VARIANTS.items() for explore in ("random", "mixed")]
    return make_tasks(configs, seeds)


def rows(results: dict[str, dict[str, Any]]) -> list[dict[str, Any]]:
    out = summary_rows(results, ("explore",))
    for row in out:
        row["variant"] = VARIANTS[row["config"].rsplit("-", 1)[0]][0]
    return out


def plot(rows_: list[dict[str, Any]], results: dict[str, dict[str, Any]], path) -> None:
    plt = figure()
    fig, axes = plt.subplots(1, 2, figsize=(10, 4))
    names = list(VARIANTS)
    for j, explore in enumerate(("random", "mixed")):
        sel = {r["config"].rsplit("-", 1)[0]: r for r in rows_ if r["explore"] == explore}
        xs = [i + 0.4 * j for i in range(len(names))]
        axes[0].bar(xs, [sel[n]["success_rate"] for n in names], 0.4, label=explore)
        axes[1].bar(xs, [sel[n]["overhead_mean"] or 0.0 for n in names], 0.4, label=explore)
    for ax, label in zip(axes, ("success rate", "path overhead mean (successes)")):
        ax.set_xticks([i + 0.2 for i in range(len(names))], names, rotation=20, ha="right")
        ax.set_ylabel(label)
        ax.legend(fontsize=8)
    fig.suptitle(f"Choices the paper leaves open, {arena_title(results)}, "
                 f"{rows_[0]['seeds']} seeds x 100 pairs")
    save_png(fig, path)
    plt.close(fig)
