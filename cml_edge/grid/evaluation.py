"""The evaluation protocol, made exact: train seeds, plan fixed pairs, pool; and the one
rule that picks the compute path when none is given (:func:`default_path`).

The protocol is the paper's (2.4): for each model seed, a fresh CML on the chosen
backend is trained on the empty arena (evaluated on the empty arena every ``epoch``
walks, for the convergence curve of Figure 4B), then evaluated once on the evaluation
arena (with obstacles if asked, placed from the evaluation seed). Pairs come from the
evaluation seed, so every method and backend sees the same pairs. Pooled metrics are
over all seeds x trials. ``idle_s`` seconds pass between the end of training and the
evaluation (each array's ``elapse``: drift on a crossbar, nothing on a digital array).

The evaluation arena may differ from the training arena: a larger empty arena
(``eval_size``, the generalisation experiment of Figure 7) or a map
(``eval_arena``, e.g. :meth:`cml_edge.grid.maps.GridMap.arena`) of the training size,
with its own pairs (``pairs``, e.g. a MovingAI scenario file). The CML never sees either
while training: it is trained in the empty arena of ``arena_size``. ``planner`` and
``max_steps`` choose the planner and its step budget (:mod:`cml_edge.grid.planning`).

One seed's run is :func:`train_and_evaluate`: make the CML, train it (a curve point
every ``epoch`` walks, training time measured without them), let ``idle_s`` pass, plan
each :class:`Evaluation`. Every command that trains and evaluates grid CMLs runs on it:
:func:`run_protocol` (``cml-edge emulate``), the experiments' task
(:func:`cml_edge.experiments.common.train_eval`), the CML beside the DQN
(:func:`cml_edge.baselines.dqn.cml_on_pairs`), the report's operation counts
(:func:`cml_edge.report.build.measure_operations`) and ``cml-edge bench``.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from cml_edge.core.cml import CML, CMLConfig
from cml_edge.core.fidelity import TWIN, pool_seeds
from cml_edge.core.learning import schedule_defers
from cml_edge.errors import InputError
from cml_edge.grid.arena import GridArena
from cml_edge.grid.fidelity import float_twin, seed_fidelity
from cml_edge.grid.metrics import Pairs, draw_pairs, summarize
from cml_edge.grid.planning import MAX_STEPS, PLANNERS, PlanResult, plan
from cml_edge.grid.training import TrainConfig, train
from cml_edge.protocol import EVAL_SEED


def factored_supported(cml: CML, schedule: str = "walk") -> bool:
    """Whether the exact factored shortcut applies: every array keeps float64 weights
    (``supports_factored``) and the schedule applies updates at the end of each walk."""
    return schedule_defers(schedule) and all(getattr(a, "supports_factored", False)
                                             for a in cml.arrays)


def default_path(cml: CML | str, schedule: str = "walk",
                 backend_options: Mapping[str, Any] | None = None, *,
                 counted: bool = False) -> str:
    """The compute path a run takes when none is given: the one rule of cml-edge.

    - ``direct`` when the run reports the arrays' operation counters (``counted``:
      ``cml-edge emulate``, :func:`run_protocol`, the hardware-budget report). The factored
      shortcut bypasses the arrays, so it would count nothing; and ``direct`` is the path
      a device array emulates operation by operation.
    - Otherwise ``factored`` where it applies (:func:`factored_supported`: float64 arrays
      and the per-walk schedule; it agrees with ``direct`` to rounding and is much faster,
      measured in the README), else ``direct``: ``cml-edge train``, ``evaluate``,
      ``navigate``, the experiments, and the extra figures of ``cml-edge bench``.

    ``cml`` is a model, or a backend name (with ``backend_options``) whose model is made
    to ask. Planning has no schedule: leave ``schedule`` at its default for it.
    """
    if counted or not schedule_defers(schedule):
        return "direct"
    if isinstance(cml, str):
        cml = CML.create(backend=cml, **(backend_options or {}))
    return "factored" if factored_supported(cml, schedule) else "direct"


@dataclass(frozen=True, eq=False)
class Evaluation:
    """One evaluation condition: plan ``pairs`` on ``arena`` with ``planner`` within
    ``max_steps`` actions."""

    arena: GridArena
    pairs: Pairs
    max_steps: int = MAX_STEPS
    planner: str = "paper"

    def plan(self, cml: CML, path: str) -> PlanResult:
        return plan(cml, self.arena, self.pairs.starts, self.pairs.goals,
                    max_steps=self.max_steps, path=path, planner=self.planner)


@dataclass(frozen=True, eq=False)
class Training:
    """How each seed's model is made and trained: what every seed of a run shares."""

    arena: GridArena
    config: TrainConfig = TrainConfig()
    cml_config: CMLConfig | None = None
    """None: :meth:`CMLConfig.for_arena` of the training arena."""
    backend: str = "float"
    backend_options: Mapping[str, Any] = field(default_factory=dict)
    path: str | None = None
    """None: :func:`default_path` of the model and the schedule."""
    epoch: int = 10
    """Walks between curve points (and between calls into the compiled loop)."""
    chip: int | None = None
    """The chip seed of the arrays (None: each model's seed; :mod:`cml_edge.grid.chips`)."""


@dataclass
class SeedRun:
    """What one seed's :func:`train_and_evaluate` produced."""

    seed: int
    cml: CML
    path: str
    train_error: np.ndarray
    """Mean training error of each walk."""
    curve: list[dict[str, Any]]
    """One point per curve evaluation: ``{"walks": n, **summarize(...)}``."""
    results: list[PlanResult]
    """One per evaluation, in order."""
    summaries: list[dict[str, Any]]
    train_counters: dict[str, int]
    """The arrays' counters at the end of training (curve plans included)."""
    counters: dict[str, int]
    """The arrays' counters at the end (training, curve and evaluations)."""
    wall_s: list[float]
    """Training wall time at the start and after every ``epoch`` walks, curve points
    excluded."""
    cpu_s: list[float]
    """The same in process CPU time."""

    @property
    def eval_counters(self) -> dict[str, int]:
        """The counters of the evaluations alone."""
        return {k: v - self.train_counters.get(k, 0) for k, v in self.counters.items()}


def train_seed(seed: int, training: Training, *, curve: Evaluation | None = None,
               curve_at_start: bool = False) -> SeedRun:
    """Make the CML of ``seed`` and train it (the first half of :func:`train_and_evaluate`);
    the run has no evaluations yet (:func:`evaluate_seed`)."""
    cml_config = training.cml_config or CMLConfig.for_arena(training.arena.size)
    cml = CML.create(cml_config, training.backend, seed, training.chip,
                     **training.backend_options)
    path = training.path or default_path(cml, training.config.schedule)
    points: list[dict[str, Any]] = []

    def point(walks: int) -> None:
        if curve is not None:
            r = curve.plan(cml, path)
            points.append({"walks": walks, **summarize(r.final, r.steps, curve.pairs)})

    if curve_at_start:
        point(0)
    wall, cpu = [0.0], [0.0]
    clock = [time.perf_counter(), time.process_time()]

    def on_epoch(walks: int) -> None:
        wall.append(wall[-1] + time.perf_counter() - clock[0])
        cpu.append(cpu[-1] + time.process_time() - clock[1])
        point(walks)
        clock[0], clock[1] = time.perf_counter(), time.process_time()

    errors = train(cml, training.arena, training.config, seed, path=path,
                   epoch=training.epoch, on_epoch=on_epoch)
    counters = cml.counters()
    return SeedRun(int(seed), cml, path, errors, points, [], [], counters, dict(counters), wall,
                   cpu)


def evaluate_seed(run: SeedRun, evaluations: Sequence[Evaluation], idle_s: float = 0.0) -> None:
    """Let ``idle_s`` pass on the run's arrays, then plan each evaluation; the run's
    results, summaries and counters are updated (the second half of
    :func:`train_and_evaluate`)."""
    cml = run.cml
    for arr in cml.arrays:  # time between programming and use (drift, retention)
        arr.elapse(idle_s)
    for ev in evaluations:
        r = ev.plan(cml, run.path)
        run.results.append(r)
        run.summaries.append(summarize(r.final, r.steps, ev.pairs))
    run.counters = cml.counters()


def train_and_evaluate(seed: int, training: Training, evaluations: Sequence[Evaluation] = (),
                       *, curve: Evaluation | None = None, curve_at_start: bool = False,
                       idle_s: float = 0.0) -> SeedRun:
    """Make the CML of ``seed``, train it, let ``idle_s`` pass, plan each evaluation.

    With ``curve``, the model plans it every ``training.epoch`` walks (and before
    training with ``curve_at_start``): the convergence curve. The training times in the
    result leave those plans out.
    """
    run = train_seed(seed, training, curve=curve, curve_at_start=curve_at_start)
    evaluate_seed(run, evaluations, idle_s)
    return run


def run_fidelity(run: SeedRun, training: Training, evaluations: Sequence[Evaluation],
                 twin: CML | None = None) -> list[dict[str, Any]]:
    """The run's weight error, decision agreement and read SNR against its float64 twin
    (:mod:`cml_edge.grid.fidelity`), one record per evaluation. ``twin``: the twin if
    already trained. The run itself is not changed."""
    cml_config = training.cml_config or CMLConfig.for_arena(training.arena.size)
    if twin is None:
        twin = float_twin(run.seed, training.arena, training.config, cml_config)
    return [seed_fidelity(run.seed, run.cml, twin, ev.arena, ev.pairs.goals, res, ev.planner,
                          ev.max_steps)
            for ev, res in zip(evaluations, run.results)]


def pool_pairs(pairs: Pairs, times: int) -> Pairs:
    """``pairs`` repeated ``times`` times (pooling the trials of several models)."""
    return Pairs(*(np.concatenate([a] * times) for a in
                   (pairs.starts, pairs.goals, pairs.chebyshev, pairs.geodesic)))


def run_protocol(backend: str = "float", seeds: Sequence[int] = range(10), trials: int = 100,
                 arena_size: int = 30, obstacles: int = 0,
                 train_config: TrainConfig | None = None, cml_config: CMLConfig | None = None,
                 eval_seed: int = EVAL_SEED, path: str | None = None, epoch: int = 10,
                 idle_s: float = 0.0,
                 progress: Callable[[int, int], None] | None = None,
                 planner: str = "paper", max_steps: int = MAX_STEPS,
                 eval_size: int | None = None, eval_arena: GridArena | None = None,
                 pairs: Pairs | None = None, chip: int | None = None, fidelity: bool = True,
                 **backend_options: Any) -> dict[str, Any]:
    """Train and evaluate one model per seed; the JSON-ready result of ``emulate``.

    Obstacles (``obstacles`` > 0) are placed from ``eval_seed`` on the evaluation arena:
    the empty arena of ``eval_size`` (default ``arena_size``), or ``eval_arena``. The
    result carries the arrays' counters, so ``path`` defaults to ``direct``
    (:func:`default_path`); its keys ``compute_path`` and ``path`` (the older name) both
    name it. ``chip``: every model on the chip of that chip seed (None: each on its own,
    the chip of its model seed; :mod:`cml_edge.grid.chips`). With ``fidelity`` (the
    default), each seed is also measured against its float64 twin (:func:`run_fidelity`):
    the keys ``weight_error``, ``decision_agreement`` and ``read_snr`` (seed means and
    spreads; per seed in ``per_seed``) are added, and no other number changes.
    """
    if planner not in PLANNERS:
        raise InputError(f"unknown planner {planner!r}; allowed: {', '.join(PLANNERS)}")
    train_config = train_config or TrainConfig()
    cml_config = cml_config or CMLConfig.for_arena(arena_size)
    path = path or default_path(backend, train_config.schedule, backend_options, counted=True)
    train_arena = GridArena.empty(arena_size)
    if eval_arena is not None and eval_size is not None:
        raise InputError("give eval_size or eval_arena, not both")
    if eval_arena is None:
        size = eval_size or arena_size
        eval_arena = (GridArena.with_obstacles(size, obstacles, eval_seed) if obstacles
                      else GridArena.empty(size))
    elif obstacles:
        raise InputError("obstacles are placed on an empty arena, not on a map")
    curve = Evaluation(train_arena, draw_pairs(train_arena, trials, eval_seed))
    if pairs is None:
        pairs = draw_pairs(eval_arena, trials, eval_seed)
    evaluation = Evaluation(eval_arena, pairs, max_steps, planner)
    training = Training(train_arena, train_config, cml_config, backend, backend_options, path,
                        epoch, chip)
    trials = len(pairs.starts)
    seeds = list(seeds)
    if not seeds:
        raise InputError("no seeds given (allowed: one or more model seeds)")
    finals, steps, per_seed, curves, train_errors, fids = [], [], [], [], [], []
    counters: dict[str, int] = {}
    t0 = time.perf_counter()
    for n, seed in enumerate(seeds):
        run = train_and_evaluate(seed, training, [evaluation], curve=curve, idle_s=idle_s)
        (res,), (summary,) = run.results, run.summaries
        finals.append(res.final)
        steps.append(res.steps)
        per_seed.append({"seed": int(seed), **summary})
        if fidelity:
            (fid,) = run_fidelity(run, training, [evaluation])
            fids.append(fid)
            per_seed[-1].update(fid)
        curves.append([p["e_pos_mean"] for p in run.curve])
        train_errors.append(run.train_error.tolist())
        for k, v in run.counters.items():
            counters[k] = counters.get(k, 0) + v
        if progress is not None:
            progress(n + 1, len(seeds))
    pooled = summarize(np.concatenate(finals), np.concatenate(steps),
                       pool_pairs(pairs, len(seeds)))
    extra = {**pool_seeds(fids), "fidelity_twin": TWIN} if fidelity else {}
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
        "compute_path": path,
        "path": path,
        "epoch_walks": epoch,
        "idle_s": float(idle_s),
        "curve_e_pos_mean": np.mean(curves, axis=0).tolist(),
        "train_error": np.mean(train_errors, axis=0).tolist(),
        "per_seed": per_seed,
        "counters": counters,
        "backend_options": backend_options,
        "wall_time_s": time.perf_counter() - t0,
        **extra,
    }
