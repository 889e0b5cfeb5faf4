"""Conductance levels on the noise-free crossbar: success against every level count.

    cml-edge sweep levels

The ``ideal`` preset (no noise; a pair's difference quantised to ``levels`` - 1 whole
levels each way, ``pair_grid`` pair) at every level count from 16 to 128, and at 256,
1,024 and a continuous conductance (levels 0) for reference; ten CMLs each, trained as
the paper's protocol trains them (empty 30 x 30 arena, random walks, direct compiled
path) and evaluated on its 100 fixed pairs (paper planner). Beside it, the same levels
with W_v's range where its learned weights live (``w_max_v`` 0.02, as the device presets
set it) instead of four times its initial weights' largest.

What it shows (docs/devices/crossbar.md, "Levels on the noise-free preset"): on
``ideal``, W_v's range is 4 max|W_v(0)| (about 1.4) while the learned W_v entries are
about 0.002, so below about a thousand levels one level is larger than a typical
learned entry. W_v then holds a few entries at +-1 level, left there by the
digital accumulator's remainder (a commit moves whole levels), and which few differ from
seed to seed: success rises with the levels, and between neighbouring counts it moves by
the spread of that draw over the seeds, not by the count.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from cml_edge.engine.sweep import Task
from cml_edge.experiments.common import (
    DEFAULT_SEEDS,
    arena_title,
    config_id,
    eval_spec,
    figure,
    make_tasks,
    reject,
    summary_rows,
)
from cml_edge.io.figures import save_png

NAME = "levels"
CLAIM = ("(not in the paper) on the noise-free crossbar, success follows the number of "
         "conductance levels, within the spread over seeds")
DIMS = (2, 3)
"""The dimensions it runs in (``cml-edge sweep levels --dims 3``: the N x N x N volume)."""
COLUMNS = ("series", "levels", "success_rate", "success_seed_std", "success_seed_min",
           "overhead_mean")
LEVELS = (*range(16, 129), 256, 1024, 0)
"""Every count from 16 to 128, then two larger ones and a continuous conductance (0)."""
SERIES = {"ideal": {}, "w_max_v": {"w_max_v": 0.02}}
"""The preset as it is, and with W_v's range where its learned weights live."""
SERIES_LEVELS = {"ideal": LEVELS, "w_max_v": (16, 24, 32, 48, 64, 96, 128, 256, 0)}


def tasks(seeds: int = DEFAULT_SEEDS, planner: str | None = None, map: str | None = None,
          scen: str | None = None, series: tuple[str, ...] = tuple(SERIES),
          levels: tuple[int, ...] | None = None) -> list[Task]:
    """The (series x levels x seed) grid; ``levels`` replaces each series' own counts."""
    reject(NAME, map=map, scen=scen)
    evals = [eval_spec("arena30", planner=planner or "paper")]
    configs = [(f"{name}-L{count}",
                {"backend": "crossbar", "evals": evals,
                 "backend_options": {"preset": "ideal", "levels": count, **SERIES[name]}})
               for name in series for count in (levels or SERIES_LEVELS[name])]
    return make_tasks(configs, seeds)


def rows(results: dict[str, dict[str, Any]]) -> list[dict[str, Any]]:
    """The pooled rows, each with its series, its levels and the spread of the seeds'
    own success rates (standard deviation, lowest)."""
    per_seed: dict[str, list[float]] = {}
    for key, res in results.items():
        per_seed.setdefault(config_id(key), []).append(res["evals"][0]["success_rate"])
    out = []
    for row in summary_rows(results, ()):
        name, count = row["config"].rsplit("-L", 1)
        seeds = np.array(per_seed[row["config"]])
        out.append({"series": name, "levels": int(count), **row,
                    "success_seed_std": float(seeds.std(ddof=1)) if seeds.size > 1 else 0.0,
                    "success_seed_min": float(seeds.min())})
    return sorted(out, key=lambda r: (r["series"], r["levels"] or 1 << 30))


def plot(rows_: list[dict[str, Any]], results: dict[str, dict[str, Any]], path) -> None:
    plt = figure()
    fig, ax = plt.subplots(figsize=(9, 4))
    for name, colour in zip(SERIES, ("C0", "C1")):
        sel = [r for r in rows_ if r["series"] == name and r["levels"]]
        if not sel:
            continue
        x = np.array([r["levels"] for r in sel])
        m = np.array([r["success_rate"] for r in sel])
        se = np.array([r["success_seed_std"] / np.sqrt(r["seeds"]) for r in sel])
        label = "ideal" if name == "ideal" else "ideal, w_max_v 0.02"
        ax.plot(x, m, "-o", color=colour, markersize=2.5, lw=1, label=label)
        ax.fill_between(x, np.clip(m - 2 * se, 0, 1), np.clip(m + 2 * se, 0, 1), color=colour,
                        alpha=0.2, lw=0)
        cont = [r for r in rows_ if r["series"] == name and not r["levels"]]
        if cont:
            ax.axhline(cont[0]["success_rate"], color=colour, ls=":", lw=1)
    ax.set_xscale("log", base=2)
    ax.set_xlabel("conductance levels (dotted: continuous)")
    ax.set_ylabel("success rate (band: 2 standard errors over seeds)")
    ax.set_ylim(0, 1.05)
    ax.legend(fontsize=8, loc="lower right")
    ax.set_title(f"Noise-free crossbar, {arena_title(results)}, {rows_[0]['seeds']} seeds "
                 "x 100 pairs")
    save_png(fig, path)
    plt.close(fig)
