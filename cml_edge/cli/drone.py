"""``cml-edge drone train | evaluate | navigate``: the drone in a walled volume
(:mod:`cml_edge.drone`), shaped like ``cml-edge robot``."""

from __future__ import annotations

import argparse
from typing import Any

import numpy as np

from cml_edge.cli.args import finite_float
from cml_edge.cli.output import num
from cml_edge.cli.vehicle import Vehicle, add_drive_options, add_run_options, add_vehicle_parsers
from cml_edge.cli.vehicle_commands import (
    World,
    run_vehicle,
    show_evaluate,
    show_navigate,
    show_train,
)
from cml_edge.drone.models import (
    BASE,
    GOAL_RADIUS,
    base_state,
    draw_drone_goals,
    load_drone_models,
    plot_drone_runs,
    save_drone_models,
)
from cml_edge.drone.observation import DEFAULT_UTILITY, DroneCMLSettings
from cml_edge.drone.sim import ENDS, DroneConfig, DroneMujocoOptions, make_drone_sim
from cml_edge.errors import InputError

MUJOCO = {"timestep": "physics step, s", "kv": "velocity servo gain, N s/m"}
"""The MuJoCo options of ``--sim mujoco``, each with its help."""


def _add_training(t: argparse.ArgumentParser) -> None:
    t.add_argument("--ends", choices=ENDS, default="rest",
                   help="each action ends at rest (default: the CML's model exact) or at "
                        "its commanded velocity")


def _add_planning(p: argparse.ArgumentParser) -> None:
    add_drive_options(p, "sphere", "50 ms", GOAL_RADIUS)
    p.add_argument("--start", type=finite_float, nargs=3, metavar=("X", "Y", "Z"),
                   default=list(BASE), help="start position, at rest (default 2 2 2)")
    add_run_options(p)


def add_parsers(subparsers) -> None:
    """``drone train|evaluate|navigate``."""
    add_vehicle_parsers(subparsers, Vehicle(
        name="drone", help="a drone in a walled 3-D volume (paper section 5)", run=cmd_drone,
        commands={"train": ("train CMLs by random flights of the drone and save them",
                            show_drone_train),
                  "evaluate": ("fly to random goals from the base", show_drone_evaluate),
                  "navigate": ("fly to a few goals and plot them from three sides",
                               show_drone_navigate)},
        plot="write a PNG of the flights in three views", moves="flies",
        axes=("X", "Y", "Z"), exact="exact", mujoco=MUJOCO,
        mujoco_defaults=DroneMujocoOptions(), utility=DEFAULT_UTILITY,
        train_options=_add_training, planning_options=_add_planning))


def _trained(args: argparse.Namespace) -> tuple[DroneConfig, DroneCMLSettings]:
    return DroneConfig(ends=args.ends), DroneCMLSettings()


def _loaded(args: argparse.Namespace, meta: dict[str, Any]
            ) -> tuple[DroneConfig, DroneCMLSettings]:
    return DroneConfig.from_dict(meta["drone"]), DroneCMLSettings.from_dict(meta["settings"])


def _stored_mujoco(sim) -> dict[str, float]:
    return {f: getattr(sim.options, f) for f in MUJOCO}


def _start(args: argparse.Namespace, drone: DroneConfig
           ) -> tuple[np.ndarray, dict[str, list[float]]]:
    start = tuple(float(b) for b in args.start)
    if not all(drone.lo <= v <= drone.hi for v in start):
        raise InputError(f"--start {start[0]:g} {start[1]:g} {start[2]:g} puts the drone "
                         f"outside the volume (allowed: {drone.lo:g}..{drone.hi:g} m)")
    state = base_state(start)
    return state, {"start": state[:3].tolist()}


def _record(drone: DroneConfig, settings: DroneCMLSettings) -> dict[str, Any]:
    return {"ends": drone.ends}


def _check_goal(goal: list[float], drone: DroneConfig) -> None:
    if not all(0.0 <= v <= drone.arena for v in goal):
        raise InputError(f"--goal {' '.join(f'{v:g}' for v in goal)} is outside the "
                         f"{drone.arena:g} m volume (allowed: 0..{drone.arena:g} on every "
                         f"axis)")


def _title(settings: DroneCMLSettings, sim_name: str, reached: np.ndarray,
           radius: float) -> str:
    return (f"CML flying the drone ({sim_name}): {int(reached.sum())}/{len(reached)} goals "
            f"within {radius:g} m")


DRONE = World(name="drone", mujoco=MUJOCO, make_sim=make_drone_sim,
              stored_mujoco=_stored_mujoco, save=save_drone_models, load=load_drone_models,
              trained=_trained, loaded=_loaded, start=_start, record=_record,
              older_path=False, draw_goals=draw_drone_goals, check_goal=_check_goal,
              plot=plot_drone_runs, title=_title)
"""What the drone's commands have of their own."""


def cmd_drone(args: argparse.Namespace) -> dict[str, Any]:
    """Run ``cml-edge drone ...``; the JSON-ready result. Bad input raises InputError."""
    return run_vehicle(DRONE, args)


# what a person reads (--json: the result) ----------------------------------------
def show_drone_train(r: dict[str, Any]) -> None:
    """``drone train``: the models trained and where they were saved."""
    show_train("drone", r, f", actions ending {'at rest' if r['ends'] == 'rest' else 'moving'}")


def show_drone_evaluate(r: dict[str, Any]) -> None:
    """``drone evaluate``: the protocol's table for the drone."""
    show_evaluate("drone", r)


def show_drone_navigate(r: dict[str, Any]) -> None:
    """``drone navigate``: one model flown to each goal."""
    s = r["start"]
    show_navigate("drone", r, f"({num(s[0])}, {num(s[1])}, {num(s[2])})")
