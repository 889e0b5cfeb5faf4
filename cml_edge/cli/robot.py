"""``cml-edge robot train | evaluate | navigate``: the continuous wheeled robot (paper 2.5, 3.5)."""

from __future__ import annotations

import argparse
from typing import Any

import numpy as np

from cml_edge.cli.args import finite_float, positive_float
from cml_edge.cli.output import num
from cml_edge.cli.vehicle import Vehicle, add_drive_options, add_run_options, add_vehicle_parsers
from cml_edge.cli.vehicle_commands import (
    World,
    run_vehicle,
    show_evaluate,
    show_navigate,
    show_train,
)
from cml_edge.errors import InputError
from cml_edge.robot.models import (
    asdict_options,
    load_robot_models,
    plot_robot_runs,
    save_robot_models,
)
from cml_edge.robot.observation import GOAL_HEADINGS, OBSERVATIONS, RobotCMLSettings
from cml_edge.robot.planning import BASE_POSE, GOAL_RADIUS, draw_goals
from cml_edge.robot.sim import MujocoOptions, RobotConfig, make_sim

MUJOCO = {"timestep": "physics step, s", "friction": "wheel-floor friction",
          "kv": "wheel velocity servo gain", "torque": "motor torque limit"}
"""The MuJoCo options of ``--sim mujoco``, each with its help."""


def _add_training(t: argparse.ArgumentParser) -> None:
    t.add_argument("--observation", choices=OBSERVATIONS, default="heading",
                   help="xy: the paper's (x, y); heading: (x, y, cos, sin) read in the "
                        "heading's frame (default); heading-world: the same in the world frame")
    t.add_argument("--goal-heading", choices=GOAL_HEADINGS, default="bearing",
                   help="default heading of o* for planning (bearing)")
    t.add_argument("--heading-scale", type=positive_float, default=None,
                   help="weight h of the heading components (default 1/30, as positions)")


def _add_planning(p: argparse.ArgumentParser) -> None:
    p.add_argument("--observation", choices=OBSERVATIONS, default=None,
                   help="check the model's observation (it is fixed at training)")
    p.add_argument("--goal-heading", choices=GOAL_HEADINGS, default=None,
                   help="heading of o* (default: the model's, bearing unless trained otherwise)")
    add_drive_options(p, "circle", "32 ms", GOAL_RADIUS)
    p.add_argument("--base", type=finite_float, nargs=3, metavar=("X", "Y", "THETA"),
                   default=list(BASE_POSE), help="start pose (default 2 2 pi/4)")
    add_run_options(p)


def add_parsers(subparsers) -> None:
    """``robot train|evaluate|navigate``."""
    add_vehicle_parsers(subparsers, Vehicle(
        name="robot", help="the continuous wheeled robot (paper 2.5, 3.5)", run=cmd_robot,
        commands={"train": ("train CMLs by random walks of the robot and save them",
                            show_robot_train),
                  "evaluate": ("drive to random goals from the base; the protocol's metrics",
                               show_robot_evaluate),
                  "navigate": ("drive to a few goals and plot them (Figure 9)",
                               show_robot_navigate)},
        plot="write a PNG like the paper's Figure 9", moves="drives", axes=("X", "Y"),
        exact="exact arcs", mujoco=MUJOCO, mujoco_defaults=MujocoOptions(), utility="raw",
        train_options=_add_training, planning_options=_add_planning))


def _trained(args: argparse.Namespace) -> tuple[RobotConfig, RobotCMLSettings]:
    return RobotConfig(), RobotCMLSettings(args.observation, args.goal_heading,
                                           args.heading_scale or RobotCMLSettings.heading_scale)


def _loaded(args: argparse.Namespace, meta: dict[str, Any]
            ) -> tuple[RobotConfig, RobotCMLSettings]:
    settings = RobotCMLSettings.from_dict(meta["settings"])
    if args.observation is not None and args.observation != settings.observation:
        raise InputError(f"--observation {args.observation}: the model was trained with the "
                         f"{settings.observation} observation")
    if args.goal_heading is not None:
        settings = RobotCMLSettings(**{**settings.to_dict(), "goal_heading": args.goal_heading})
    return RobotConfig.from_dict(meta["robot"]), settings


def _start(args: argparse.Namespace, robot: RobotConfig
           ) -> tuple[tuple[float, ...], dict[str, list[float]]]:
    base = tuple(float(b) for b in args.base)
    if not (robot.lo <= base[0] <= robot.hi and robot.lo <= base[1] <= robot.hi):
        raise InputError(f"--base {base[0]:g} {base[1]:g} puts the robot outside the arena "
                         f"(allowed: {robot.lo:g}..{robot.hi:g} m)")
    return base, {"base": list(base)}


def _record(robot: RobotConfig, settings: RobotCMLSettings) -> dict[str, Any]:
    return {"observation": settings.observation, "goal_heading": settings.goal_heading,
            "heading_scale": settings.heading_scale}


def _check_goal(goal: list[float], robot: RobotConfig) -> None:
    gx, gy = goal
    if not (0.0 <= gx <= robot.arena and 0.0 <= gy <= robot.arena):
        raise InputError(f"--goal {gx:g} {gy:g} is off the {robot.arena:g} x {robot.arena:g}"
                         f" m arena (allowed: 0..{robot.arena:g})")


def _title(settings: RobotCMLSettings, sim_name: str, reached: np.ndarray,
           radius: float) -> str:
    return (f"CML ({settings.observation} observation, {sim_name}): "
            f"{int(reached.sum())}/{len(reached)} goals reached")


ROBOT = World(name="robot", mujoco=MUJOCO, make_sim=make_sim, stored_mujoco=asdict_options,
              save=save_robot_models, load=load_robot_models, trained=_trained,
              loaded=_loaded, start=_start, record=_record, older_path=True,
              draw_goals=draw_goals, check_goal=_check_goal, plot=plot_robot_runs,
              title=_title)
"""What the robot's commands have of their own."""


def cmd_robot(args: argparse.Namespace) -> dict[str, Any]:
    """Run ``cml-edge robot ...``; the JSON-ready result. Bad input raises InputError."""
    return run_vehicle(ROBOT, args)


# what a person reads (--json: the result) ----------------------------------------
def show_robot_train(r: dict[str, Any]) -> None:
    """``robot train``: the models trained and where they were saved."""
    show_train("robot", r, rows=[("observation", f"{r['observation']} (goal heading "
                                                 f"{r['goal_heading']}, heading scale "
                                                 f"{num(r['heading_scale'])})")])


def show_robot_evaluate(r: dict[str, Any]) -> None:
    """``robot evaluate``: the protocol's table for the robot."""
    show_evaluate("robot", r, f", {r['observation']} observation")


def show_robot_navigate(r: dict[str, Any]) -> None:
    """``robot navigate``: one model driven to each goal."""
    show_navigate("robot", r, f"base ({num(r['base'][0])}, {num(r['base'][1])})")
