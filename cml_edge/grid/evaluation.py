"""The evaluation protocol of DESIGN.md, made exact: train seeds, plan fixed pairs, pool.

For each model seed: a fresh CML on the chosen backend is trained on the empty arena
(evaluated on the empty arena every ``epoch`` walks, for the convergence curve of
Figure 4B), then evaluated once on the evaluation arena (with obstacles if asked,
placed from the evaluation seed). Pairs come from the evaluation seed, so every
method and backend sees the same pairs. Pooled metrics are over all seeds x trials.
``idle_s`` seconds pass between the end of training and the evaluation (each array's
``elapse``: drift on a crossbar, nothing on a digital array).

The evaluation arena may differ from the training arena: a larger empty arena
(``eval_size``, the generalisation experiment of Figure 7) or a map
(``eval_arena``, e.g. :meth:`cml_edge.maps.GridMap.arena`) of the training size, with
its own pairs (``pairs``, e.g. a MovingAI scenario file). The CML never sees either
while training: it is trained in the empty arena of ``arena_size``. ``planner`` and
``max_steps`` choose the planner and its step budget (:mod:`cml_edge.grid.planning`).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from cml_edge.core.cml import CML, CMLConfig
from cml_edge.errors import InputError
from cml_edge.grid.arena import GridArena
from cml_edge.grid.metrics import Pairs, draw_pairs, e_pos, summarize
from cml_edge.grid.planning import MAX_STEPS, PLANNERS, plan
from cml_edge.grid.training import TrainConfig, train
from cml_edge.protocol import EVAL_SEED


def evaluate_model(cml: CML, arena: GridArena, pairs: Pairs, path: str = "direct",
                   max_steps: int = MAX_STEPS, planner: str = "paper") -> dict[str, Any]:
    """Plan every pair and summarise (Eqs. 8, 9)."""
    res = plan(cml, arena, pairs.starts, pairs.goals, max_steps=max_steps, path=path,
               planner=planner)
    return summarize(res.final, res.steps, pairs)


def pool_pairs(pairs: Pairs, times: int) -> Pairs:
    """``pairs`` repeated ``times`` times (pooling the trials of several models)."""
    return Pairs(*(np.concatenate([a] * times) for a in
                   (pairs.starts, pairs.goals, pairs.chebyshev, pairs.geodesic)))


def run_protocol(backend: str = "float", seeds: Sequence[int] = range(10), trials: int = 100,
                 arena_size: int = 30, obstacles: int = 0,
                 train_config: TrainConfig | None = None, cml_config: CMLConfig | None = None,
                 eval_seed: int = EVAL_SEED, path: str = "direct", epoch: int = 10,
                 idle_s: float = 0.0,
                 progress: Callable[[int, int], None] | None = None,
                 planner: str = "paper", max_steps: int = MAX_STEPS,
                 eval_size: int | None = None, eval_arena: GridArena | None = None,
                 pairs: Pairs | None = None,
                 **backend_options: Any) -> dict[str, Any]:
    """Train and evaluate one model per seed; the JSON-ready result of ``emulate``.

    Obstacles (``obstacles`` > 0) are placed from ``eval_seed`` on the evaluation arena:
    the empty arena of ``eval_size`` (default ``arena_size``), or ``eval_arena``.
    """
    if planner not in PLANNERS:
        raise InputError(f"unknown planner {planner!r}; allowed: {', '.join(PLANNERS)}")
    train_config = train_config or TrainConfig()
    cml_config = cml_config or CMLConfig.for_arena(arena_size)
    train_arena = GridArena.empty(arena_size)
    if eval_arena is not None and eval_size is not None:
        raise InputError("give eval_size or eval_arena, not both")
    if eval_arena is None:
        size = eval_size or arena_size
        eval_arena = (GridArena.with_obstacles(size, obstacles, eval_seed) if obstacles
                      else GridArena.empty(size))
    elif obstacles:
        raise InputError("obstacles are placed on an empty arena, not on a map")
    curve_pairs = draw_pairs(train_arena, trials, eval_seed)
    if pairs is None:
        pairs = draw_pairs(eval_arena, trials, eval_seed)
    trials = len(pairs.starts)
    seeds = list(seeds)
    finals, steps, per_seed, curves, train_errors = [], [], [], [], []
    counters: dict[str, int] = {}
    t0 = time.perf_counter()
    for n, seed in enumerate(seeds):
        cml = CML.create(cml_config, backend, seed, **backend_options)
        curve: list[float] = []

        def on_epoch(done: int, cml: CML = cml, curve: list[float] = curve) -> None:
            r = plan(cml, train_arena, curve_pairs.starts, curve_pairs.goals, path=path)
            curve.append(float(e_pos(r.final, curve_pairs.goals).mean()))

        train_errors.append(train(cml, train_arena, train_config, seed, path=path, epoch=epoch,
                                  on_epoch=on_epoch).tolist())
        for arr in cml.arrays:  # time between programming and use (drift, retention)
            arr.elapse(idle_s)
        res = plan(cml, eval_arena, pairs.starts, pairs.goals, max_steps=max_steps, path=path,
                   planner=planner)
        finals.append(res.final)
        steps.append(res.steps)
        per_seed.append({"seed": int(seed), **summarize(res.final, res.steps, pairs)})
        curves.append(curve)
        for k, v in cml.counters().items():
            counters[k] = counters.get(k, 0) + v
        if progress is not None:
            progress(n + 1, len(seeds))
    pooled = summarize(np.concatenate(finals), np.concatenate(steps),
                       pool_pairs(pairs, len(seeds)))
    return {
        "backend": backend,
        "seeds": len(seeds),
        "seed_list": [int(s) for s in seeds],
        **pooled,
        "trials": int(trials),
        "arena": int(arena_size),
        "eval_arena": int(eval_arena.size),
        "obstacles": int(obstacles),
        "planner": planner,
        "max_steps": int(max_steps),
        "eval_seed": int(eval_seed),
        "explore": train_config.explore,
        "walks": train_config.walks,
        "steps": train_config.steps,
        "schedule": train_config.schedule,
        "utility": cml_config.utility,
        "path": path,
        "epoch_walks": epoch,
        "idle_s": float(idle_s),
        "curve_e_pos_mean": np.mean(curves, axis=0).tolist(),
        "train_error": np.mean(train_errors, axis=0).tolist(),
        "per_seed": per_seed,
        "counters": counters,
        "backend_options": backend_options,
        "wall_time_s": time.perf_counter() - t0,
    }
