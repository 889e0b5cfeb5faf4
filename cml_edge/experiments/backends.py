"""The protocol across every registered synaptic array (and every crossbar preset).

    cml-edge sweep backends

For each configuration of :func:`cml_edge.backends.configurations` (each registered
backend name, each preset of a backend that takes one): ten CMLs trained on the empty
30 x 30 arena on that array, direct compiled path (float64 uses the factored path, which
is exact for it), random exploration, evaluated on 100 fixed pairs of the empty arena
(paper planner, or ``--planner``) and with 300 obstacles (escape planner). New arrays are
picked up as they register.
"""

from __future__ import annotations

from typing import Any

from cml_edge.backends import configurations
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

NAME = "backends"
CLAIM = "(not in the paper) the same protocol on every emulated synaptic array"
DIMS = (2, 3)
"""The dimensions it runs in (``cml-edge sweep backends --dims 3``: the N x N x N volume)."""
COLUMNS = ("config", "eval", "success_rate", "success_rate_connected", "e_pos_mean",
           "overhead_mean", "overhead_geodesic_mean")


def tasks(seeds: int = DEFAULT_SEEDS, planner: str | None = None, map: str | None = None,
          scen: str | None = None) -> list[Task]:
    reject(NAME, map=map, scen=scen)
    evals = [eval_spec("arena30", planner=planner or "paper"),
             eval_spec("obst300-escape", obstacles=300, planner="escape")]
    configs = [(cid, {"backend": name, "backend_options": opts, "evals": evals})
               for cid, name, opts in configurations()]
    return make_tasks(configs, seeds)


def rows(results: dict[str, dict[str, Any]]) -> list[dict[str, Any]]:
    return summary_rows(results, ("backend",))


def plot(rows_: list[dict[str, Any]], results: dict[str, dict[str, Any]], path) -> None:
    plt = figure()
    fig, ax = plt.subplots(figsize=(max(6, 1.1 * len(rows_) / 2 + 3), 4))
    cids = list(dict.fromkeys(r["config"] for r in rows_))
    evals = list(dict.fromkeys(r["eval"] for r in rows_))
    width = 0.8 / len(evals)
    for j, ev in enumerate(evals):
        vals = [next((r["success_rate_connected"] for r in rows_
                      if r["config"] == c and r["eval"] == ev), 0) for c in cids]
        ax.bar([i + j * width for i in range(len(cids))], vals, width, label=ev)
    ax.set_xticks([i + 0.4 - width / 2 for i in range(len(cids))], cids, rotation=30,
                  ha="right", fontsize=8)
    ax.set_ylabel("success over connected pairs")
    ax.set_ylim(0, 1.05)
    ax.legend(fontsize=8)
    ax.set_title(f"Synaptic arrays, {arena_title(results)}, {rows_[0]['seeds']} seeds x 100 pairs")
    save_png(fig, path)
    plt.close(fig)

