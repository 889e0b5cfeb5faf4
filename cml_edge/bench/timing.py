"""Speed of the training and planning loops (``cml-edge bench``): figures, not assertions.

Each figure is the median over ``repeats`` timed runs after a compiling warm-up run, in
microseconds per step of the process's CPU time (``time.process_time``: on a machine
shared with other jobs, their load does not enter the figures or their ratios):

- ``train_step_us_random`` / ``train_step_us_mixed``: one training step (exploration
  and the local rule) of the direct compiled loop, averaged over the paper's whole
  100 x 900-step training, as the paper's Table 3 averages;
- ``plan_step_us``: one planning step of the direct loop, over the protocol's 100 pairs;
- for the float64 array also ``train_step_us_factored``, ``plan_step_us_factored`` and
  ``train_total_s_factored`` (the whole 100 x 900 training).

A backend name may carry a preset, ``crossbar:reram`` (:func:`bench_names` with
``presets=True`` names every preset of a backend that takes one), and ``settings``
(``--set field=value``) change device fields of every named backend, whose keys then list
them (``crossbar:pcm (out_noise=0)``: the preset without its read noise, against the same
float64 denominator). Every run also
times the yardstick (:mod:`cml_edge.bench.fused`: the float64 step hand-fused into a plain
Numba function, bit-identical to the direct path) and gives, measured in the same run, the
``ratios``:
float64 direct / fused (goal 1.3), factored / fused factored (goal 1.1), and each other
backend's direct path / float64 direct, per training and per planning step (goal 2).

``--robot SIM ...`` adds the wheeled robot: simulated ``train_actions_per_s``
(random walks with the local rule, heading-aware CML, float64) and ``plan_actions_per_s``
(driving to goals from the base), each timed after a compiling warm-up: 10 walks x 900
actions and 100 goals on the kinematic simulator, 1 walk x 300 actions and 5 goals on
MuJoCo, which is physics-bound (its figures are in benchmarks/README.md).

``--dims 3`` (``dims`` of :func:`run_bench`) adds ``space``: each named backend's direct
path timed again in the 30 x 30 x 30 volume with the 26 king moves (``--moves face``: 6),
and, for each, the training step per synapse (CPU nanoseconds per step over the CML's
(N_i + 2 N_a) N_s weights: 4,608 on the plane, 14,080 in space) on the plane and in
space, measured in the same run, and their ratio (goal: within 2, :data:`GOALS` ``space``).
"""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from cml_edge.backends import backend_spec, configurations
from cml_edge.bench.fused import FusedLearner, FusedScorer, fused_factored_of
from cml_edge.core.cml import CML
from cml_edge.core.step import FactoredScorer, SeamScorer
from cml_edge.grid.arena import GridArena
from cml_edge.grid.exploration import GridExplorer
from cml_edge.grid.metrics import draw_pairs
from cml_edge.grid.planning import WTA, PlanResult, plan_loop
from cml_edge.grid.seed_run import cml_config_for
from cml_edge.grid.training import (
    FactoredLearner,
    SeamLearner,
    TrainConfig,
    train,
    train_loop,
)
from cml_edge.protocol import EVAL_SEED

WALKS, STEPS = 100, 900
GOALS = {"direct": 1.3, "factored": 1.1, "device": 2.0, "space": 2.0}
"""The goals for the ratios (module docstring)."""

LEARNERS: dict[str, Callable[[CML, GridArena], Any]] = {
    "direct": lambda cml, arena: SeamLearner.of(cml, True),
    "factored": FactoredLearner.of,
    "fused": lambda cml, arena: FusedLearner.of(cml),
    "fused_factored": fused_factored_of,
}
SCORERS: dict[str, Callable[[CML], Any]] = {
    "direct": SeamScorer.of, "factored": FactoredScorer.of, "fused": FusedScorer.of}


def parse_name(name: str, settings: Sequence[str] = ()) -> tuple[str, dict[str, Any]]:
    """``backend`` or ``backend:preset`` -> (backend, options)
    (:func:`cml_edge.backends.configurations`), with ``settings`` (``--set`` texts,
    ``field=value``) applied; InputError if anything is unknown or contradicts the backend
    name (:meth:`~cml_edge.backends.device.DeviceSpec.given`)."""
    ((_, backend, options),) = configurations([name], presets=False)
    return backend, backend_spec(backend).device.given(backend, options, settings)


def label(name: str, settings: Sequence[str] = ()) -> str:
    """A bench entry's key: the name, and the settings it was timed with."""
    return f"{name} ({', '.join(s.strip() for s in settings)})" if settings else name


def bench_names(names: Sequence[str], presets: bool = False) -> list[str]:
    """The names to time: each as given, or, with ``presets``, one ``backend:preset`` per
    preset of a backend that takes one and names none
    (:func:`cml_edge.backends.configurations`)."""
    return [f"{backend}:{options['preset']}" if "preset" in options else backend
            for _, backend, options in configurations(names, presets)]


def _median_time(run: Callable[[int], float], repeats: int) -> float:
    run(-1)  # compile and warm up
    return statistics.median(run(r) for r in range(repeats))


def _model(arena: GridArena, backend: str, options: dict[str, Any], seed: int) -> CML:
    return CML.create(cml_config_for(arena), backend, seed, **options)


def time_train(arena: GridArena, config: TrainConfig, seed: int, backend: str,
               options: dict[str, Any], learner: str) -> float:
    """CPU seconds per step of one compiled training from a fresh model of ``seed``."""
    cml = _model(arena, backend, options, seed)
    plug = LEARNERS[learner](cml, arena)
    explorer = GridExplorer.of(arena, config, seed)
    errors = np.zeros(config.walks)
    c = cml.config
    t0 = time.process_time()
    train_loop(plug, explorer, c.obs_origin, c.obs_scale, 0, config.walks, config.steps, errors)
    return (time.process_time() - t0) / (config.walks * config.steps)


def time_plan(cml: CML, arena: GridArena, starts: np.ndarray, goals: np.ndarray,
              scorer: str) -> float:
    """CPU seconds per step of the paper's planner over the pairs, on the ``scorer`` path."""
    n = len(starts)
    res = PlanResult.empty(n, 100, arena)
    plug = SCORERS[scorer](cml)
    c = cml.config
    cells = arena.cells()
    t0 = time.process_time()
    plan_loop(plug, WTA(), cells, c.obs_origin, c.obs_scale, c.utility == "normalized",
              False, starts, goals, 0, n, 100, res)
    return (time.process_time() - t0) / max(int(res.steps.sum()), 1)


def bench_backend(name: str, repeats: int = 5, paths: Sequence[str] | None = None,
                  settings: Sequence[str] = (), dims: int = 2,
                  moves: str = "king") -> dict[str, float]:
    """The figures of one backend name (see the module docstring), its device fields set
    by ``settings``; ``paths`` defaults to the direct path, and the factored one where the
    arrays support it; on the 30 x 30 arena, or the 30 x 30 x 30 volume (``dims`` 3)
    with the ``moves`` set."""
    backend, options = parse_name(name, settings)
    arena = GridArena.empty(30, dims, moves)
    pairs = draw_pairs(arena, 100, EVAL_SEED)
    starts = np.ascontiguousarray(pairs.starts, dtype=np.int64)
    goals = np.ascontiguousarray(pairs.goals, dtype=np.int64)
    model = _model(arena, backend, options, 0)
    if paths is None:
        factored = all(getattr(a, "supports_factored", False) for a in model.arrays)
        paths = ("direct", "factored") if factored else ("direct",)
    out: dict[str, float] = {}
    for path in paths:
        suffix = "" if path == "direct" else f"_{path}"
        for explore in ("random", "mixed") if path == "direct" else ("random",):
            def run_train(r: int, explore: str = explore, path: str = path) -> float:
                config = TrainConfig(1, 50, explore) if r < 0 else TrainConfig(WALKS, STEPS,
                                                                               explore)
                return time_train(arena, config, max(r, 0), backend, options, path)

            key = f"train_step_us_{explore}" if path == "direct" else f"train_step_us{suffix}"
            per_step = _median_time(run_train, repeats)
            out[key] = per_step * 1e6
            if path != "direct":
                out[f"train_total_s{suffix}"] = per_step * WALKS * STEPS
        if path not in SCORERS:
            continue
        trained = _model(arena, backend, options, 0)  # trained by the protocol, seed 0
        train(trained, arena, TrainConfig(WALKS, STEPS), 0,
              path="factored" if path == "factored" else "direct", epoch=WALKS)

        def run_plan(r: int, path: str = path, model: CML = trained) -> float:
            return time_plan(model, arena, starts, goals, path)

        out[f"plan_step_us{suffix}"] = _median_time(run_plan, repeats) * 1e6
    return out


def ratios(float_figs: dict[str, float], fused: dict[str, float],
           others: dict[str, dict[str, float]]) -> dict[str, dict[str, float]]:
    """The ratios of the module docstring, from figures measured in one run."""
    out = {"float64 direct / fused": {
        "train": float_figs["train_step_us_random"] / fused["train_step_us_fused"],
        "plan": float_figs["plan_step_us"] / fused["plan_step_us_fused"],
        "goal": GOALS["direct"]}}
    if "train_step_us_factored" in float_figs:
        out["factored / fused factored"] = {
            "train": float_figs["train_step_us_factored"]
            / fused["train_step_us_fused_factored"], "goal": GOALS["factored"]}
    for name, figs in others.items():
        out[f"{name} / float64 direct"] = {
            "train": figs["train_step_us_random"] / float_figs["train_step_us_random"],
            "plan": figs["plan_step_us"] / float_figs["plan_step_us"],
            "goal": GOALS["device"]}
    return out


def per_synapse(plane: dict[str, float], space: dict[str, float], synapses: tuple[int, int]
                ) -> dict[str, float]:
    """The training step per synapse on the plane and in space (ns), their ratio and its
    goal, from one backend's figures in both (``train_step_us_random``) and the CML's
    weights in each (``synapses``)."""
    two = plane["train_step_us_random"] * 1e3 / synapses[0]
    three = space["train_step_us_random"] * 1e3 / synapses[1]
    return {"train_step_ns_per_synapse_2d": two, "train_step_ns_per_synapse_3d": three,
            "synapses_2d": synapses[0], "synapses_3d": synapses[1], "ratio": three / two,
            "goal": GOALS["space"]}


def synapse_counts(dims: int, moves: str) -> tuple[int, int]:
    """The CML's weights on the 30 x 30 plane (king moves) and in the ``dims``-D world."""
    plane, space = (CML.create(cml_config_for(a)).parameter_count()
                    for a in (GridArena.empty(30), GridArena.empty(30, dims, moves)))
    return plane, space


def run_bench(names: Sequence[str], repeats: int = 5,
              progress: Callable[[int, int], None] | None = None,
              settings: Sequence[str] = (), dims: int = 2,
              moves: str = "king") -> dict[str, object]:
    """``{"backends": {key: figures}, "yardstick": ..., "ratios": ...}`` for each name, with
    ``settings`` (``field=value``) applied to each named backend (its key then lists them,
    :func:`label`); float64 and the yardstick are always timed, as they are (the ratios'
    denominators). ``dims`` 3 (or ``moves`` face): also ``space``, each name's direct
    path in that world and its step per synapse against the plane's (module
    docstring)."""
    for name in names:
        parse_name(name, settings)
    in_space = (dims, moves) != (2, "king")
    total = len(names) + 1 + (len(dict.fromkeys(["float", *names])) if in_space else 0)
    fused = bench_backend("float", repeats, ("fused", "fused_factored"))
    if progress is not None:
        progress(1, total)
    keys = {label(name, settings): name for name in names}
    result: dict[str, dict[str, float]] = {}
    for i, key in enumerate(dict.fromkeys(["float", *keys])):
        result[key] = bench_backend(keys.get(key, "float"), repeats,
                                    settings=settings if key != "float" else ())
        if progress is not None:
            progress(min(i + 2, total), total)
    others = {n: f for n, f in result.items() if n != "float"}
    out = {"backends": {k: result[k] for k in keys}, "yardstick": fused,
           "ratios": ratios(result["float"], fused, others), "repeats": repeats,
           "walks": WALKS, "steps": STEPS, "settings": [s.strip() for s in settings]}
    if in_space:
        synapses = synapse_counts(dims, moves)
        space: dict[str, dict[str, float]] = {}
        for i, key in enumerate(dict.fromkeys(["float", *keys])):
            figs = bench_backend(keys.get(key, "float"), repeats, ("direct",),
                                 settings if key != "float" else (), dims, moves)
            space[key] = {**figs, **per_synapse(result[key], figs, synapses)}
            if progress is not None:
                progress(min(len(result) + 2 + i, total), total)
        out["space"] = {"dims": dims, "moves": moves, "backends": space}
    return out


ROBOT_BUDGETS = {"kinematic": (10, 900, 100), "mujoco": (1, 300, 5)}  # walks, steps, goals


def bench_robot(sims: Sequence[str], repeats: int = 5) -> dict[str, dict[str, float]]:
    """Simulated actions per second of the robot on each simulator (module docstring)."""
    from cml_edge.robot.models import evaluate_models, train_models
    from cml_edge.robot.observation import RobotCMLSettings
    from cml_edge.robot.planning import draw_goals
    from cml_edge.robot.sim import RobotConfig, make_sim
    from cml_edge.robot.training import RobotTrainConfig

    settings = RobotCMLSettings("heading")
    out = {}
    for name in sims:
        sim = make_sim(name, RobotConfig())
        walks, steps, n_goals = ROBOT_BUDGETS[name]
        goals = draw_goals(sim.config, n_goals, EVAL_SEED)
        train_rates, plan_rates = [], []
        for r in range(repeats):
            cmls, record = train_models([r], sim, settings, RobotTrainConfig(walks, steps),
                                        settings.cml_config(utility="raw"))
            train_rates.append(record["actions_per_s"])
            plan_rates.append(evaluate_models(cmls, sim, settings, goals)["actions_per_s"])
        out[name] = {"train_actions_per_s": statistics.median(train_rates),
                     "plan_actions_per_s": statistics.median(plan_rates),
                     "train_actions": walks * steps, "goals": n_goals}
    return out
