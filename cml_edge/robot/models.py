"""The continuous wheeled robot (paper 2.5, 3.5): model files, the evaluation protocol, figures.

The pieces live in :mod:`cml_edge.robot.sim` (arena, robot, kinematic and MuJoCo
simulators), :mod:`cml_edge.robot.observation`, :mod:`cml_edge.robot.training` and
:mod:`cml_edge.robot.planning`; this module puts them together for
``cml-edge robot train|evaluate|navigate`` (:mod:`cml_edge.cli.robot`).

Model files. One ``.npz`` (no pickles) holds the CMLs of one or more training seeds:
``format`` ("cml-edge-robot-model"), ``format_version``, ``meta`` (JSON: the CML config,
the backend, the robot config, the observation settings, the simulator and the training
record) and each array's ``state_dict`` under ``m<i>/W_q/``, ``m<i>/W_k/``, ``m<i>/W_v/``.
Loading checks all of it. Files are written under a temporary name and renamed.

Protocol: every model drives the robot from the base pose (2, 2) m facing the
centre (bottom left) to the same ``trials`` goals, drawn uniformly on [0.5, 29.5]^2 from
the evaluation seed (123); a trial succeeds when the robot ends an action within 0.25 m
of its goal, within 100 actions (``--stop step`` checks at every 32 ms simulation step
instead, so passing through the circle counts). Pooled over the models (one per training
seed; ``evaluate`` pools several files trained alike): ``success_rate``, and over the
successful trials ``mean_actions`` and ``path_ratio`` (length of the driven path, along
the simulation steps, over the straight start-goal distance); e_pos (Eq. 8) over all.
Speed (``actions_per_s``) is timed after a warm-up call, so it excludes compilation.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from cml_edge.core.cml import CML, CMLConfig
from cml_edge.core.model_file import cml_arrays, cml_from_arrays, read_npz
from cml_edge.errors import InputError, PluginError
from cml_edge.io.files import atomic_write
from cml_edge.robot.observation import RobotCMLSettings
from cml_edge.robot.planning import (
    BASE_POSE,
    GOAL_RADIUS,
    MAX_ACTIONS,
    RobotPlanResult,
    plan_robot,
    summarize_robot,
)
from cml_edge.robot.sim import SIMS, RobotConfig, RobotSim
from cml_edge.robot.training import RobotTrainConfig, train_robot

FORMAT = "cml-edge-robot-model"
FORMAT_VERSION = 1


class RobotModelError(InputError):
    """A robot model file that is missing, corrupted, foreign or of another version."""


# model files --------------------------------------------------------------------------
def save_robot_models(path: str | Path, cmls: list[CML], meta: dict[str, Any]) -> None:
    """Write the CMLs of several seeds and their shared ``meta`` (JSON-able) atomically."""
    save_models(path, cmls, meta, FORMAT, FORMAT_VERSION)


def save_models(path: str | Path, cmls: list[CML], meta: dict[str, Any], fmt: str,
                version: int) -> None:
    """Write the CMLs of several seeds and their shared ``meta`` as format ``fmt`` (the
    robot's, the drone's) at ``version``, atomically."""
    if not cmls:
        raise InputError("no models to save")
    arrays: dict[str, np.ndarray] = {
        "format": np.array(fmt),
        "format_version": np.array(version),
        "meta": np.array(json.dumps({**meta, "config": cmls[0].config.to_dict(),
                                     "backend": cmls[0].backend, "n_models": len(cmls)},
                                    sort_keys=True)),
    }
    for i, cml in enumerate(cmls):
        arrays.update(cml_arrays(cml, f"m{i}/"))
    atomic_write(path, lambda f: np.savez(f, **arrays))


def load_robot_models(path: str | Path) -> tuple[list[CML], dict[str, Any]]:
    """Load and validate a robot model file; returns its CMLs and its meta record."""

    def check(meta: dict[str, Any], config: CMLConfig) -> None:
        settings = RobotCMLSettings.from_dict(meta["settings"])
        RobotConfig.from_dict(meta["robot"])
        if meta["sim"] not in SIMS:
            raise InputError(f"unknown simulator {meta['sim']!r}")
        if config.n_i != settings.n_i:
            raise InputError(f"N_i = {config.n_i} does not fit the {settings.observation} "
                             f"observation")

    return load_models(path, FORMAT, FORMAT_VERSION, RobotModelError, check,
                       {"cml-edge-model": " (a grid model: use cml-edge evaluate)",
                        "cml-edge-drone-model": " (a drone model: use cml-edge drone "
                                                "evaluate)"})


def load_models(path: str | Path, fmt: str, version: int, error: type[InputError],
                check: Callable[[dict[str, Any], CMLConfig], None],
                foreign: dict[str, str]) -> tuple[list[CML], dict[str, Any]]:
    """Load and validate a model file of format ``fmt`` at ``version`` (``check`` validates
    the world's part of the meta record; ``error`` for anything wrong, with ``foreign``'s
    hint for a known other format); returns its CMLs and its meta record."""
    name = str(path)
    data = read_npz(path, fmt, version, error, foreign)
    what = fmt.removeprefix("cml-edge-").replace("-", " ")
    try:
        meta = json.loads(str(data["meta"]))
        config = CMLConfig.from_dict(meta["config"])
        check(meta, config)
        n = int(meta["n_models"])
        if n < 1:
            raise InputError(f"n_models {n} < 1")
        cmls = [cml_from_arrays(data, config, meta["backend"], f"m{i}/") for i in range(n)]
    except PluginError as exc:  # a device of a plugin that is not loaded
        raise error(f"{name!r}: {exc}") from None
    except (KeyError, TypeError, ValueError, json.JSONDecodeError) as exc:
        raise error(f"{name!r} is a corrupted {what} file: {exc}") from None
    return cmls, meta


# training and the protocol ----------------------------------------------------------------
def train_models(seeds: list[int], sim: RobotSim, settings: RobotCMLSettings,
                 config: RobotTrainConfig, cml_config: CMLConfig, backend: str = "float",
                 path: str = "direct", progress=None,
                 backend_options: dict[str, Any] | None = None
                 ) -> tuple[list[CML], dict[str, Any]]:
    """Train one CML per seed on ``sim``, its arrays on ``backend`` with
    ``backend_options`` (the device's fields, e.g. a preset); returns them and the
    training record."""
    options = dict(backend_options or {})
    cmls, errors, gains = [], [], []
    # compile first (a one-action walk on a throwaway CML), so the timing is the loop's
    train_robot(CML.create(cml_config, backend, 0, **options), sim, settings,
                RobotTrainConfig(1, 1), 0, path)
    t0 = time.perf_counter()
    total = len(seeds) * config.walks
    for n, seed in enumerate(seeds):
        cml = CML.create(cml_config, backend, seed, **options)

        def on_walk(done: int, n: int = n) -> None:
            if progress is not None:
                progress(n * config.walks + done, total)

        info = train_robot(cml, sim, settings, config, seed, path=path, on_walk=on_walk)
        cmls.append(cml)
        errors.append(info["train_error"].tolist())
        gains.append(info["eq3_gain"])
    wall = time.perf_counter() - t0
    record = {"walks": config.walks, "steps": config.steps, "schedule": config.schedule,
              "seeds": [int(s) for s in seeds], "path": path, "backend_options": options,
              "train_error": errors, "eq3_gain": gains, "wall_time_s": wall,
              "actions_per_s": len(seeds) * config.walks * config.steps / max(wall, 1e-9)}
    return cmls, record


def evaluate_models(cmls: list[CML], sim: RobotSim, settings: RobotCMLSettings, goals: np.ndarray,
                    base: tuple[float, float, float] = BASE_POSE,
                    max_actions: int = MAX_ACTIONS, radius: float = GOAL_RADIUS,
                    stop: str = "action", path: str = "direct",
                    progress=None, twins: list[tuple[int, CML]] | None = None
                    ) -> dict[str, Any]:
    """Drive each model from ``base`` to every goal; pooled and per-model metrics. With
    ``twins`` ((seed, float64 twin) per model, :mod:`cml_edge.robot.fidelity`), also each
    model's weight error, decision agreement and read SNR, pooled over the models
    (:func:`cml_edge.core.fidelity.pool_seeds`)."""
    from cml_edge.core.fidelity import TWIN, pool_seeds
    from cml_edge.robot.fidelity import robot_seed_fidelity

    starts = np.tile(np.asarray(base, dtype=np.float64), (len(goals), 1))
    results: list[RobotPlanResult] = []
    per_seed = []
    plan_robot(cmls[0], sim, settings, starts[:1], goals[:1], 1, radius, path, stop=stop)  # compile
    t0 = time.perf_counter()
    for n, cml in enumerate(cmls):
        res = plan_robot(cml, sim, settings, starts, goals, max_actions, radius, path, stop=stop)
        results.append(res)
        per_seed.append(summarize_robot(res, starts, goals))
        if progress is not None:
            progress(n + 1, len(cmls))
    wall = time.perf_counter() - t0
    for (seed, twin), cml, res, entry in zip(twins or [], cmls, results, per_seed):
        entry.update(robot_seed_fidelity(seed, cml, twin, sim, settings, goals, res))
    pooled = RobotPlanResult(*(np.concatenate(arrays) for arrays in zip(*results)))
    all_starts = np.concatenate([starts] * len(cmls))
    summary = summarize_robot(pooled, all_starts, np.concatenate([goals] * len(cmls)))
    actions = int(pooled.steps.sum())
    fidelity = {**pool_seeds(per_seed), "fidelity_twin": TWIN} if twins is not None else {}
    return {**summary, "seeds": len(cmls), "trials": int(len(goals)), "per_seed": per_seed,
            "actions": actions, "wall_time_s": wall, "actions_per_s": actions / max(wall, 1e-9),
            **fidelity}


# figures ------------------------------------------------------------------------------
def plot_robot_runs(out: str | Path, config: RobotConfig, trails: list[np.ndarray],
                    goals: np.ndarray, reached: np.ndarray, base, radius: float = GOAL_RADIUS,
                    title: str | None = None) -> None:
    """A PNG like the paper's Figure 9: the arena, the base (bottom left), the goals (stars,
    green when reached) with their 0.25 m circles, and the trajectories driven."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from cml_edge.io.figures import save_png

    fig, ax = plt.subplots(figsize=(6, 6))
    S = config.arena
    ax.add_patch(plt.Rectangle((0, 0), S, S, fill=False, linewidth=2, color="0.2"))
    ax.set_xlim(-0.5, S + 0.5)
    ax.set_ylim(-0.5, S + 0.5)
    ax.set_aspect("equal")
    ax.grid(color="0.92", linewidth=0.5)
    colors = plt.get_cmap("tab10")
    for i, (trail, goal, ok) in enumerate(zip(trails, goals, reached)):
        c = colors(i % 10)
        ax.plot(trail[:, 0], trail[:, 1], "-", color=c, linewidth=1.2)
        ax.add_patch(plt.Circle(goal, radius, fill=False, color=c, linewidth=0.8))
        ax.plot(*goal, "*", markersize=13, color="tab:green" if ok else "tab:red",
                markeredgecolor="k", markeredgewidth=0.5)
    ax.plot(base[0], base[1], "x", color="k", markersize=12, mew=3, label="base")
    ax.plot([], [], "*", color="tab:green", markeredgecolor="k", label="goal reached")
    ax.plot([], [], "*", color="tab:red", markeredgecolor="k", label="goal missed")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    n_ok = int(np.sum(reached))
    ax.set_title(title or f"CML driving the robot: {n_ok}/{len(goals)} goals reached")
    ax.legend(loc="upper left", bbox_to_anchor=(1.02, 1.0), fontsize=8, frameon=False)
    save_png(fig, out)
    plt.close(fig)


def asdict_options(sim: RobotSim) -> dict[str, float] | None:
    options = getattr(sim, "options", None)
    return None if options is None else {f: getattr(options, f) for f in
                                         ("timestep", "friction", "kv", "torque", "mass",
                                          "com_x")}
