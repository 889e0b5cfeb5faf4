"""``cml-edge robot train | evaluate | navigate``: the continuous wheeled robot (paper 2.5, 3.5)."""

from __future__ import annotations

import argparse
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from cml_edge import __version__
from cml_edge.cli.args import (
    Progress,
    backend_options,
    command_line,
    finite_float,
    positive_float,
)
from cml_edge.cli.output import (
    device_label,
    fidelity_rows,
    labelled,
    num,
    pct,
    plural,
    secs,
    table,
)
from cml_edge.cli.vehicle import Vehicle, add_drive_options, add_run_options, add_vehicle_parsers
from cml_edge.core.cml import CMLConfig
from cml_edge.engine.timings import stage
from cml_edge.errors import InputError
from cml_edge.io.files import writable_file
from cml_edge.robot.models import (
    asdict_options,
    evaluate_models,
    load_robot_models,
    plot_robot_runs,
    save_robot_models,
    train_models,
)
from cml_edge.robot.observation import GOAL_HEADINGS, OBSERVATIONS, RobotCMLSettings
from cml_edge.robot.planning import BASE_POSE, GOAL_RADIUS, draw_goals, plan_robot, summarize_robot
from cml_edge.robot.sim import MujocoOptions, RobotConfig, RobotSim, make_sim
from cml_edge.robot.training import RobotTrainConfig

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


def _mujoco_options(args: argparse.Namespace) -> dict[str, float]:
    return {f: getattr(args, f"mujoco_{f}") for f in MUJOCO
            if getattr(args, f"mujoco_{f}", None) is not None}


def _make_sim(name: str, robot: RobotConfig, args: argparse.Namespace,
              stored: dict[str, float] | None = None) -> RobotSim:
    options = {**(stored or {}), **_mujoco_options(args)} if name == "mujoco" else {}
    if name != "mujoco" and _mujoco_options(args):
        raise InputError("--mujoco-* options need --sim mujoco")
    return make_sim(name, robot, **options)


def _cmd_train(args: argparse.Namespace) -> dict[str, Any]:
    writable_file(args.out, "--out")
    options = backend_options(args)
    robot = RobotConfig()
    settings = RobotCMLSettings(args.observation, args.goal_heading,
                                args.heading_scale or RobotCMLSettings.heading_scale)
    config = RobotTrainConfig(args.walks, args.steps, args.schedule)
    sim = _make_sim(args.sim, robot, args)
    seeds = list(range(args.seed, args.seed + args.seeds))
    with stage("train"):
        cmls, record = train_models(seeds, sim, settings, config,
                                    settings.cml_config(utility=args.utility), args.backend,
                                    args.path, Progress("robot train"), options)
    record.update({"command": command_line(),
                   "cml_edge_version": __version__})
    mujoco = asdict_options(sim) if args.sim == "mujoco" else None
    with stage("write"):
        save_robot_models(args.out, cmls, {"robot": robot.to_dict(),
                                           "settings": settings.to_dict(), "sim": args.sim,
                                           "mujoco": mujoco, "training": record})
    return {"model": args.out, "sim": args.sim, "observation": settings.observation,
            "goal_heading": settings.goal_heading, "heading_scale": settings.heading_scale,
            "utility": args.utility, "backend": args.backend, "backend_options": options,
            "walks": config.walks,
            "steps": config.steps, "schedule": config.schedule, "seeds": seeds,
            "compute_path": args.path, "path": args.path, "eq3_gain": record["eq3_gain"],
            "final_train_error": [e[-1] for e in record["train_error"]],
            "wall_time_s": record["wall_time_s"], "actions_per_s": record["actions_per_s"],
            "command": record["command"], "cml_edge_version": __version__}


def _load_for_planning(args: argparse.Namespace):
    if getattr(args, "plot", None):
        writable_file(args.plot, "--plot")
    cmls, meta = load_pooled(args.model, load_robot_models, "robot")
    settings = RobotCMLSettings.from_dict(meta["settings"])
    if args.observation is not None and args.observation != settings.observation:
        raise InputError(f"--observation {args.observation}: the model was trained with the "
                         f"{settings.observation} observation")
    if args.goal_heading is not None:
        settings = RobotCMLSettings(**{**settings.to_dict(), "goal_heading": args.goal_heading})
    set_utility(cmls, args.utility)
    robot = RobotConfig.from_dict(meta["robot"])
    sim_name = args.sim or meta["sim"]
    sim = _make_sim(sim_name, robot, args, meta.get("mujoco") if meta["sim"] == "mujoco" else None)
    base = tuple(float(b) for b in args.base)
    if not (robot.lo <= base[0] <= robot.hi and robot.lo <= base[1] <= robot.hi):
        raise InputError(f"--base {base[0]:g} {base[1]:g} puts the robot outside the arena "
                         f"(allowed: {robot.lo:g}..{robot.hi:g} m)")
    return cmls, meta, settings, robot, sim, sim_name, base


def _planning_record(args, meta, settings, cmls, sim_name, base) -> dict[str, Any]:
    return {"model": args.model, "sim": sim_name, "trained_on": meta["sim"],
            "observation": settings.observation, "goal_heading": settings.goal_heading,
            "heading_scale": settings.heading_scale, "utility": cmls[0].config.utility,
            "backend": cmls[0].backend, "stop": args.stop, "radius": args.radius,
            "max_actions": args.max_actions, "base": list(base), "eval_seed": args.eval_seed,
            "compute_path": args.path, "path": args.path,
            "training_walks": meta["training"].get("walks"),
            "training_steps": meta["training"].get("steps"),
            "command": command_line(), "cml_edge_version": __version__}


def _cmd_evaluate(args: argparse.Namespace) -> dict[str, Any]:
    cmls, meta, settings, robot, sim, sim_name, base = _load_for_planning(args)
    cmls, result = evaluate_pooled(args, cmls, meta, sim, settings,
                                   lambda: draw_goals(robot, args.trials, args.eval_seed), base,
                                   make_sim("kinematic", robot), f"robot evaluate ({sim_name})")
    return {**_planning_record(args, meta, settings, cmls, sim_name, base), **result}


# what the robot's and the drone's commands share ----------------------------------------
def load_pooled(model, load, world: str) -> tuple[list, dict[str, Any]]:
    """The models of one or several files (``model``: a path or a list) read by ``load``,
    pooled: files that differ in how they were trained are refused."""
    files = model if isinstance(model, list) else [model]
    cmls, meta = load(files[0])
    for other in files[1:]:
        more, m = load(other)
        for key in ("settings", world, "sim", "mujoco", "config", "backend"):
            if m.get(key) != meta.get(key):
                raise InputError(f"{other} differs from {files[0]} in its {key}; only models "
                                 f"trained alike are pooled")
        cmls += more
        meta["training"] = {**meta["training"], "seeds": meta["training"].get("seeds", []) +
                            m["training"].get("seeds", [])}
    return cmls, meta


def set_utility(cmls: list, utility: str | None) -> None:
    """Plan with ``utility`` instead of the models' own (None: keep theirs)."""
    if utility is not None:
        for cml in cmls:
            cml.config = CMLConfig(**{**cml.config.to_dict(), "utility": utility})


def evaluate_pooled(args: argparse.Namespace, cmls: list, meta: dict[str, Any], sim, settings,
                    draw: Callable[[], np.ndarray], start, kinematic, label: str
                    ) -> tuple[list, dict[str, Any]]:
    """``evaluate``'s work for a vehicle: the first ``--seeds`` models, their float64 twins
    retrained on ``kinematic`` (the vehicle's kinematic simulator), every model driven from
    ``start`` to the goals ``draw`` draws (once the options are checked); the models used
    and the result with ``seed_list``."""
    if args.seeds is not None:
        if args.seeds > len(cmls):
            raise InputError(f"--seeds {args.seeds}: the model file holds {len(cmls)} models")
        cmls = cmls[: args.seeds]
    goals = draw()
    seeds = meta["training"].get("seeds", list(range(len(cmls))))[: len(cmls)]
    with stage("twin"):
        twins, why = _twins(meta, settings, kinematic, cmls, seeds)
    with stage("evaluate"):  # with the replays against the twins
        result = evaluate_models(cmls, sim, settings, goals, start, args.max_actions,
                                 args.radius, args.stop, args.path, Progress(label), twins)
    if twins is None:
        result.update({"weight_error": None, "decision_agreement": None, "read_snr": None,
                       "fidelity_twin": f"unavailable: {why}"})
    for entry, seed in zip(result["per_seed"], seeds):
        entry["seed"] = seed
    return cmls, {**result, "seed_list": seeds}


def _twins(meta: dict[str, Any], settings, sim, cmls: list, seeds: list[int]):
    """((seed, float64 twin) per model, retrained from the file's training record on the
    kinematic simulator ``sim``, :mod:`cml_edge.robot.fidelity`), or (None, why not)."""
    from cml_edge.robot.fidelity import robot_twin

    training = meta["training"]
    if meta["sim"] != "kinematic":
        return None, f"the models were trained on {meta['sim']} (twins are retrained on the " \
                     "kinematic simulator only)"
    if any(k not in training for k in ("walks", "steps", "schedule", "seeds")):
        return None, "the model file does not record its training"
    config = RobotTrainConfig(training["walks"], training["steps"], training["schedule"])
    return [(seed, robot_twin(seed, sim, settings, config, cml.config))
            for seed, cml in zip(seeds, cmls)], ""


def _cmd_navigate(args: argparse.Namespace) -> dict[str, Any]:
    cmls, meta, settings, robot, sim, sim_name, base = _load_for_planning(args)
    if args.model_index >= len(cmls):
        raise InputError(f"--model-index {args.model_index}: the model file holds "
                         f"{len(cmls)} models (allowed: 0..{len(cmls) - 1})")
    if args.goal is not None:
        gx, gy = args.goal
        if not (0.0 <= gx <= robot.arena and 0.0 <= gy <= robot.arena):
            raise InputError(f"--goal {gx:g} {gy:g} is off the {robot.arena:g} x {robot.arena:g}"
                             f" m arena (allowed: 0..{robot.arena:g})")
        goals = np.array([[gx, gy]])
    else:
        goals = draw_goals(robot, args.goals, args.eval_seed)
    starts = np.tile(np.asarray(base), (len(goals), 1))
    res = plan_robot(cmls[args.model_index], sim, settings, starts, goals, args.max_actions,
                     args.radius, args.path, keep_paths=True, stop=args.stop)
    out = {**_planning_record(args, meta, settings, cmls, sim_name, base),
           "model_index": args.model_index, **summarize_robot(res, starts, goals),
           "runs": {"goals": goals.tolist(), "reached": res.reached.tolist(),
                    "actions": res.steps.tolist(), "final": res.final.tolist(),
                    "path_length": res.length.tolist()}}
    if args.plot:
        plot_robot_runs(args.plot, robot, res.paths, goals, res.reached, base, args.radius,
                        title=f"CML ({settings.observation} observation, {sim_name}): "
                              f"{int(res.reached.sum())}/{len(goals)} goals reached")
        out["plot"] = args.plot
    return out


def cmd_robot(args: argparse.Namespace) -> dict[str, Any]:
    """Run ``cml-edge robot ...``; the JSON-ready result. Bad input raises InputError."""
    commands = {"train": _cmd_train, "evaluate": _cmd_evaluate, "navigate": _cmd_navigate}
    return commands[args.robot_command](args)


# what a person reads (--json: the result) ----------------------------------------
def _seed_range(seeds: Sequence[int]) -> str:
    seeds = list(seeds)
    return f"seed {seeds[0]}" if len(seeds) == 1 else f"seeds {seeds[0]}..{seeds[-1]}"


def show_robot_train(r: dict[str, Any]) -> None:
    """``robot train``: the models trained and where they were saved."""
    print(f"robot train: {plural(len(r['seeds']), 'model')} ({_seed_range(r['seeds'])}) on "
          f"{r['sim']}, {r['walks']} walks x {r['steps']} actions ({r['schedule']} schedule)")
    print("\n".join(labelled([
        ("device", device_label(r["backend"], r.get("backend_options"))),
        ("observation", f"{r['observation']} (goal heading {r['goal_heading']}, heading "
                        f"scale {num(r['heading_scale'])})"),
        ("model", r["model"]),
        ("final training error", ", ".join(num(e) for e in r["final_train_error"])),
        ("time", f"{secs(r['wall_time_s'])} ({num(r['actions_per_s'])} actions/s)")])))


def _robot_rows(r: dict[str, Any]) -> list[tuple[str, str]]:
    runs = r.get("seeds", 1) * r["trials"]
    return [("device", device_label(r["backend"])),
            ("success rate", f"{pct(r['success_rate'])}  ({round(r['success_rate'] * runs):,}"
                             f" of {runs:,} goals within {num(r['radius'])} m)"),
            ("path ratio", "n/a (no goal reached)" if r.get("path_ratio") is None else
             f"{num(r['path_ratio'])}  (path length / straight distance; "
             f"{num(r['mean_actions'])} actions a goal)")]


def show_robot_evaluate(r: dict[str, Any]) -> None:
    """``robot evaluate``: the protocol's table for the robot."""
    print(f"robot evaluate: {plural(r['seeds'], 'model')} x {plural(r['trials'], 'goal')} on "
          f"{r['sim']} (trained on {r['trained_on']}), {r['observation']} observation")
    print("\n".join(labelled([*_robot_rows(r), *fidelity_rows(r),
                              ("time", f"{secs(r['wall_time_s'])} "
                                       f"({num(r['actions_per_s'])} actions/s)")])))


def show_robot_navigate(r: dict[str, Any]) -> None:
    """``robot navigate``: one model driven to each goal."""
    print(f"robot navigate: model {r['model_index']} to {plural(r['trials'], 'goal')} on "
          f"{r['sim']}, from base ({num(r['base'][0])}, {num(r['base'][1])}) m")
    rows = [[f"({num(g[0])}, {num(g[1])})", num(ok), f"{a:,}", num(d)]
            for g, ok, a, d in zip(r["runs"]["goals"], r["runs"]["reached"],
                                   r["runs"]["actions"], r["runs"]["path_length"])]
    print("\n".join(labelled([*_robot_rows(r), ("plot", r.get("plot"))])))
    if len(rows) <= 10:
        print("\n".join("  " + line for line in table(rows, ["goal (m)", "reached", "actions",
                                                              "path (m)"])))
