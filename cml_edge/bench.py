"""Speed of the training and planning loops (``cml-edge bench``): figures, not assertions.

Each figure is the median over ``repeats`` timed runs after a compiling warm-up run:

- ``train_step_us_random`` / ``train_step_us_mixed``: one training step (exploration
  and the local rule) of the direct compiled loop, averaged over the paper's whole
  100 x 900-step training, as the paper's Table 3 averages;
- ``plan_step_us``: one planning step of the direct loop, over the protocol's 100 pairs;
- for the float64 array also ``train_step_us_factored``, ``plan_step_us_factored`` and
  ``train_total_s_factored`` (the whole 100 x 900 training).

``--robot SIM ...`` adds the wheeled robot (issue 8): simulated ``train_actions_per_s``
(random walks with the local rule, heading-aware CML, float64) and ``plan_actions_per_s``
(driving to goals from the base), each timed after a compiling warm-up: 10 walks x 900
actions and 100 goals on the kinematic simulator, 1 walk x 300 actions and 5 goals on
MuJoCo, which is physics-bound (its figures are in the README).
"""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable, Sequence

from cml_edge.core.cml import CML
from cml_edge.grid.arena import GridArena
from cml_edge.grid.evaluation import Training, default_path, train_and_evaluate
from cml_edge.grid.metrics import draw_pairs
from cml_edge.grid.planning import plan
from cml_edge.grid.training import TrainConfig
from cml_edge.protocol import EVAL_SEED

WALKS, STEPS = 100, 900


def _median_time(run: Callable[[int], float], repeats: int) -> float:
    run(-1)  # compile and warm up
    return statistics.median(run(r) for r in range(repeats))


def bench_backend(name: str, repeats: int = 5) -> dict[str, float]:
    """The figures of one backend (see the module docstring)."""
    arena = GridArena.empty(30)
    pairs = draw_pairs(arena, 100, EVAL_SEED)
    full = {e: TrainConfig(WALKS, STEPS, e) for e in ("random", "mixed")}
    warm = {e: TrainConfig(1, 50, e) for e in ("random", "mixed")}
    out: dict[str, float] = {}
    paths = ["direct"]  # the path device arrays emulate, and the one default_path adds
    if (extra := default_path(name)) not in paths:
        paths.append(extra)
    for path in paths:
        suffix = "" if path == "direct" else f"_{path}"
        explores = ("random", "mixed") if path == "direct" else ("random",)
        for explore in explores:
            def run_train(r: int, explore: str = explore, path: str = path) -> float:
                config = warm[explore] if r < 0 else full[explore]
                run = train_and_evaluate(max(r, 0), Training(arena, config, backend=name,
                                                             path=path, epoch=config.walks))
                return run.wall_s[-1] / (config.walks * config.steps)

            key = f"train_step_us_{explore}" if path == "direct" else f"train_step_us{suffix}"
            per_step = _median_time(run_train, repeats)
            out[key] = per_step * 1e6
            if path != "direct":
                out[f"train_total_s{suffix}"] = per_step * WALKS * STEPS
        model = train_and_evaluate(0, Training(arena, full["random"], backend=name,
                                               path=path)).cml

        def run_plan(r: int, path: str = path, model: CML = model) -> float:
            t0 = time.perf_counter()
            res = plan(model, arena, pairs.starts, pairs.goals, path=path)
            return (time.perf_counter() - t0) / max(int(res.steps.sum()), 1)

        out[f"plan_step_us{suffix}"] = _median_time(run_plan, repeats) * 1e6
    return out


def run_bench(names: Sequence[str], repeats: int = 5,
              progress: Callable[[int, int], None] | None = None) -> dict[str, object]:
    """``{"backends": {name: figures}}`` for each backend named."""
    result: dict[str, dict[str, float]] = {}
    for i, name in enumerate(names):
        result[name] = bench_backend(name, repeats)
        if progress is not None:
            progress(i + 1, len(names))
    return {"backends": result, "repeats": repeats, "walks": WALKS, "steps": STEPS}


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
