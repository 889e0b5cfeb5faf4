"""The ``train | evaluate | navigate`` parsers of a vehicle, the wheeled robot's
(:mod:`~cml_edge.cli.robot`) and the drone's (:mod:`~cml_edge.cli.drone`): one builder,
:func:`add_vehicle_parsers`, given what tells the two apart (:class:`Vehicle`), and the
option groups they share. The commands themselves are
:mod:`~cml_edge.cli.vehicle_commands`'s."""

from __future__ import annotations

import argparse
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from cml_edge.cli.args import add_backend, finite_float, nonneg_int, positive_float, positive_int
from cml_edge.core.cml import UTILITIES
from cml_edge.core.learning import SCHEDULES
from cml_edge.protocol import EVAL_SEED
from cml_edge.robot.planning import MAX_ACTIONS, PATHS, STOPS
from cml_edge.robot.sim import SIMS
from cml_edge.robot.training import RobotTrainConfig

AddOptions = Callable[[argparse.ArgumentParser], None]


@dataclass(frozen=True)
class Vehicle:
    """What tells one vehicle's commands from the other's."""

    name: str
    """The command group, as the model files are named in the help (``robot``)."""
    help: str
    """The group's help."""
    run: Callable[[argparse.Namespace], dict[str, Any]]
    """The group's command."""
    commands: Mapping[str, tuple[str, Callable[[dict[str, Any]], None]]]
    """``train``, ``evaluate`` and ``navigate``: each one's help and what a person reads of
    its result."""
    plot: str
    """``navigate --plot``'s help."""
    moves: str
    """What a model does to the vehicle (``drives``)."""
    axes: tuple[str, ...]
    """The goal's coordinates, as ``navigate --goal`` names them."""
    exact: str
    """What the kinematic simulator computes exactly (``exact arcs``)."""
    mujoco: Mapping[str, str]
    """The MuJoCo options: each field of ``mujoco_defaults`` with its help."""
    mujoco_defaults: Any
    """The MuJoCo simulator's options as they are by default."""
    utility: str
    """The planning utility ``train`` stores with the models by default."""
    train_options: AddOptions
    """Adds ``train``'s options of this vehicle (after ``--sim``)."""
    planning_options: AddOptions
    """Adds ``evaluate``'s and ``navigate``'s last options: this vehicle's own with
    :func:`add_drive_options` and :func:`add_run_options`."""


def add_vehicle_parsers(subparsers, v: Vehicle) -> None:
    """``NAME train|evaluate|navigate`` for the vehicle ``v``."""
    p = subparsers.add_parser(v.name, help=v.help)
    p.set_defaults(run=v.run)
    sub = p.add_subparsers(dest=f"{v.name}_command", required=True, parser_class=type(p))
    parsers = {name: sub.add_parser(name, help=text) for name, (text, _) in v.commands.items()}
    for name, (_, show) in v.commands.items():
        parsers[name].set_defaults(show=show)

    t = parsers["train"]
    _add_sim(t, v, "kinematic")
    v.train_options(t)
    t.add_argument("--utility", choices=UTILITIES, default=v.utility,
                   help=f"planning utility stored with the model ({v.utility})")
    _add_training_options(t)

    e = parsers["evaluate"]
    e.add_argument("model", nargs="+", help=f"{v.name} model file(s) (.npz); the models of "
                   "several files (trained alike) are pooled")
    _add_sim(e, v, None)
    e.add_argument("--trials", type=positive_int, default=100, help="random goals (100)")
    e.add_argument("--seeds", type=positive_int, default=None,
                   help="use the first N models (default all)")
    v.planning_options(e)

    n = parsers["navigate"]
    n.add_argument("model", help=f"{v.name} model file (.npz)")
    _add_sim(n, v, None)
    n.add_argument("--goal", type=finite_float, nargs=len(v.axes), metavar=v.axes,
                   default=None, help="one goal (default: --goals random goals)")
    n.add_argument("--goals", type=positive_int, default=10,
                   help="random goals from the evaluation seed (10)")
    n.add_argument("--model-index", type=nonneg_int, default=0,
                   help=f"which model of the file {v.moves} (0)")
    n.add_argument("--plot", default=None, help=v.plot)
    v.planning_options(n)


def _add_sim(p: argparse.ArgumentParser, v: Vehicle, default: str | None) -> None:
    tail = "default kinematic" if default else "default: the one the model was trained on"
    p.add_argument("--sim", choices=SIMS, default=default,
                   help=f"kinematic ({v.exact}, compiled) or mujoco (physics; the robot "
                        f"extra); {tail}")
    g = p.add_argument_group("mujoco options")
    for f, helptext in v.mujoco.items():
        g.add_argument(f"--mujoco-{f}", type=positive_float, default=None, metavar="X",
                       help=f"{helptext} (default {getattr(v.mujoco_defaults, f)})")


def add_drive_options(p: argparse.ArgumentParser, shape: str, step: str,
                      radius: float) -> None:
    """The planning options the robot and the drone share: the utility, the stop check (of
    the goal ``shape``, every simulation ``step``), the budget and the goal ``radius``."""
    p.add_argument("--utility", choices=UTILITIES, default=None,
                   help="planning utility (default: the model's)")
    p.add_argument("--stop", choices=STOPS, default="action",
                   help=f"check the goal {shape} after each action (the default) or at every "
                        f"{step} simulation step")
    p.add_argument("--max-actions", type=positive_int, default=MAX_ACTIONS,
                   help=f"action budget ({MAX_ACTIONS})")
    p.add_argument("--radius", type=positive_float, default=radius,
                   help=f"goal radius in m ({radius})")


def add_run_options(p: argparse.ArgumentParser) -> None:
    """The goals' seed, the compute path and ``--json``, for the robot and the drone."""
    p.add_argument("--eval-seed", type=nonneg_int, default=EVAL_SEED,
                   help=f"seed of the random goals ({EVAL_SEED})")
    p.add_argument("--path", choices=PATHS, default="direct",
                   help="compiled loop (direct) or plain-Python reference")
    p.add_argument("--json", action="store_true", help="print one JSON object on stdout")


def _add_training_options(t: argparse.ArgumentParser) -> None:
    """The ``train`` options the robot and the drone share: the walks, the device, the
    seeds, the compute path and the output."""
    t.add_argument("--walks", type=positive_int, default=RobotTrainConfig.walks,
                   help=f"exploration walks ({RobotTrainConfig.walks})")
    t.add_argument("--steps", type=positive_int, default=RobotTrainConfig.steps,
                   help=f"actions per walk ({RobotTrainConfig.steps})")
    t.add_argument("--schedule", choices=SCHEDULES, default="walk",
                   help="updates applied at the end of each walk (walk) or at once (step)")
    add_backend(t)
    t.add_argument("--seed", type=nonneg_int, default=0, help="first model seed (0)")
    t.add_argument("--seeds", type=positive_int, default=1,
                   help="models to train, seeds SEED..SEED+N-1, all in one file (1)")
    t.add_argument("--path", choices=PATHS, default="direct",
                   help="compiled loop (direct) or plain-Python reference")
    t.add_argument("--out", required=True, help="model file to write (.npz)")
    t.add_argument("--json", action="store_true", help="print one JSON object on stdout")
