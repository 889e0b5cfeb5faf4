"""Obstacles unseen in training (the paper's Figure 8), paper planner against escape.

    cml-edge sweep obstacles

Ten CMLs trained on the empty 30 x 30 arena (random exploration, float64, factored
path) plan 100 fixed pairs with 0, 100, 200, 300 and 400 point obstacles placed from
the evaluation seed at evaluation only, with the paper's planner and with the escape
planner (:mod:`cml_edge.grid.planning`), 100 actions each. Success is counted over the
pairs that are connected at all (BFS); path length is reported against the geodesic.
The paper: fine at 100-200 obstacles, the planner halts in front of clusters at
300-400.
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
from cml_edge.grid.planning import PLANNERS
from cml_edge.io.figures import save_png
from cml_edge.protocol import EVAL_SEED

NAME = "obstacles"
CLAIM = ("the paper's planner navigates 100-200 obstacles but degrades at 300-400, halting "
         "in front of obstacle clusters (Figure 8)")
DIMS = (2, 3)
"""The dimensions it runs in (``cml-edge sweep obstacles --dims 3``: the N x N x N volume)."""
COLUMNS = ("planner", "obstacles", "connected_pairs", "success_rate", "success_rate_connected",
           "e_pos_mean", "overhead_geodesic_mean")
OBSTACLES = (0, 100, 200, 300, 400)


def tasks(seeds: int = DEFAULT_SEEDS, planner: str | None = None, map: str | None = None,
          scen: str | None = None) -> list[Task]:
    reject(NAME, map=map, scen=scen)
    planners = (planner,) if planner else PLANNERS
    evals = [eval_spec(f"{p}-obst{n}", obstacles=n, planner=p, max_steps=100)
             for p in planners for n in OBSTACLES]
    return make_tasks([("random", {"explore": "random", "evals": evals})], seeds)


def rows(results: dict[str, dict[str, Any]]) -> list[dict[str, Any]]:
    return sorted(summary_rows(results, ()), key=lambda r: (r["planner"], r["obstacles"]))


def plot(rows_: list[dict[str, Any]], results: dict[str, dict[str, Any]], path) -> None:
    plt = figure()
    fig, axes = plt.subplots(1, 4, figsize=(17, 4))
    for planner, color in (("paper", "tab:red"), ("escape", "tab:blue")):
        sel = [r for r in rows_ if r["planner"] == planner]
        if not sel:
            continue
        x = [r["obstacles"] for r in sel]
        axes[0].plot(x, [r["e_pos_mean"] for r in sel], "-o", color=color, label=planner)
        axes[1].plot(x, [r["success_rate_connected"] for r in sel], "-o", color=color,
                     label=planner)
        axes[2].plot(x, [r["overhead_geodesic_mean"] for r in sel], "-o", color=color,
                     label=planner)
    axes[0].set_title("(A) e_pos mean")
    axes[1].set_title("success over connected pairs")
    axes[2].set_title("steps / geodesic (successes)")
    for ax in axes[:3]:
        ax.set_xlabel(f"point obstacles ({arena_title(results)})")
        ax.legend(fontsize=8)
    if all(r.get("dims", 2) == 2 for r in results.values()):  # a path drawn on the plane
        _example(axes[3])
    fig.suptitle(f"Obstacles placed at evaluation only, {rows_[0]['seeds']} seeds x 100 pairs "
                 "(cf. paper Fig. 8)", y=1.04)
    save_png(fig, path)
    plt.close(fig)


def _example(ax) -> None:
    """Seed 0 at 400 obstacles: the first pair the paper's planner fails, both paths."""
    from cml_edge.core.cml import CML, CMLConfig
    from cml_edge.grid.arena import GridArena
    from cml_edge.grid.metrics import draw_pairs
    from cml_edge.grid.planning import plan
    from cml_edge.grid.training import TrainConfig, train

    arena = GridArena.with_obstacles(30, 400, EVAL_SEED)
    pairs = draw_pairs(arena, 100, EVAL_SEED)
    cml = CML.create(CMLConfig.for_arena(30), "float", 0)
    train(cml, GridArena.empty(30), TrainConfig(), 0, path="factored")
    res = {p: plan(cml, arena, pairs.starts, pairs.goals, path="factored", planner=p)
           for p in PLANNERS}
    ok = {p: (r.final == pairs.goals).all(1) for p, r in res.items()}
    cand = np.flatnonzero(~ok["paper"] & ok["escape"])
    if not len(cand):
        return
    i = int(cand[0])
    ox, oy = np.nonzero(arena.blocked)
    ax.scatter(ox, oy, marker="s", s=14, color="0.3")
    for p, color in (("paper", "tab:red"), ("escape", "tab:blue")):
        tr = res[p].paths[i, : res[p].steps[i] + 1]
        ax.plot(tr[:, 0], tr[:, 1], "-", color=color, lw=4 if p == "paper" else 1.5,
                alpha=0.5 if p == "paper" else 1.0,
                label=f"{p}: {res[p].steps[i]} steps, {'reached' if ok[p][i] else 'halted'}")
    ax.plot(*pairs.starts[i], "x", color="k", ms=10, mew=2)
    ax.plot(*pairs.goals[i], "*", color="tab:green", ms=14)
    ax.set_xlim(-0.5, 29.5)
    ax.set_ylim(-0.5, 29.5)
    ax.set_aspect("equal")
    ax.set_title("400 obstacles, seed 0: a pair the paper's planner fails")
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(0, -0.08))

