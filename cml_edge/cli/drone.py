"""``cml-edge drone train | evaluate | navigate``: the drone in a walled volume
(:mod:`cml_edge.drone`), shaped like ``cml-edge robot``."""

from __future__ import annotations

import argparse
from typing import Any

import numpy as np

from cml_edge import __version__
from cml_edge.cli.args import Progress, backend_options, command_line, finite_float
from cml_edge.cli.output import device_label, fidelity_rows, labelled, num, plural, secs, table
from cml_edge.cli.robot import _robot_rows, _seed_range, evaluate_pooled, load_pooled, set_utility
from cml_edge.cli.vehicle import Vehicle, add_drive_options, add_run_options, add_vehicle_parsers
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
from cml_edge.engine.timings import stage
from cml_edge.errors import InputError
from cml_edge.io.files import writable_file
from cml_edge.robot.models import train_models
from cml_edge.robot.planning import plan_robot, summarize_robot
from cml_edge.robot.training import RobotTrainConfig

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


def _make_sim(name: str, drone: DroneConfig, args: argparse.Namespace,
              stored: dict[str, float] | None = None):
    given = {f: getattr(args, f"mujoco_{f}") for f in MUJOCO
             if getattr(args, f"mujoco_{f}", None) is not None}
    if name != "mujoco" and given:
        raise InputError("--mujoco-* options need --sim mujoco")
    return make_drone_sim(name, drone, **({**(stored or {}), **given} if name == "mujoco"
                                          else {}))


def _cmd_train(args: argparse.Namespace) -> dict[str, Any]:
    writable_file(args.out, "--out")
    options = backend_options(args)
    drone = DroneConfig(ends=args.ends)
    settings = DroneCMLSettings()
    config = RobotTrainConfig(args.walks, args.steps, args.schedule)
    sim = _make_sim(args.sim, drone, args)
    seeds = list(range(args.seed, args.seed + args.seeds))
    with stage("train"):
        cmls, record = train_models(seeds, sim, settings, config,
                                    settings.cml_config(utility=args.utility), args.backend,
                                    args.path, Progress("drone train"), options)
    record.update({"command": command_line(), "cml_edge_version": __version__})
    mujoco = ({f: getattr(sim.options, f) for f in MUJOCO} if args.sim == "mujoco" else None)
    with stage("write"):
        save_drone_models(args.out, cmls, {"drone": drone.to_dict(),
                                           "settings": settings.to_dict(), "sim": args.sim,
                                           "mujoco": mujoco, "training": record})
    return {"model": args.out, "sim": args.sim, "ends": drone.ends, "utility": args.utility,
            "backend": args.backend, "backend_options": options, "walks": config.walks,
            "steps": config.steps, "schedule": config.schedule, "seeds": seeds,
            "compute_path": args.path, "eq3_gain": record["eq3_gain"],
            "final_train_error": [e[-1] for e in record["train_error"]],
            "wall_time_s": record["wall_time_s"], "actions_per_s": record["actions_per_s"],
            "command": record["command"], "cml_edge_version": __version__}


def _load_for_planning(args: argparse.Namespace):
    if getattr(args, "plot", None):
        writable_file(args.plot, "--plot")
    cmls, meta = load_pooled(args.model, load_drone_models, "drone")
    settings = DroneCMLSettings.from_dict(meta["settings"])
    set_utility(cmls, args.utility)
    drone = DroneConfig.from_dict(meta["drone"])
    sim_name = args.sim or meta["sim"]
    sim = _make_sim(sim_name, drone, args, meta.get("mujoco") if meta["sim"] == "mujoco" else None)
    start = tuple(float(b) for b in args.start)
    if not all(drone.lo <= v <= drone.hi for v in start):
        raise InputError(f"--start {start[0]:g} {start[1]:g} {start[2]:g} puts the drone "
                         f"outside the volume (allowed: {drone.lo:g}..{drone.hi:g} m)")
    return cmls, meta, settings, drone, sim, sim_name, base_state(start)


def _planning_record(args, meta, cmls, drone, sim_name, start) -> dict[str, Any]:
    return {"model": args.model, "sim": sim_name, "trained_on": meta["sim"],
            "ends": drone.ends, "utility": cmls[0].config.utility, "backend": cmls[0].backend,
            "stop": args.stop, "radius": args.radius, "max_actions": args.max_actions,
            "start": start[:3].tolist(), "eval_seed": args.eval_seed,
            "compute_path": args.path, "training_walks": meta["training"].get("walks"),
            "training_steps": meta["training"].get("steps"),
            "command": command_line(), "cml_edge_version": __version__}


def _cmd_evaluate(args: argparse.Namespace) -> dict[str, Any]:
    cmls, meta, settings, drone, sim, sim_name, start = _load_for_planning(args)
    cmls, result = evaluate_pooled(args, cmls, meta, sim, settings,
                                   lambda: draw_drone_goals(drone, args.trials, args.eval_seed),
                                   tuple(start),
                                   make_drone_sim("kinematic", drone),
                                   f"drone evaluate ({sim_name})")
    return {**_planning_record(args, meta, cmls, drone, sim_name, start), **result}


def _cmd_navigate(args: argparse.Namespace) -> dict[str, Any]:
    cmls, meta, settings, drone, sim, sim_name, start = _load_for_planning(args)
    if args.model_index >= len(cmls):
        raise InputError(f"--model-index {args.model_index}: the model file holds "
                         f"{len(cmls)} models (allowed: 0..{len(cmls) - 1})")
    if args.goal is not None:
        if not all(0.0 <= v <= drone.arena for v in args.goal):
            raise InputError(f"--goal {' '.join(f'{v:g}' for v in args.goal)} is outside the "
                             f"{drone.arena:g} m volume (allowed: 0..{drone.arena:g} on every "
                             f"axis)")
        goals = np.array([args.goal], dtype=np.float64)
    else:
        goals = draw_drone_goals(drone, args.goals, args.eval_seed)
    starts = np.tile(start, (len(goals), 1))
    res = plan_robot(cmls[args.model_index], sim, settings, starts, goals, args.max_actions,
                     args.radius, args.path, keep_paths=True, stop=args.stop)
    out = {**_planning_record(args, meta, cmls, drone, sim_name, start),
           "model_index": args.model_index, **summarize_robot(res, starts, goals),
           "runs": {"goals": goals.tolist(), "reached": res.reached.tolist(),
                    "actions": res.steps.tolist(), "final": res.final[:, :3].tolist(),
                    "path_length": res.length.tolist()}}
    if args.plot:
        plot_drone_runs(args.plot, drone, res.paths, goals, res.reached, start, args.radius,
                        title=f"CML flying the drone ({sim_name}): "
                              f"{int(res.reached.sum())}/{len(goals)} goals within "
                              f"{args.radius:g} m")
        out["plot"] = args.plot
    return out


def cmd_drone(args: argparse.Namespace) -> dict[str, Any]:
    """Run ``cml-edge drone ...``; the JSON-ready result. Bad input raises InputError."""
    commands = {"train": _cmd_train, "evaluate": _cmd_evaluate, "navigate": _cmd_navigate}
    return commands[args.drone_command](args)


# what a person reads (--json: the result) ----------------------------------------
def show_drone_train(r: dict[str, Any]) -> None:
    """``drone train``: the models trained and where they were saved."""
    print(f"drone train: {plural(len(r['seeds']), 'model')} ({_seed_range(r['seeds'])}) on "
          f"{r['sim']}, {r['walks']} walks x {r['steps']} actions ({r['schedule']} schedule), "
          f"actions ending {'at rest' if r['ends'] == 'rest' else 'moving'}")
    print("\n".join(labelled([
        ("device", device_label(r["backend"], r.get("backend_options"))),
        ("model", r["model"]),
        ("final training error", ", ".join(num(e) for e in r["final_train_error"])),
        ("time", f"{secs(r['wall_time_s'])} ({num(r['actions_per_s'])} actions/s)")])))


def show_drone_evaluate(r: dict[str, Any]) -> None:
    """``drone evaluate``: the protocol's table for the drone."""
    print(f"drone evaluate: {plural(r['seeds'], 'model')} x {plural(r['trials'], 'goal')} on "
          f"{r['sim']} (trained on {r['trained_on']})")
    print("\n".join(labelled([*_robot_rows(r), *fidelity_rows(r),
                              ("time", f"{secs(r['wall_time_s'])} "
                                       f"({num(r['actions_per_s'])} actions/s)")])))


def show_drone_navigate(r: dict[str, Any]) -> None:
    """``drone navigate``: one model flown to each goal."""
    s = r["start"]
    print(f"drone navigate: model {r['model_index']} to {plural(r['trials'], 'goal')} on "
          f"{r['sim']}, from ({num(s[0])}, {num(s[1])}, {num(s[2])}) m")
    rows = [[f"({num(g[0])}, {num(g[1])}, {num(g[2])})", num(ok), f"{a:,}", num(d)]
            for g, ok, a, d in zip(r["runs"]["goals"], r["runs"]["reached"],
                                   r["runs"]["actions"], r["runs"]["path_length"])]
    print("\n".join(labelled([*_robot_rows(r), ("plot", r.get("plot"))])))
    if len(rows) <= 10:
        print("\n".join("  " + line for line in table(rows, ["goal (m)", "reached", "actions",
                                                              "path (m)"])))
