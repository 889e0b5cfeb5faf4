"""The drone (:mod:`cml_edge.drone.sim`): its protocol, model files and figures.

The CML loops are the robot's (:mod:`cml_edge.robot.training`,
:mod:`cml_edge.robot.planning`, :mod:`cml_edge.robot.fidelity`): they take the drone's
simulator and observation frame as plug-ins (its sizes and streams from the simulator),
so nothing of them is repeated here. This module puts them together for
``cml-edge drone train|evaluate|navigate`` (:mod:`cml_edge.cli.drone`).

Protocol: every model flies from the base, (2, 2, 2) m at rest (a bottom corner), to the
same ``trials`` goals, drawn uniformly on [0.5, 29.5]^3 from the evaluation seed (123) on
the drone's stream; a trial succeeds when the drone ends an action within 0.6 m of its
goal (:mod:`cml_edge.drone.observation` says why 0.6 m), within 100 actions (``--stop
step`` checks at every 50 ms simulation step instead). Pooled over the models:
``success_rate``, and over the successful trials ``mean_actions`` and ``path_ratio``
(length of the flown path, along the simulation steps, over the straight start-goal
distance); e_pos (Eq. 8) over all.

Model files: the robot's layout (:func:`cml_edge.robot.models.save_models`) under the
format ``cml-edge-drone-model``; ``meta`` holds the drone config, the observation
settings, the simulator and the training record.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from cml_edge.core.cml import CML, CMLConfig
from cml_edge.drone.observation import DroneCMLSettings
from cml_edge.drone.sim import SIMS, DroneConfig
from cml_edge.errors import InputError
from cml_edge.protocol import STREAM_DRONE_GOALS
from cml_edge.robot.models import load_models, save_models
from cml_edge.robot.planning import draw_goals

FORMAT = "cml-edge-drone-model"
FORMAT_VERSION = 1
MAX_ACTIONS = 100
GOAL_RADIUS = 0.6
BASE = (2.0, 2.0, 2.0)
"""The base, a bottom corner of the volume; the drone starts there at rest."""
GOAL_MARGIN = 0.5  # goals are drawn in [0.5, 29.5]^3


class DroneModelError(InputError):
    """A drone model file that is missing, corrupted, foreign or of another version."""


def base_state(base=BASE) -> np.ndarray:
    """The state (x, y, z, 0, 0, 0) of a start position: at rest."""
    return np.concatenate([np.asarray(base, dtype=np.float64), np.zeros(3)])


def draw_drone_goals(config: DroneConfig, trials: int, seed: int) -> np.ndarray:
    """``trials`` goals uniform on [0.5, side - 0.5]^3 from the evaluation ``seed``."""
    return draw_goals(config, trials, seed, GOAL_MARGIN, 3, STREAM_DRONE_GOALS)


def save_drone_models(path: str | Path, cmls: list[CML], meta: dict[str, Any]) -> None:
    """Write the CMLs of several seeds and their shared ``meta`` (JSON-able) atomically."""
    save_models(path, cmls, meta, FORMAT, FORMAT_VERSION)


def _check_meta(meta: dict[str, Any], config: CMLConfig) -> None:
    settings = DroneCMLSettings.from_dict(meta["settings"])
    DroneConfig.from_dict(meta["drone"])
    if meta["sim"] not in SIMS:
        raise InputError(f"unknown simulator {meta['sim']!r}")
    if (config.n_i, config.n_a) != (settings.n_i, 26):
        raise InputError(f"N_i = {config.n_i}, N_a = {config.n_a} do not fit the drone "
                         f"(3 and 26)")


def load_drone_models(path: str | Path) -> tuple[list[CML], dict[str, Any]]:
    """Load and validate a drone model file; returns its CMLs and its meta record."""
    return load_models(path, FORMAT, FORMAT_VERSION, DroneModelError, _check_meta,
                       {"cml-edge-model": " (a grid model: use cml-edge evaluate)",
                        "cml-edge-robot-model": " (a robot model: use cml-edge robot "
                                                "evaluate)"})


def plot_drone_runs(out: str | Path, config: DroneConfig, trails: list[np.ndarray],
                    goals: np.ndarray, reached: np.ndarray, base, radius: float = GOAL_RADIUS,
                    title: str | None = None) -> None:
    """A PNG of the volume's flights seen from three sides (the grid's 3-D views,
    :func:`cml_edge.io.figures.three_views`): the base (cross), the goals (stars, green
    when reached) and the trajectories flown."""
    from cml_edge.io.figures import pyplot, save_png, three_views

    plt = pyplot()
    colors = plt.get_cmap("tab10")
    S = config.arena
    edges = [(a, b) for a in range(8) for b in range(a + 1, 8) if bin(a ^ b).count("1") == 1]
    corners = np.array([[(c >> k & 1) * S for k in range(3)] for c in range(8)])

    def draw(ax) -> None:
        for a, b in edges:  # the volume's wireframe
            ax.plot(*corners[[a, b]].T, color="0.6", linewidth=0.6)
        for i, (trail, goal, ok) in enumerate(zip(trails, goals, reached)):
            ax.plot(*trail[:, :3].T, "-", color=colors(i % 10), linewidth=1.1)
            ax.plot(*[[v] for v in goal], "*", markersize=11,
                    color="tab:green" if ok else "tab:red", markeredgecolor="k",
                    markeredgewidth=0.4)
        ax.plot(*[[v] for v in base[:3]], "x", color="k", markersize=10, mew=3, label="base")
        ax.plot([], [], "*", color="tab:green", markeredgecolor="k", label="goal reached")
        ax.plot([], [], "*", color="tab:red", markeredgecolor="k", label="goal missed")

    n_ok = int(np.sum(reached))
    fig = three_views(draw, (-0.5, S + 0.5), title or
                      f"CML flying the drone: {n_ok}/{len(goals)} goals reached "
                      f"(within {radius:g} m)", " (m)")
    save_png(fig, out)
    plt.close(fig)
