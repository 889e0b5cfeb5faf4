"""The evaluation protocol, made exact: train seeds, plan fixed pairs, pool; and the one
rule that picks the compute path when none is given (:func:`default_path`).

The protocol is the paper's (2.4): for each model seed, a fresh CML on the chosen
backend is trained on the empty arena (evaluated on the empty arena every ``epoch``
walks, for the convergence curve of Figure 4B), then evaluated once on the evaluation
arena (with obstacles if asked, placed from the evaluation seed). Pairs come from the
evaluation seed, so every method and backend sees the same pairs. Pooled metrics are
over all seeds x trials. ``idle_s`` seconds pass between the end of training and the
evaluation (each array's ``elapse``: drift on a crossbar, nothing on a digital array).
A run's settings are one JSON-able record, :class:`Protocol`; :func:`run_protocol` runs
it.

The evaluation arena may differ from the training arena: a larger empty arena
(``eval_size``, the generalisation experiment of Figure 7) or a map (``map``, a MovingAI
map of the training size, with its own pairs from a ``scen`` file if given). The CML
never sees either while training: it is trained in the empty arena of ``arena_size``.
``planner`` and ``max_steps`` choose the planner and its step budget
(:mod:`cml_edge.grid.planning`). :func:`eval_setting` makes such an evaluation condition
from its JSON description, and :func:`pool_records` pools the per-trial records of
several seeds.

One seed's run is :func:`train_and_evaluate`: make the CML, train it (a curve point
every ``epoch`` walks, training time measured without them), let ``idle_s`` pass, plan
each :class:`Evaluation`. Every command that trains and evaluates grid CMLs runs on it:
:func:`run_protocol` (``cml-edge emulate``), the experiments' task
(:func:`cml_edge.experiments.common.train_eval`), the CML beside the DQN
(:func:`cml_edge.baselines.dqn.cml_on_pairs`), the report's operation counts
(:func:`cml_edge.report.build.measure_operations`) and ``cml-edge bench``.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass, field, fields
from numbers import Integral, Real
from pathlib import Path
from typing import Any

import numpy as np

from cml_edge.backends import backend_spec, beyond_reference
from cml_edge.core.cml import CML, UTILITIES, CMLConfig
from cml_edge.core.fidelity import TWIN, pool_seeds
from cml_edge.core.finite import check_finite, check_weights
from cml_edge.core.learning import schedule_defers
from cml_edge.core.records import Record
from cml_edge.engine.timings import stage
from cml_edge.errors import InputError
from cml_edge.grid.arena import GridArena
from cml_edge.grid.fidelity import float_twin, seed_fidelity
from cml_edge.grid.maps import load_map, load_scen, resolve_map, scenario_pairs, step_budget
from cml_edge.grid.metrics import Pairs, draw_pairs, summarize
from cml_edge.grid.planning import MAX_STEPS, PLANNERS, PlanResult, plan
from cml_edge.grid.training import PATHS, TrainConfig, train
from cml_edge.protocol import EVAL_SEED

TRAIN_FIELDS = tuple(f.name for f in fields(TrainConfig))


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
      measured in benchmarks/README.md), else ``direct``: ``cml-edge train``, ``evaluate``,
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
               curve_at_start: bool = False,
               on_epoch: Callable[[int], None] | None = None) -> SeedRun:
    """Make the CML of ``seed`` and train it (the first half of :func:`train_and_evaluate`);
    the run has no evaluations yet (:func:`evaluate_seed`). ``on_epoch(walks)`` is called
    after every ``training.epoch`` walks (outside the timed training)."""
    cml_config = training.cml_config or CMLConfig.for_arena(training.arena.size)
    cml = CML.create(cml_config, training.backend, seed, training.chip,
                     **training.backend_options)
    path = training.path or default_path(cml, training.config.schedule)
    points: list[dict[str, Any]] = []

    def point(walks: int) -> None:
        if curve is not None:
            with stage("curve"):
                r = curve.plan(cml, path)
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
                   cpu)


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


def eval_setting(spec: Mapping[str, Any], train_size: int) -> tuple[GridArena, Pairs, int]:
    """The arena, pairs and step budget of an evaluation condition (a JSON-able ``spec``:
    ``map`` and ``scen``, or ``size`` (None: ``train_size``) and ``obstacles``;
    ``trials`` pairs from ``eval_seed`` unless a ``scen`` file gives them; ``max_steps``
    None: :func:`~cml_edge.grid.maps.step_budget` of the arena)."""
    if spec.get("map"):
        grid = load_map(resolve_map(spec["map"]))
        arena = grid.arena()
        if spec.get("scen"):
            pairs = scenario_pairs(grid, load_scen(spec["scen"]), Path(spec["scen"]).name)
        else:
            pairs = draw_pairs(arena, spec["trials"], spec["eval_seed"])
    else:
        size = spec.get("size") or train_size
        arena = (GridArena.with_obstacles(size, spec["obstacles"], spec["eval_seed"])
                 if spec["obstacles"] else GridArena.empty(size))
        pairs = draw_pairs(arena, spec["trials"], spec["eval_seed"])
    budget = spec.get("max_steps") or step_budget(arena.size)
    return arena, pairs, budget


def pool_records(records: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    """The metrics of :func:`~cml_edge.grid.metrics.summarize` (Eqs. 8, 9) over the trials
    of several seeds' JSON records (each with its ``final``, ``steps``, ``starts``,
    ``goals``, ``chebyshev`` and ``geodesic`` lists)."""
    final = np.concatenate([np.asarray(r["final"], np.int64).reshape(-1, 2) for r in records])
    steps = np.concatenate([np.asarray(r["steps"], np.int64) for r in records])
    pairs = Pairs(*(np.concatenate([np.asarray(r[k], np.int64) for r in records])
                    for k in ("starts", "goals", "chebyshev", "geodesic")))
    return summarize(final, steps, pairs)


def _integer(name: str, value: Any, least: int, allowed: str | None = None) -> int:
    """``value`` as an int; InputError unless it is an integer >= ``least``."""
    if isinstance(value, bool) or not isinstance(value, Integral) or value < least:
        raise InputError(f"{name} {value!r} is not allowed (allowed: "
                         f"{allowed or f'an integer >= {least}'})")
    return int(value)


@dataclass(frozen=True)
class Protocol(Record):
    """The settings of one run of the evaluation protocol (:func:`run_protocol`), JSON-able
    (:meth:`to_dict`, :meth:`from_dict`; ``train`` as the fields of a
    :class:`~cml_edge.grid.training.TrainConfig`). Checked when made: a bad value raises
    :class:`~cml_edge.errors.InputError` naming it."""

    what = "protocol"

    backend: str = "float"
    seeds: tuple[int, ...] = tuple(range(10))
    """The model seeds, one trained model each."""
    trials: int = 100
    """(start, goal) pairs drawn from ``eval_seed`` (a ``scen`` file brings its own)."""
    arena_size: int = 30
    """The side of the empty training arena (and of the evaluation arena by default)."""
    obstacles: int = 0
    """Point obstacles placed from ``eval_seed`` on the evaluation arena."""
    train: TrainConfig = TrainConfig()
    """Walks, steps per walk, exploration and update schedule (paper 2.2)."""
    utility: str = "normalized"
    """The planning utility of :class:`~cml_edge.core.cml.CMLConfig`; the rest of the
    config is :meth:`~cml_edge.core.cml.CMLConfig.for_arena` of ``arena_size``."""
    eval_seed: int = EVAL_SEED
    """The seed of the pairs and obstacles: every backend and method sees the same."""
    path: str | None = None
    """The compute path; None: :func:`default_path` of a counted run (``direct``)."""
    idle_s: float = 0.0
    """Seconds between the end of training and the evaluation (each array's ``elapse``)."""
    planner: str = "paper"
    """A planner of :data:`~cml_edge.grid.planning.PLANNERS`."""
    max_steps: int = MAX_STEPS
    """The planning step budget."""
    epoch: int = 10
    """Walks between the curve's points."""
    backend_options: Mapping[str, Any] = field(default_factory=dict)
    """The device's config fields (``{"preset": "pcm"}``)."""
    eval_size: int | None = None
    """The side of an empty evaluation arena larger or smaller than the training arena
    (None: ``arena_size``)."""
    map: str | None = None
    """A map to evaluate on (a MovingAI ``.map`` file or a shipped map's name,
    :func:`~cml_edge.grid.maps.resolve_map`), of the training arena's side."""
    scen: str | None = None
    """A MovingAI ``.scen`` file of ``map``: its problems replace the drawn pairs."""
    chip: int | None = None
    """Every model on the chip of this chip seed (None: each on the chip of its model
    seed; :mod:`cml_edge.grid.chips`)."""
    fidelity: bool = True
    """Measure each seed against its float64 twin (:func:`run_fidelity`)."""

    def __post_init__(self) -> None:
        def put(name: str, value: Any) -> None:
            object.__setattr__(self, name, value)

        if not isinstance(self.backend, str):
            raise InputError(f"backend {self.backend!r} is not a name")
        backend_spec(self.backend)
        if isinstance(self.seeds, (str, bytes)):
            raise InputError(f"seeds {self.seeds!r} is not a list of model seeds")
        put("seeds", tuple(_integer("seed", s, 0) for s in self.seeds))
        if not self.seeds:
            raise InputError("no seeds given (allowed: one or more model seeds)")
        for name, least in (("trials", 1), ("arena_size", 2), ("obstacles", 0),
                            ("eval_seed", 0), ("max_steps", 1), ("epoch", 1)):
            put(name, _integer(name, getattr(self, name), least))
        if not isinstance(self.train, TrainConfig):
            raise InputError(f"train {self.train!r} is not a TrainConfig")
        if self.utility not in UTILITIES:
            raise InputError(f"unknown utility {self.utility!r}; allowed: "
                             f"{', '.join(UTILITIES)}")
        if self.path is not None and self.path not in PATHS:
            raise InputError(f"unknown path {self.path!r}; allowed: {', '.join(PATHS)}")
        if isinstance(self.idle_s, bool) or not isinstance(self.idle_s, Real) \
                or not math.isfinite(self.idle_s) or self.idle_s < 0:
            raise InputError(f"idle_s {self.idle_s!r} is not allowed (allowed: a finite "
                             f"number >= 0 seconds)")
        put("idle_s", float(self.idle_s))
        if self.planner not in PLANNERS:
            raise InputError(f"unknown planner {self.planner!r}; allowed: "
                             f"{', '.join(PLANNERS)}")
        if not isinstance(self.backend_options, Mapping):
            raise InputError(f"backend_options {self.backend_options!r} is not a mapping")
        put("backend_options", dict(self.backend_options))
        if self.eval_size is not None:
            put("eval_size", _integer("eval_size", self.eval_size, 2))
        for name in ("map", "scen"):
            value = getattr(self, name)
            if value is not None and not (isinstance(value, str) and value):
                raise InputError(f"{name} {value!r} is not a file name")
        if self.scen is not None and self.map is None:
            raise InputError("a scen file needs a map")
        if self.map is not None:
            if self.eval_size is not None:
                raise InputError("give eval_size or map, not both")
            if self.obstacles:
                raise InputError("obstacles are placed on an empty arena, not on a map")
        if self.chip is not None:
            put("chip", _integer("chip", self.chip, 0, "a chip seed >= 0"))
        if not isinstance(self.fidelity, bool):
            raise InputError(f"fidelity {self.fidelity!r} is not true or false")

    def to_dict(self) -> dict[str, Any]:
        d = asdict(self)
        return {**d, "seeds": list(self.seeds)}

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> Protocol:
        d = dict(d)
        if "train" in d:
            train = d["train"]
            if not isinstance(train, Mapping) or set(train) - set(TRAIN_FIELDS):
                raise InputError(f"train {train!r} is not allowed (allowed: a mapping of "
                                 f"{', '.join(TRAIN_FIELDS)})")
            d["train"] = TrainConfig(**train)
        return super().from_dict(d)

    def cml_config(self) -> CMLConfig:
        """The CML's config: :meth:`~cml_edge.core.cml.CMLConfig.for_arena` of the training
        arena with the protocol's utility."""
        return CMLConfig.for_arena(self.arena_size, utility=self.utility)

    def training(self) -> Training:
        """What every seed of the run shares: the empty training arena, the configs, the
        device and the compute path (None: :func:`default_path` of a counted run)."""
        path = self.path or default_path(self.backend, self.train.schedule,
                                         self.backend_options, counted=True)
        return Training(GridArena.empty(self.arena_size), self.train, self.cml_config(),
                        self.backend, self.backend_options, path, self.epoch, self.chip)

    def evaluation(self) -> Evaluation:
        """Where the trained models are evaluated (:func:`eval_setting`): the map (its
        ``scen`` problems, or drawn pairs), or the empty arena of ``eval_size`` (default
        ``arena_size``) with the ``obstacles``; with the planner and ``max_steps``."""
        spec = {"map": self.map, "scen": self.scen, "size": self.eval_size,
                "obstacles": self.obstacles, "trials": self.trials,
                "eval_seed": self.eval_seed, "max_steps": self.max_steps}
        return Evaluation(*eval_setting(spec, self.arena_size), self.planner)


def protocol_seed(p: Protocol, seed: int,
                  on_epoch: Callable[[int], None] | None = None) -> dict[str, Any]:
    """One model seed of :func:`run_protocol`, as JSON (what :func:`pool_protocol` pools):
    the evaluation's per-trial ``final`` and ``steps``, the seed's ``summary`` (with its
    fidelity record), the ``curve`` (e_pos every ``epoch`` walks), the ``train_error``
    and the arrays' ``counters``, and ``wall_s``, the seconds it took. ``on_epoch``:
    :func:`train_seed`'s."""
    t0 = time.perf_counter()
    training = p.training()
    arena = training.arena
    evaluation = p.evaluation()
    curve = Evaluation(arena, draw_pairs(arena, p.trials, p.eval_seed))
    run = train_and_evaluate(seed, training, [evaluation], curve=curve, idle_s=p.idle_s,
                             on_epoch=on_epoch)
    (res,), (summary,) = run.results, run.summaries
    record = {"seed": int(seed), "final": res.final.tolist(), "steps": res.steps.tolist(),
              "summary": {"seed": int(seed), **summary},
              "curve": [point["e_pos_mean"] for point in run.curve],
              "train_error": run.train_error.tolist(), "counters": run.counters,
              "fidelity": None}
    if p.fidelity:
        (record["fidelity"],) = run_fidelity(run, training, [evaluation])
        record["summary"].update(record["fidelity"])
    record["wall_s"] = time.perf_counter() - t0
    return record


def protocol_task(protocol: dict[str, Any], seed: int) -> dict[str, Any]:
    """:func:`protocol_seed` as a sweep task (:mod:`cml_edge.engine.sweep`): ``protocol``
    is :meth:`Protocol.to_dict`."""
    return protocol_seed(Protocol.from_dict(protocol), seed)


PROTOCOL_TASK = "cml_edge.grid.evaluation:protocol_task"


def run_protocol(protocol: Protocol = Protocol(),
                 progress: Callable[[int, int], None] | None = None) -> dict[str, Any]:
    """Train and evaluate one model per seed of ``protocol`` (:func:`protocol_seed`) and
    pool them (:func:`pool_protocol`): the JSON-ready result of ``emulate``.
    ``progress(done, total)`` counts units of work over all seeds: each seed's training
    epochs (one every ``epoch`` walks), then its evaluation (with the fidelity); it is
    called with 0 first, then after each unit."""
    p = protocol
    units = -(-p.train.walks // p.epoch) + 1  # per seed: its epochs, its evaluation
    total = units * len(p.seeds)
    tick = progress or (lambda done, total: None)
    tick(0, total)
    t0 = time.perf_counter()
    records = []
    for n, seed in enumerate(p.seeds):
        records.append(protocol_seed(p, seed, on_epoch=lambda walks, n=n: tick(
            n * units + -(-walks // p.epoch), total)))
        tick((n + 1) * units, total)
    return pool_protocol(p, records, time.perf_counter() - t0)


def pool_protocol(protocol: Protocol, records: Sequence[Mapping[str, Any]],
                  wall_time_s: float) -> dict[str, Any]:
    """The result of ``protocol`` from its seeds' records (:func:`protocol_seed`, in seed
    order).

    Every model is trained on the empty arena of ``arena_size``, planning the training
    arena's pairs every ``epoch`` walks (the curve), and evaluated once on
    :meth:`Protocol.evaluation`. The result carries the arrays' counters, so the compute
    path defaults to ``direct`` (:func:`default_path`); its keys ``compute_path`` and
    ``path`` (the older name) both name it. With ``fidelity`` (the default), each seed is
    also measured against its float64 twin (:func:`run_fidelity`): the keys
    ``weight_error``, ``decision_agreement`` and ``read_snr`` (seed means and spreads; per
    seed in ``per_seed``) are added, and no other number changes. On a map, ``map`` and
    ``scen`` close the result. A NaN or an infinity in the weights after training or
    drift, or in the metrics, raises :class:`~cml_edge.core.finite.NonFiniteError` (a
    failed run).
    """
    p = protocol
    path = p.training().path
    evaluation = p.evaluation()
    pairs = evaluation.pairs
    counters: dict[str, int] = {}
    for r in records:
        for k, v in r["counters"].items():
            counters[k] = counters.get(k, 0) + v
    pooled = summarize(np.concatenate([np.asarray(r["final"], np.int64).reshape(-1, 2)
                                       for r in records]),
                       np.concatenate([np.asarray(r["steps"], np.int64) for r in records]),
                       pool_pairs(pairs, len(records)))
    extra = {**pool_seeds([r["fidelity"] for r in records]), "fidelity_twin": TWIN} \
        if p.fidelity else {}
    on_map = {"map": p.map, "scen": p.scen} if p.map is not None else {}
    result = {
        "backend": p.backend,
        "seeds": len(records),
        "seed_list": [int(r["seed"]) for r in records],
        **pooled,
        "trials": int(len(pairs.starts)),
        "arena": int(p.arena_size),
        "eval_arena": int(evaluation.arena.size),
        "obstacles": int(p.obstacles),
        "planner": p.planner,
        "max_steps": int(p.max_steps),
        "eval_seed": int(p.eval_seed),
        "explore": p.train.explore,
        "walks": p.train.walks,
        "steps": p.train.steps,
        "schedule": p.train.schedule,
        "utility": p.utility,
        "compute_path": path,
        "path": path,
        "epoch_walks": p.epoch,
        "idle_s": float(p.idle_s),
        "curve_e_pos_mean": np.mean([r["curve"] for r in records], axis=0).tolist(),
        "train_error": np.mean([r["train_error"] for r in records], axis=0).tolist(),
        "per_seed": [dict(r["summary"]) for r in records],
        "counters": counters,
        "backend_options": dict(p.backend_options),
        **beyond_reference(p.backend, p.backend_options, p.train.schedule),
        "wall_time_s": wall_time_s,
        **extra,
        **on_map,
    }
    check_finite(result, "evaluation")
    return result
