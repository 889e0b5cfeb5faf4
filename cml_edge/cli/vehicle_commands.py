"""The ``train | evaluate | navigate`` commands of a vehicle, the wheeled robot's
(:mod:`~cml_edge.cli.robot`) and the drone's (:mod:`~cml_edge.cli.drone`), and what a
person reads of them: one implementation, :func:`run_vehicle`, given what tells the two
worlds apart (:class:`World`); their parsers are :mod:`~cml_edge.cli.vehicle`'s."""

from __future__ import annotations

import argparse
from collections.abc import Callable, Collection, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from cml_edge import __version__
from cml_edge.cli.args import Progress, backend_options, command_line
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
from cml_edge.core.cml import CMLConfig
from cml_edge.engine.timings import stage
from cml_edge.errors import InputError
from cml_edge.io.files import writable_file
from cml_edge.robot.models import evaluate_models, train_models
from cml_edge.robot.planning import plan_robot, summarize_robot
from cml_edge.robot.training import RobotTrainConfig


@dataclass(frozen=True)
class World:
    """What tells one vehicle's commands from the other's, past their parsers: each
    callable takes and gives the vehicle's own config (``RobotConfig``, ``DroneConfig``)
    and CML settings."""

    name: str
    """The command group, and the vehicle's key in the model files (``robot``)."""
    mujoco: Collection[str]
    """The fields of the ``--mujoco-*`` options."""
    make_sim: Callable[..., Any]
    """The simulator called by name, of a vehicle config, with MuJoCo options."""
    stored_mujoco: Callable[[Any], dict[str, float]]
    """The MuJoCo options a model file records of the simulator it was trained on."""
    save: Callable[[str, list, dict[str, Any]], None]
    """Writes a model file."""
    load: Callable[[str], tuple[list, dict[str, Any]]]
    """Reads a model file: its models and their record."""
    trained: Callable[[argparse.Namespace], tuple[Any, Any]]
    """``train``'s vehicle config and CML settings, from its options."""
    loaded: Callable[[argparse.Namespace, dict[str, Any]], tuple[Any, Any]]
    """``evaluate``'s and ``navigate``'s, from the model file's record and their options."""
    start: Callable[[argparse.Namespace, Any], tuple[Any, dict[str, list[float]]]]
    """The start state of every run, checked, and its entry in the result."""
    record: Callable[[Any, Any], dict[str, Any]]
    """The vehicle's own entries in the results (after ``sim``), from its config and
    settings."""
    older_path: bool
    """Whether the results name the compute path ``path`` too, its older name."""
    draw_goals: Callable[[Any, int, int], np.ndarray]
    """``trials`` random goals from a seed."""
    check_goal: Callable[[list[float], Any], None]
    """Refuses ``navigate --goal`` outside the world."""
    plot: Callable[..., None]
    """Writes ``navigate --plot`` (:func:`cml_edge.robot.models.plot_robot_runs`)."""
    title: Callable[[Any, str, np.ndarray, float], str]
    """The plot's title, of the settings, the simulator, the goals reached and the
    radius."""


def run_vehicle(w: World, args: argparse.Namespace) -> dict[str, Any]:
    """Run ``cml-edge NAME ...`` for the world ``w``; the JSON-ready result. Bad input
    raises InputError."""
    commands = {"train": _train, "evaluate": _evaluate, "navigate": _navigate}
    return commands[getattr(args, f"{w.name}_command")](w, args)


def _make_sim(w: World, name: str, vehicle, args: argparse.Namespace,
              stored: dict[str, float] | None = None):
    given = {f: getattr(args, f"mujoco_{f}") for f in w.mujoco
             if getattr(args, f"mujoco_{f}", None) is not None}
    if name != "mujoco" and given:
        raise InputError("--mujoco-* options need --sim mujoco")
    return w.make_sim(name, vehicle, **({**(stored or {}), **given} if name == "mujoco" else {}))


def _compute_path(w: World, path: str) -> dict[str, str]:
    return {"compute_path": path, **({"path": path} if w.older_path else {})}


def _train(w: World, args: argparse.Namespace) -> dict[str, Any]:
    writable_file(args.out, "--out")
    options = backend_options(args)
    vehicle, settings = w.trained(args)
    config = RobotTrainConfig(args.walks, args.steps, args.schedule)
    sim = _make_sim(w, args.sim, vehicle, args)
    seeds = list(range(args.seed, args.seed + args.seeds))
    with stage("train"):
        cmls, record = train_models(seeds, sim, settings, config,
                                    settings.cml_config(utility=args.utility), args.backend,
                                    args.path, Progress(f"{w.name} train"), options)
    record.update({"command": command_line(), "cml_edge_version": __version__})
    mujoco = w.stored_mujoco(sim) if args.sim == "mujoco" else None
    with stage("write"):
        w.save(args.out, cmls, {w.name: vehicle.to_dict(), "settings": settings.to_dict(),
                                "sim": args.sim, "mujoco": mujoco, "training": record})
    return {"model": args.out, "sim": args.sim, **w.record(vehicle, settings),
            "utility": args.utility, "backend": args.backend, "backend_options": options,
            "walks": config.walks, "steps": config.steps, "schedule": config.schedule,
            "seeds": seeds, **_compute_path(w, args.path), "eq3_gain": record["eq3_gain"],
            "final_train_error": [e[-1] for e in record["train_error"]],
            "wall_time_s": record["wall_time_s"], "actions_per_s": record["actions_per_s"],
            "command": record["command"], "cml_edge_version": __version__}


def _load_for_planning(w: World, args: argparse.Namespace):
    """The models, their record, the settings, the vehicle, the simulator, its name, the
    start state and the result's first entries of ``evaluate`` and ``navigate``."""
    if getattr(args, "plot", None):
        writable_file(args.plot, "--plot")
    cmls, meta = load_pooled(args.model, w.load, w.name)
    vehicle, settings = w.loaded(args, meta)
    set_utility(cmls, args.utility)
    sim_name = args.sim or meta["sim"]
    sim = _make_sim(w, sim_name, vehicle, args,
                    meta.get("mujoco") if meta["sim"] == "mujoco" else None)
    start, entry = w.start(args, vehicle)
    record = {"model": args.model, "sim": sim_name, "trained_on": meta["sim"],
              **w.record(vehicle, settings), "utility": cmls[0].config.utility,
              "backend": cmls[0].backend, "stop": args.stop, "radius": args.radius,
              "max_actions": args.max_actions, **entry, "eval_seed": args.eval_seed,
              **_compute_path(w, args.path), "training_walks": meta["training"].get("walks"),
              "training_steps": meta["training"].get("steps"),
              "command": command_line(), "cml_edge_version": __version__}
    return cmls, meta, settings, vehicle, sim, sim_name, start, record


def _evaluate(w: World, args: argparse.Namespace) -> dict[str, Any]:
    """The first ``--seeds`` models, their float64 twins retrained on the vehicle's
    kinematic simulator, every model driven from the start to the random goals."""
    cmls, meta, settings, vehicle, sim, sim_name, start, record = _load_for_planning(w, args)
    kinematic = w.make_sim("kinematic", vehicle)
    if args.seeds is not None:
        if args.seeds > len(cmls):
            raise InputError(f"--seeds {args.seeds}: the model file holds {len(cmls)} models")
        cmls = cmls[: args.seeds]
    goals = w.draw_goals(vehicle, args.trials, args.eval_seed)
    seeds = meta["training"].get("seeds", list(range(len(cmls))))[: len(cmls)]
    with stage("twin"):
        twins, why = _twins(meta, settings, kinematic, cmls, seeds)
    with stage("evaluate"):  # with the replays against the twins
        result = evaluate_models(cmls, sim, settings, goals, tuple(start), args.max_actions,
                                 args.radius, args.stop, args.path,
                                 Progress(f"{w.name} evaluate ({sim_name})"), twins)
    if twins is None:
        result.update({"weight_error": None, "decision_agreement": None, "read_snr": None,
                       "fidelity_twin": f"unavailable: {why}"})
    for entry, seed in zip(result["per_seed"], seeds):
        entry["seed"] = seed
    return {**record, **result, "seed_list": seeds}


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


def _navigate(w: World, args: argparse.Namespace) -> dict[str, Any]:
    cmls, meta, settings, vehicle, sim, sim_name, start, record = _load_for_planning(w, args)
    if args.model_index >= len(cmls):
        raise InputError(f"--model-index {args.model_index}: the model file holds "
                         f"{len(cmls)} models (allowed: 0..{len(cmls) - 1})")
    if args.goal is not None:
        w.check_goal(args.goal, vehicle)
        goals = np.array([args.goal], dtype=np.float64)
    else:
        goals = w.draw_goals(vehicle, args.goals, args.eval_seed)
    starts = np.tile(np.asarray(start), (len(goals), 1))
    res = plan_robot(cmls[args.model_index], sim, settings, starts, goals, args.max_actions,
                     args.radius, args.path, keep_paths=True, stop=args.stop)
    out = {**record, "model_index": args.model_index, **summarize_robot(res, starts, goals),
           "runs": {"goals": goals.tolist(), "reached": res.reached.tolist(),
                    "actions": res.steps.tolist(), "final": res.final[:, :3].tolist(),
                    "path_length": res.length.tolist()}}
    if args.plot:
        w.plot(args.plot, vehicle, res.paths, goals, res.reached, start, args.radius,
               title=w.title(settings, sim_name, res.reached, args.radius))
        out["plot"] = args.plot
    return out


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


# what a person reads (--json: the result) ----------------------------------------
def _seed_range(seeds: Sequence[int]) -> str:
    seeds = list(seeds)
    return f"seed {seeds[0]}" if len(seeds) == 1 else f"seeds {seeds[0]}..{seeds[-1]}"


def show_train(name: str, r: dict[str, Any], tail: str = "",
               rows: Sequence[tuple[str, str]] = ()) -> None:
    """``NAME train``: the models trained (the heading ending in ``tail``, the vehicle's
    ``rows`` after the device) and where they were saved."""
    print(f"{name} train: {plural(len(r['seeds']), 'model')} ({_seed_range(r['seeds'])}) on "
          f"{r['sim']}, {r['walks']} walks x {r['steps']} actions ({r['schedule']} schedule)"
          f"{tail}")
    print("\n".join(labelled([
        ("device", device_label(r["backend"], r.get("backend_options"))), *rows,
        ("model", r["model"]),
        ("final training error", ", ".join(num(e) for e in r["final_train_error"])),
        ("time", f"{secs(r['wall_time_s'])} ({num(r['actions_per_s'])} actions/s)")])))


def _planning_rows(r: dict[str, Any]) -> list[tuple[str, str]]:
    runs = r.get("seeds", 1) * r["trials"]
    return [("device", device_label(r["backend"])),
            ("success rate", f"{pct(r['success_rate'])}  ({round(r['success_rate'] * runs):,}"
                             f" of {runs:,} goals within {num(r['radius'])} m)"),
            ("path ratio", "n/a (no goal reached)" if r.get("path_ratio") is None else
             f"{num(r['path_ratio'])}  (path length / straight distance; "
             f"{num(r['mean_actions'])} actions a goal)")]


def show_evaluate(name: str, r: dict[str, Any], tail: str = "") -> None:
    """``NAME evaluate``: the protocol's table (the heading ending in ``tail``)."""
    print(f"{name} evaluate: {plural(r['seeds'], 'model')} x {plural(r['trials'], 'goal')} "
          f"on {r['sim']} (trained on {r['trained_on']}){tail}")
    print("\n".join(labelled([*_planning_rows(r), *fidelity_rows(r),
                              ("time", f"{secs(r['wall_time_s'])} "
                                       f"({num(r['actions_per_s'])} actions/s)")])))


def show_navigate(name: str, r: dict[str, Any], start: str) -> None:
    """``NAME navigate``: one model driven from ``start`` to each goal."""
    print(f"{name} navigate: model {r['model_index']} to {plural(r['trials'], 'goal')} on "
          f"{r['sim']}, from {start} m")
    rows = [[f"({', '.join(num(v) for v in g)})", num(ok), f"{a:,}", num(d)]
            for g, ok, a, d in zip(r["runs"]["goals"], r["runs"]["reached"],
                                   r["runs"]["actions"], r["runs"]["path_length"])]
    print("\n".join(labelled([*_planning_rows(r), ("plot", r.get("plot"))])))
    if len(rows) <= 10:
        print("\n".join("  " + line for line in table(rows, ["goal (m)", "reached", "actions",
                                                              "path (m)"])))
