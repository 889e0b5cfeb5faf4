"""The evaluation protocol, made exact: train seeds, plan fixed pairs, pool.

The protocol is the paper's (2.4): for each model seed, a fresh CML on the chosen
backend is trained on the empty arena (evaluated on the empty arena every ``epoch``
walks, for the convergence curve of Figure 4B), then evaluated once on the evaluation
condition (:meth:`Protocol.condition`: the empty arena, a larger one (``eval_size``, the
generalisation experiment of Figure 7), obstacles placed from the evaluation seed, or a
map). Pairs come from the evaluation seed, so every method and backend sees the same
pairs. Pooled metrics are over all seeds x trials. ``idle_s`` seconds pass between the
end of training and the evaluation. A run's settings are one JSON-able record,
:class:`Protocol`; :func:`run_protocol` runs it (``cml-edge emulate``), one seed at a
time (:func:`protocol_seed`, :func:`cml_edge.grid.seed_run.train_and_evaluate`), and
:func:`pool_protocol` pools the seeds.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass, field, fields
from numbers import Real
from typing import Any

import numpy as np

from cml_edge.backends import backend_spec, beyond_reference
from cml_edge.core.cml import UTILITIES, CMLConfig
from cml_edge.core.fidelity import TWIN, pool_seeds
from cml_edge.core.finite import check_finite
from cml_edge.core.records import Record, integer
from cml_edge.errors import InputError
from cml_edge.grid.arena import DIMS, MOVE_SETS, GridArena
from cml_edge.grid.condition import Condition
from cml_edge.grid.metrics import draw_pairs, pool_pairs, summarize
from cml_edge.grid.paths import default_path
from cml_edge.grid.planning import MAX_STEPS
from cml_edge.grid.seed_run import (
    Evaluation,
    Training,
    cml_config_for,
    run_fidelity,
    train_and_evaluate,
)
from cml_edge.grid.training import PATHS, TrainConfig
from cml_edge.protocol import EVAL_SEED

TRAIN_FIELDS = tuple(f.name for f in fields(TrainConfig))


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
    dims: int = 2
    """The arena's dimensions: 2 (the paper's plane) or 3 (a cube of side ``arena_size``)."""
    moves: str = "king"
    """The move set (:func:`~cml_edge.grid.arena.move_table`): ``king`` (8 on the plane, 26
    in space) or ``face`` (4, 6)."""

    def __post_init__(self) -> None:
        def put(name: str, value: Any) -> None:
            object.__setattr__(self, name, value)

        if not isinstance(self.backend, str):
            raise InputError(f"backend {self.backend!r} is not a name")
        backend_spec(self.backend)
        if isinstance(self.seeds, (str, bytes)):
            raise InputError(f"seeds {self.seeds!r} is not a list of model seeds")
        put("seeds", tuple(integer("seed", s, 0) for s in self.seeds))
        if not self.seeds:
            raise InputError("no seeds given (allowed: one or more model seeds)")
        for name, least in (("trials", 1), ("arena_size", 2), ("obstacles", 0),
                            ("eval_seed", 0), ("max_steps", 1), ("epoch", 1)):
            put(name, integer(name, getattr(self, name), least))
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
        if not isinstance(self.backend_options, Mapping):
            raise InputError(f"backend_options {self.backend_options!r} is not a mapping")
        put("backend_options", dict(self.backend_options))
        if self.eval_size is not None:
            put("eval_size", integer("eval_size", self.eval_size, 2))
        if self.map is not None and self.eval_size is not None:
            raise InputError("give eval_size or map, not both")
        if self.chip is not None:
            put("chip", integer("chip", self.chip, 0, "a chip seed >= 0"))
        if not isinstance(self.fidelity, bool):
            raise InputError(f"fidelity {self.fidelity!r} is not true or false")
        if self.dims not in DIMS:
            raise InputError(f"dims {self.dims!r} is not allowed (allowed: 2, 3)")
        if self.moves not in MOVE_SETS:
            raise InputError(f"unknown moves {self.moves!r}; allowed: {', '.join(MOVE_SETS)}")
        self.condition()  # its own checks: the map and its scen, the obstacles

    def to_dict(self) -> dict[str, Any]:
        """The settings as JSON; ``dims`` and ``moves`` only off the plane's king moves (so a
        plane's protocol reads as it did before a third dimension existed)."""
        d = {**asdict(self), "seeds": list(self.seeds)}
        if (self.dims, self.moves) == (2, "king"):
            del d["dims"], d["moves"]
        return d

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

    def arena(self) -> GridArena:
        """The empty training arena: side ``arena_size``, ``dims`` dimensions, ``moves``."""
        return GridArena.empty(self.arena_size, self.dims, self.moves)

    def cml_config(self) -> CMLConfig:
        """The CML's config: :func:`~cml_edge.grid.seed_run.cml_config_for` the training
        arena, with the protocol's utility."""
        return cml_config_for(self.arena(), utility=self.utility)

    def training(self) -> Training:
        """What every seed of the run shares: the empty training arena, the configs, the
        device and the compute path (None: :func:`default_path` of a counted run)."""
        path = self.path or default_path(self.backend, self.train.schedule,
                                         self.backend_options, counted=True)
        return Training(self.arena(), self.train, self.cml_config(),
                        self.backend, self.backend_options, path, self.epoch, self.chip)

    def condition(self) -> Condition:
        """Where the trained models are evaluated: the map (its ``scen`` problems, or drawn
        pairs), or the empty arena of ``eval_size`` (None: ``arena_size``) with the
        ``obstacles``; with the planner and ``max_steps``."""
        return Condition(size=self.eval_size, obstacles=self.obstacles, map=self.map,
                         scen=self.scen, planner=self.planner, max_steps=self.max_steps,
                         trials=self.trials, eval_seed=self.eval_seed)

    def evaluation(self) -> Evaluation:
        """:meth:`condition` for the models of this run's training arena."""
        return self.condition().evaluation(self.arena_size, self.dims, self.moves)


def protocol_seed(p: Protocol, seed: int,
                  on_epoch: Callable[[int], None] | None = None) -> dict[str, Any]:
    """One model seed of :func:`run_protocol`, as JSON (what :func:`pool_protocol` pools):
    the evaluation's per-trial ``final`` and ``steps``, the seed's ``summary`` (with its
    fidelity record), the ``curve`` (e_pos every ``epoch`` walks), the ``train_error``
    and the arrays' ``counters`` (and those of the training alone, ``learn_counters``,
    and of the evaluation, ``plan_counters``), and ``wall_s``, the seconds it took.
    ``on_epoch``: :func:`train_seed`'s."""
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
              "learn_counters": run.learn_counters, "plan_counters": run.eval_counters,
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


PROTOCOL_TASK = "cml_edge.grid.protocol:protocol_task"


def run_protocol(protocol: Protocol = Protocol(),
                 progress: Callable[[int, int], None] | None = None,
                 records: list[dict[str, Any]] | None = None) -> dict[str, Any]:
    """Train and evaluate one model per seed of ``protocol`` (:func:`protocol_seed`) and
    pool them (:func:`pool_protocol`): the JSON-ready result of ``emulate``.
    ``progress(done, total)`` counts units of work over all seeds: each seed's training
    epochs (one every ``epoch`` walks), then its evaluation (with the fidelity); it is
    called with 0 first, then after each unit. ``records``: a list the seeds' records
    (:func:`protocol_seed`) are appended to, for what reads them beyond the pooled result
    (``emulate``'s hardware budget, :func:`cml_edge.costs.budget.protocol_costs`)."""
    p = protocol
    units = -(-p.train.walks // p.epoch) + 1  # per seed: its epochs, its evaluation
    total = units * len(p.seeds)
    tick = progress or (lambda done, total: None)
    tick(0, total)
    t0 = time.perf_counter()
    records = [] if records is None else records
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
    pooled = summarize(np.concatenate([np.asarray(r["final"], np.int64).reshape(-1, p.dims)
                                       for r in records]),
                       np.concatenate([np.asarray(r["steps"], np.int64) for r in records]),
                       pool_pairs(pairs, len(records)))
    extra = {**pool_seeds([r["fidelity"] for r in records]), "fidelity_twin": TWIN} \
        if p.fidelity else {}
    on_map = {"map": p.map, "scen": p.scen} if p.map is not None else {}
    in_space = {"dims": p.dims, "moves": p.moves} if (p.dims, p.moves) != (2, "king") else {}
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
        **in_space,
    }
    check_finite(result, "evaluation")
    return result
