"""MovingAI-format maps: the paper's planner against the escape planner.

    cml-edge sweep maps                   # the shipped maps (rooms, utrap, maze)
    cml-edge sweep maps --map FILE.map --scen FILE.map.scen

For each map, ten CMLs are trained in the empty arena of the map's size (mapless: the
map is never seen in training; random exploration, float64, factored path) and plan
the map's scenarios (or 100 pairs from the evaluation seed without ``--scen``) with
both planners. Step budget: :func:`cml_edge.grid.maps.step_budget` (107 on a 32 x 32 map).
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
from cml_edge.grid.maps import load_map, resolve_map, shipped_maps, shipped_path
from cml_edge.grid.planning import PLANNERS
from cml_edge.io.figures import save_png

NAME = "maps"
CLAIM = ("(past the paper) a purely greedy local planner fails most pairs that need a "
         "detour (rooms with doors, a U-trap); the escape planner reaches them")
DIMS = (2,)
PLANE_ONLY = (" (its maps are MovingAI plane maps; a voxel map in 3-D: cml-edge emulate --dims 3 "
              "--map NAME, or cml-edge scenario maps --dims 3)")
COLUMNS = ("map", "planner", "max_steps", "connected_pairs", "success_rate_connected",
           "e_pos_mean", "overhead_geodesic_mean")


def tasks(seeds: int = DEFAULT_SEEDS, planner: str | None = None, map: str | None = None,
          scen: str | None = None) -> list[Task]:
    if scen and not map:
        raise InputError("--scen needs --map")
    planners = (planner,) if planner else PLANNERS
    if map:
        files = [(str(resolve_map(map)), scen)]
    else:
        files = [(str(shipped_path(n)), str(shipped_path(n, ".map.scen"))) for n in shipped_maps()]
    configs = []
    for mfile, sfile in files:
        grid = load_map(mfile)
        name = grid.name.removesuffix(".map")
        evals = [eval_spec(f"{name}-{p}", map=mfile, scen=sfile, planner=p) for p in planners]
        configs.append((f"map-{name}", {"arena": grid.side, "explore": "random",
                                        "evals": evals}))
    return make_tasks(configs, seeds)


def rows(results: dict[str, dict[str, Any]]) -> list[dict[str, Any]]:
    out = summary_rows(results, ())
    for row in out:
        row["map"] = row["config"].removeprefix("map-")
    return sorted(out, key=lambda r: (r["map"], r["planner"] != "paper"))


def plot(rows_: list[dict[str, Any]], results: dict[str, dict[str, Any]], path) -> None:
    from cml_edge.core.cml import CML, CMLConfig
    from cml_edge.grid.arena import GridArena
    from cml_edge.grid.condition import Condition
    from cml_edge.grid.planning import plan
    from cml_edge.grid.training import TrainConfig, train

    maps = sorted({r["map"] for r in rows_})
    plt = figure()
    fig, axes = plt.subplots(1, len(maps), figsize=(5 * len(maps), 5.2), squeeze=False)
    for ax, name in zip(axes[0], maps):
        key = next(k for k in results if k.startswith(f"map-{name}-s"))
        specs = {ev["planner"]: ev for ev in results[key]["evals"]}
        spec = next(iter(specs.values()))
        ev = Condition.within(spec).evaluation(0)
        arena, pairs, budget = ev.arena, ev.pairs, ev.max_steps
        cml = CML.create(CMLConfig.for_arena(arena.size), "float", 0)
        train(cml, GridArena.empty(arena.size), TrainConfig(), 0, path="factored")
        res = {p: plan(cml, arena, pairs.starts, pairs.goals, max_steps=budget,
                       path="factored", planner=p) for p in specs}
        ok = {p: (r.final == pairs.goals).all(1) for p, r in res.items()}
        cand = np.flatnonzero(~ok.get("paper", ok[next(iter(ok))]) & ok.get("escape", True))
        i = int(cand[0]) if len(cand) else 0
        ox, oy = np.nonzero(arena.blocked)
        ax.scatter(ox, oy, marker="s", s=12, color="0.3")
        for p, color in (("paper", "tab:red"), ("escape", "tab:blue")):
            if p in res:
                tr = res[p].paths[i, : res[p].steps[i] + 1]
                ax.plot(tr[:, 0], tr[:, 1], "-", color=color, lw=4 if p == "paper" else 1.5,
                        alpha=0.5 if p == "paper" else 1.0,
                        label=f"{p}: {res[p].steps[i]} steps, "
                              f"{'reached' if ok[p][i] else 'failed'}")
        ax.plot(*pairs.starts[i], "x", color="k", ms=10, mew=2)
        ax.plot(*pairs.goals[i], "*", color="tab:green", ms=14)
        ax.set_xlim(-0.5, arena.size - 0.5)
        ax.set_ylim(arena.size - 0.5, -0.5)  # MovingAI rows run downwards
        ax.set_aspect("equal")
        line = ", ".join(f"{r['planner']} {r['success_rate_connected']:.2f}"
                         for r in rows_ if r["map"] == name)
        ax.set_title(f"{name}: success {line}", fontsize=9)
        ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(0, -0.02))
    fig.suptitle(f"Maps (trained mapless, {rows_[0]['seeds']} seeds); seed-0 example pair")
    save_png(fig, path)
    plt.close(fig)

