"""One model seed's run on the grid: make the CML, train it, let time pass, plan.

:func:`train_and_evaluate` is the paper's protocol (2.4) for one seed: a fresh CML on the
chosen backend is trained on the empty arena (planning a curve's pairs every ``epoch``
walks, for the convergence curve of Figure 4B; training time measured without them),
``idle_s`` seconds pass (each array's ``elapse``: drift on a crossbar, nothing on a
digital array), then each :class:`Evaluation` is planned. Every command that trains and
evaluates grid CMLs runs on it: :func:`cml_edge.grid.protocol.run_protocol` (``cml-edge
emulate``), the experiments' task (:func:`cml_edge.experiments.common.train_eval`), the
scenarios' grid world (:mod:`cml_edge.grid.world`), the CML beside the DQN
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
from cml_edge.core.finite import check_weights
from cml_edge.engine.timings import stage
from cml_edge.grid.arena import GridArena
from cml_edge.grid.fidelity import float_twin, seed_fidelity
from cml_edge.grid.metrics import Pairs, summarize
from cml_edge.grid.paths import default_path
from cml_edge.grid.planning import MAX_STEPS, PlanResult, plan
from cml_edge.grid.training import TrainConfig, train


def cml_config_for(arena: GridArena, **overrides: Any) -> CMLConfig:
    """The CML's config for a grid arena: :meth:`CMLConfig.for_arena` of its side, with an
    observation per axis and per range sensor (n_i = the arena's dimensions + K) and an
    action per move (n_a)."""
    return CMLConfig.for_arena(arena.size, **{"n_i": arena.dims + arena.n_sensors,
                                              "n_a": arena.n_actions, **overrides})


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
    """None: :func:`cml_config_for` the training arena."""
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
    curve_counters: dict[str, int] = field(default_factory=dict)
    """What the curve's plans added to the arrays' counters while training (so
    ``train_counters`` less these is the training's own work: :attr:`learn_counters`)."""

    @property
    def learn_counters(self) -> dict[str, int]:
        """The counters of the training alone, the curve's plans taken out."""
        return {k: v - self.curve_counters.get(k, 0) for k, v in self.train_counters.items()}

    @property
    def eval_counters(self) -> dict[str, int]:
        """The counters of the evaluations alone."""
        return {k: v - self.train_counters.get(k, 0) for k, v in self.counters.items()}


def train_seed(seed: int, training: Training, *, curve: Evaluation | None = None,
               curve_at_start: bool = False,
               on_epoch: Callable[[int], None] | None = None) -> SeedRun:
    """Make the CML of ``seed`` and train it (the first half of :func:`train_and_evaluate`);
    the run has no evaluations yet (:func:`evaluate_seed`). ``on_epoch(walks)`` is called
    after every ``training.epoch`` walks (outside the timed training)."""
    cml_config = training.cml_config or cml_config_for(training.arena)
    cml = CML.create(cml_config, training.backend, seed, training.chip,
                     **training.backend_options)
    path = training.path or default_path(cml, training.config.schedule,
                                             arena=training.arena)
    points: list[dict[str, Any]] = []

    spent: dict[str, int] = {}  # the curve's plans' counters

    def point(walks: int) -> None:
        if curve is not None:
            before = cml.counters()
            with stage("curve"):
                r = curve.plan(cml, path)
            for k, v in cml.counters().items():
                spent[k] = spent.get(k, 0) + v - before.get(k, 0)
            points.append({"walks": walks, **summarize(r.final, r.steps, curve.pairs)})

    if curve_at_start:
        point(0)
    wall, cpu = [0.0], [0.0]
    clock = [time.perf_counter(), time.process_time()]

    def epoch_done(walks: int) -> None:
        wall.append(wall[-1] + time.perf_counter() - clock[0])
        cpu.append(cpu[-1] + time.process_time() - clock[1])
        point(walks)
        if on_epoch is not None:
            on_epoch(walks)
        clock[0], clock[1] = time.perf_counter(), time.process_time()

    with stage("train"):  # the curve's plans are its stage "curve"
        errors = train(cml, training.arena, training.config, seed, path=path,
                       epoch=training.epoch, on_epoch=epoch_done)
    counters = cml.counters()
    return SeedRun(int(seed), cml, path, errors, points, [], [], counters, dict(counters), wall,
                   cpu, spent)


def evaluate_seed(run: SeedRun, evaluations: Sequence[Evaluation], idle_s: float = 0.0) -> None:
    """Let ``idle_s`` pass on the run's arrays, then plan each evaluation; the run's
    results, summaries and counters are updated (the second half of
    :func:`train_and_evaluate`). Weights the idle time made NaN or infinite raise
    :class:`~cml_edge.core.finite.NonFiniteError` (a failed run)."""
    cml = run.cml
    with stage("evaluate"):
        for arr in cml.arrays:  # time between programming and use (drift, retention)
            arr.elapse(idle_s)
        check_weights(cml, "drift", run.seed)
        for ev in evaluations:
            r = ev.plan(cml, run.path)
            run.results.append(r)
            run.summaries.append(summarize(r.final, r.steps, ev.pairs))
    run.counters = cml.counters()


def train_and_evaluate(seed: int, training: Training, evaluations: Sequence[Evaluation] = (),
                       *, curve: Evaluation | None = None, curve_at_start: bool = False,
                       idle_s: float = 0.0,
                       on_epoch: Callable[[int], None] | None = None) -> SeedRun:
    """Make the CML of ``seed``, train it, let ``idle_s`` pass, plan each evaluation.

    With ``curve``, the model plans it every ``training.epoch`` walks (and before
    training with ``curve_at_start``): the convergence curve. The training times in the
    result leave those plans out. ``on_epoch``: :func:`train_seed`'s.
    """
    run = train_seed(seed, training, curve=curve, curve_at_start=curve_at_start,
                     on_epoch=on_epoch)
    evaluate_seed(run, evaluations, idle_s)
    return run


def run_fidelity(run: SeedRun, training: Training, evaluations: Sequence[Evaluation],
                 twin: CML | None = None) -> list[dict[str, Any]]:
    """The run's weight error, decision agreement and read SNR against its float64 twin
    (:mod:`cml_edge.grid.fidelity`), one record per evaluation. ``twin``: the twin if
    already trained. The run itself is not changed."""
    cml_config = training.cml_config or cml_config_for(training.arena)
    if twin is None:
        twin = float_twin(run.seed, training.arena, training.config, cml_config)
    return [seed_fidelity(run.seed, run.cml, twin, ev.arena, ev.pairs.goals, res, ev.planner,
                          ev.max_steps)
            for ev, res in zip(evaluations, run.results)]

