"""``cml-edge train | evaluate | navigate | emulate``: the CML on the grid (paper 2.1-3.4)."""

from __future__ import annotations

import argparse
import time
from collections.abc import Sequence
from dataclasses import replace
from typing import Any

import numpy as np

from cml_edge import __version__
from cml_edge.backends import BACKENDS, beyond_reference
from cml_edge.cli import limits
from cml_edge.cli.args import (
    Progress,
    add_backend,
    add_chips,
    arena_size,
    backend_options,
    chips_options,
    command_line,
    coordinate,
    finite_float,
    nonneg_int,
    positive_int,
    say_estimate,
)
from cml_edge.cli.compiling import protocol_units, warm_up
from cml_edge.cli.output import (
    arena_text,
    beyond_rows,
    device_label,
    labelled,
    num,
    plural,
    secs,
    show_evaluate,
    show_protocol,
)
from cml_edge.core.cml import CML, UTILITIES
from cml_edge.core.fidelity import TWIN, pool_seeds
from cml_edge.core.finite import dumps
from cml_edge.core.learning import SCHEDULES
from cml_edge.core.model_file import load_model, save_model
from cml_edge.engine import timings
from cml_edge.engine.timings import stage
from cml_edge.errors import InputError
from cml_edge.grid.arena import DIMS, MOVE_SETS, GridArena, fewest_moves, move_table
from cml_edge.grid.exploration import EXPLORATIONS
from cml_edge.grid.fidelity import float_twin, seed_fidelity
from cml_edge.grid.metrics import Pairs, draw_pairs, geodesic_distances, summarize
from cml_edge.grid.paths import default_path
from cml_edge.grid.planning import MAX_STEPS, PLANNERS, plan
from cml_edge.grid.protocol import Protocol, run_protocol
from cml_edge.grid.seed_run import Evaluation, cml_config_for
from cml_edge.grid.sensors import GOALS, Sensors
from cml_edge.grid.training import PATHS, TrainConfig, train
from cml_edge.io.files import atomic_write, writable_file, writable_folder
from cml_edge.protocol import EVAL_SEED


def _add_training(p: argparse.ArgumentParser, counted: bool = False) -> None:
    """The training options; ``counted``: the command reports the arrays' counters, so its
    default compute path is direct (:func:`cml_edge.grid.paths.default_path`)."""
    p.add_argument("--arena", type=arena_size, default=30, help="arena side (default 30)")
    p.add_argument("--dims", type=int, choices=DIMS, default=2,
                   help="2: the paper's N x N plane; 3: an N x N x N volume (default 2)")
    p.add_argument("--moves", choices=MOVE_SETS, default="king",
                   help="king: every neighbour (8 on the plane, 26 in space); face: the axis "
                        "neighbours only (4, 6) (default king)")
    p.add_argument("--walks", type=positive_int, default=100, help="exploration walks (100)")
    p.add_argument("--steps", type=positive_int, default=900, help="steps per walk (900)")
    p.add_argument("--explore", choices=EXPLORATIONS, default="random",
                   help="exploration strategy (random)")
    p.add_argument("--schedule", choices=SCHEDULES, default=None,
                   help="walk: updates summed over a walk, applied at its end (the paper); "
                        "step: applied in place every step (default walk; loihi2: step, the "
                        "schedule Lava runs)")
    p.add_argument("--utility", choices=UTILITIES, default="normalized",
                   help="planning utility: W_v columns normalised (default) or raw")
    default = ("direct (the counters are counted on it)" if counted else
               "factored for float64 with the walk schedule, else direct")
    p.add_argument("--path", choices=PATHS, default=None,
                   help="compute path: factored (float fast path), direct (compiled, through "
                        f"the array), reference (plain Python); default {default}")


def _add_sensors(p: argparse.ArgumentParser) -> None:
    """Range sensors in the embedding (:mod:`cml_edge.grid.sensors`)."""
    d = Sensors()
    p.add_argument("--sensors", type=nonneg_int, default=None, metavar="K",
                   help="append K range readings to the observation (the face or king "
                        "directions: 4 or 8 on the plane, 6 or 26 in space; 0: none, but "
                        "train among obstacles) and train among obstacles (default: none, "
                        "the paper's empty arena)")
    p.add_argument("--sensor-range", type=positive_int, default=d.range, metavar="R",
                   help=f"cells a sensor sees, readings clipped there ({d.range})")
    p.add_argument("--sensor-weight", type=finite_float, default=d.weight, metavar="W",
                   help=f"the K sensor inputs together against positions in [-0.5, 0.5] "
                        f"({d.weight})")
    p.add_argument("--sensor-goal", choices=GOALS, default=d.goal,
                   help="the goal's sensor inputs: open (open space, zero: a pull away from "
                        "what is near) or here (the agent's own: they cancel) "
                        f"(default {d.goal})")
    p.add_argument("--train-obstacles", type=nonneg_int, default=None, metavar="N",
                   help="with --sensors: point obstacles of the training arena, placed from "
                        f"layout seed {d.layout_seed} (default: a third of the cells)")


def _sensors(args: argparse.Namespace) -> Sensors | None:
    """The ``--sensors`` options as a record (None without ``--sensors``); checked against
    the arena."""
    if args.sensors is None:
        if args.train_obstacles is not None:
            raise InputError("--train-obstacles needs --sensors")
        return None
    sensors = Sensors(args.sensors, args.sensor_range, args.sensor_weight, args.sensor_goal,
                      args.train_obstacles)
    sensors.check(args.dims, args.arena)
    return sensors


def _add_eval(p: argparse.ArgumentParser) -> None:
    p.add_argument("--obstacles", type=nonneg_int, default=0,
                   help="point obstacles placed at evaluation only (0)")
    p.add_argument("--trials", type=positive_int, default=100, help="(start, goal) pairs (100)")
    p.add_argument("--max-steps", type=positive_int, default=None,
                   help="planning step budget (100; with --map: max(100, ceil(100 x side / "
                        "30)))")
    p.add_argument("--json", action="store_true", help="print one JSON object on stdout")


def _add_planner(p: argparse.ArgumentParser) -> None:
    p.add_argument("--planner", choices=PLANNERS, default="paper",
                   help="paper: WTA over utility x affordance (the paper's); escape: the "
                        "paper's WTA plus a reactive escape when it would revisit a cell "
                        "(boundary following, LRTA* fallback; see cml_edge.grid.planning)")


def _add_map(p: argparse.ArgumentParser, scen: bool = True) -> None:
    p.add_argument("--map", default=None, metavar="FILE",
                   help="plan on a MovingAI .map file (or a shipped map: rooms, utrap, "
                        "maze); the CML never sees it in training")
    if scen:  # navigate plans one --start / --goal: no problems to replace
        p.add_argument("--scen", default=None, metavar="FILE",
                       help="MovingAI .scen file: its (start, goal) problems replace the "
                            "drawn pairs (needs --map)")


def _load_map_args(args: argparse.Namespace, dims: int = 2, moves: str = "king"):
    """(the map's arena, Pairs or None) of --map / --scen, or (None, None); checks the
    options. A MovingAI ``.map`` on the plane, a voxel map (``.3dmap``) in space."""
    from cml_edge.grid.condition import Condition

    if getattr(args, "scen", None) and not args.map:
        raise InputError("--scen needs --map")
    if not args.map:
        return None, None
    if getattr(args, "obstacles", 0):
        raise InputError(f"--obstacles {args.obstacles} cannot be combined with --map (the map "
                         f"is the evaluation arena)")
    arena, pairs = Condition(map=args.map, scen=getattr(args, "scen", None)).map_arena(dims,
                                                                                    moves)
    limits.recheck(args, arena=arena.size, dims=dims,
                   **({} if pairs is None else {"trials": len(pairs.goals)}))
    return arena, pairs


def _budget(args: argparse.Namespace, side: int, on_map: bool) -> int:
    """--max-steps, or by default 100 (the paper's) and step_budget(side) on a map."""
    from cml_edge.grid.maps import step_budget

    if args.max_steps is not None:
        return args.max_steps
    return step_budget(side) if on_map else MAX_STEPS


def add_parsers(sub) -> None:
    """The grid commands."""
    p = sub.add_parser("train", help="train one CML and save it")
    _add_training(p)
    _add_sensors(p)
    add_backend(p)
    p.add_argument("--seed", type=nonneg_int, default=0, help="model seed (0)")
    p.add_argument("--out", required=True, help="model file to write (.npz)")
    p.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    p.set_defaults(run=cmd_train, show=show_train)

    p = sub.add_parser("evaluate", help="evaluate a saved model on fixed (start, goal) pairs")
    p.add_argument("model", help="model file (.npz)")
    p.add_argument("--arena", type=arena_size, default=None,
                   help="arena side (default: the training arena)")
    _add_eval(p)
    p.add_argument("--seed", type=nonneg_int, default=EVAL_SEED,
                   help=f"evaluation seed: pairs and obstacles ({EVAL_SEED})")
    p.add_argument("--path", choices=PATHS, default=None,
                   help="compute path (see train); default factored for a float64 model, "
                        "else direct")
    _add_planner(p)
    _add_map(p)
    p.set_defaults(run=cmd_evaluate, show=show_evaluate)

    p = sub.add_parser("navigate", help="plan one path with a saved model, optionally plot it")
    p.add_argument("model", help="model file (.npz)")
    p.add_argument("--start", type=coordinate, nargs="+", metavar="C", required=True,
                   help="the start cell: X Y (X Y Z for a 3-D model)")
    p.add_argument("--goal", type=coordinate, nargs="+", metavar="C", required=True,
                   help="the goal cell: X Y (X Y Z for a 3-D model)")
    p.add_argument("--arena", type=arena_size, default=None,
                   help="arena side (default: the training arena)")
    p.add_argument("--obstacles", type=nonneg_int, default=0, help="point obstacles (0)")
    p.add_argument("--seed", type=nonneg_int, default=EVAL_SEED, help="obstacle seed")
    p.add_argument("--max-steps", type=positive_int, default=None,
                   help="step budget (100; with --map: max(100, ceil(100 x side / 30)))")
    _add_planner(p)
    _add_map(p, scen=False)
    p.add_argument("--plot", help="write a PNG of the arena and the path")
    p.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    p.set_defaults(run=cmd_navigate, show=show_navigate)

    p = sub.add_parser("emulate", help="train and evaluate models on a synaptic array "
                       "(the evaluation protocol)")
    _add_training(p, counted=True)
    add_backend(p)
    _add_eval(p)
    p.add_argument("--seeds", type=positive_int, default=10, help="models, seeds 0..N-1 (10)")
    p.add_argument("--eval-seed", type=nonneg_int, default=EVAL_SEED,
                   help=f"evaluation seed: pairs and obstacles ({EVAL_SEED})")
    p.add_argument("--drift-time", type=finite_float, default=0.0, metavar="T",
                   help="seconds between the end of training and evaluation; arrays that "
                        "drift (crossbar) apply it (0)")
    p.add_argument("--out", help="also write the JSON result to this file")
    _add_planner(p)
    _add_map(p)
    add_chips(p)
    p.add_argument("--restart", action="store_true",
                   help="start the chips' run in --chips-out over (a run folder of another "
                        "protocol is refused without it)")
    p.set_defaults(run=cmd_emulate, show=show_protocol)


def _default_schedule(args: argparse.Namespace) -> None:
    """``--schedule`` not given: the device's (``DeviceSpec.schedule``; an unknown backend
    is refused after, by the backend options)."""
    if args.schedule is None:
        spec = BACKENDS.get(args.backend)
        args.schedule = getattr(getattr(spec, "device", None), "schedule", "walk")


def cmd_train(args: argparse.Namespace) -> dict[str, Any]:
    _default_schedule(args)
    writable_file(args.out, "--out")
    options = backend_options(args)
    config = TrainConfig(args.walks, args.steps, args.explore, args.schedule)
    sensors = _sensors(args)
    arena = (GridArena.sensed(sensors, args.arena, args.dims, args.moves) if sensors else
             GridArena.empty(args.arena, args.dims, args.moves))
    cml = CML.create(cml_config_for(arena, utility=args.utility), args.backend, args.seed,
                     **options)
    path = args.path or default_path(cml, args.schedule, arena=arena)
    t0 = time.perf_counter()
    bar = Progress("train")
    bar(0, config.walks)
    with stage("train"):
        errors = train(cml, arena, config, args.seed, path=path,
                       on_epoch=lambda done: bar(done, config.walks))
    record = {"arena": args.arena, "dims": args.dims, "moves": args.moves,
              **({"sensors": sensors.to_dict()} if sensors else {}),
              "walks": args.walks, "steps": args.steps,
              "explore": args.explore, "schedule": args.schedule, "seed": args.seed,
              "path": path, "backend_options": options, "train_error": errors.tolist(),
              "wall_time_s": time.perf_counter() - t0, "cml_edge_version": __version__,
              "command": command_line()}
    with stage("write"):
        save_model(args.out, cml, record)
    out = {"model": args.out, "backend": args.backend, **{k: record[k] for k in (
        "arena", "walks", "steps", "explore", "schedule", "seed")}, "compute_path": path,
        "path": path, "wall_time_s": record["wall_time_s"],
        "final_train_error": float(errors[-1]), **_in_space(args.dims, args.moves, sensors),
        **beyond_reference(args.backend, options, args.schedule)}
    if path != "factored":  # the factored shortcut bypasses the arrays: nothing to count
        out["counters"] = cml.counters()
    return out


def _in_space(dims: int, moves: str, sensors: Sensors | None = None) -> dict[str, Any]:
    """The keys a result adds off the plane's king moves and with range sensors (none on
    the plane without them: its results read as before)."""
    return {**({"dims": dims, "moves": moves} if (dims, moves) != (2, "king") else {}),
            **({"sensors": sensors.to_dict()} if sensors else {})}


def _model_world(cml: CML, record: dict[str, Any], model: str
                 ) -> tuple[int, str, Sensors | None]:
    """(dims, moves, range sensors) a model was trained with (a file without them: the
    plane's king moves, no sensors), checked against its CML's inputs and actions."""
    dims, moves = int(record.get("dims", 2)), record.get("moves", "king")
    if dims not in DIMS or moves not in MOVE_SETS:
        raise InputError(f"{model!r} records dims {dims!r} and moves {moves!r} (allowed: "
                         f"dims 2 or 3, moves {' or '.join(MOVE_SETS)})")
    sensed = record.get("sensors")
    if sensed is not None and not isinstance(sensed, dict):
        raise InputError(f"{model!r} records sensors {sensed!r} (allowed: a JSON object)")
    sensors = Sensors.from_dict(sensed) if sensed is not None else None
    if sensors is not None:
        sensors.check(dims, int(record.get("arena", 30)))
    n_i = dims + (sensors.k if sensors else 0)
    n_a = len(move_table(dims, moves))
    if (cml.config.n_i, cml.config.n_a) != (n_i, n_a):
        raise InputError(f"{model!r} has {cml.config.n_i} inputs and {cml.config.n_a} "
                         f"actions; a grid model of {dims} dimensions with {moves} moves"
                         f"{f' and {sensors.k} range sensors' if sensors else ''} has "
                         f"{n_i} and {n_a}")
    return dims, moves, sensors


def _eval_arena(args: argparse.Namespace, record: dict[str, Any], dims: int,
                moves: str) -> GridArena:
    size = args.arena if args.arena is not None else int(record.get("arena", 30))
    if args.obstacles:
        return GridArena.with_obstacles(size, args.obstacles, args.seed, dims, moves)
    return GridArena.empty(size, dims, moves)


def cmd_evaluate(args: argparse.Namespace) -> dict[str, Any]:
    if args.map and args.arena is not None:
        raise InputError(f"--arena {args.arena} cannot be combined with --map (the map sets "
                         f"the arena)")
    with stage("load"):
        cml, record = load_model(args.model)
    dims, moves, sensors = _model_world(cml, record, args.model)
    grid, scen_pairs = _load_map_args(args, dims, moves)
    arena = (grid if grid is not None else _eval_arena(args, record, dims, moves)
             ).sensing(sensors)
    twin = {k: record[k] for k in ("walks", "steps") if k in record}  # its training
    limits.recheck(args, arena=arena.size, dims=dims, trials=len(scen_pairs.goals)
                   if scen_pairs else args.trials, **twin)
    pairs = scen_pairs or draw_pairs(arena, args.trials, args.seed)
    path = args.path or default_path(cml)
    budget = _budget(args, arena.size, grid is not None)
    say_estimate()
    with stage("evaluate"):
        res = Evaluation(arena, pairs, budget, args.planner).plan(cml, path)
    result = summarize(res.final, res.steps, pairs)
    out = {"model": args.model, "backend": cml.backend, "seeds": 1, **result,
           "arena": arena.size, "obstacles": args.obstacles, "eval_seed": args.seed,
           "compute_path": path, "path": path, "planner": args.planner, "max_steps": budget,
           **_in_space(dims, moves, sensors)}
    if grid is not None:
        out.update({"map": args.map, "scen": args.scen})
    out.update(_model_fidelity(cml, record, arena, pairs, res, args.planner, budget))
    return out


def _model_fidelity(cml: CML, record: dict[str, Any], arena: GridArena, pairs: Pairs,
                    res: Any, planner: str, budget: int) -> dict[str, Any]:
    """The saved model against its float64 twin, retrained from the model file's training
    record (seed, arena, walks, steps, exploration, schedule): the keys ``emulate`` adds,
    over its one seed. A file that does not record its training gets None for each."""
    keys = ("seed", "arena", "walks", "steps", "explore", "schedule")
    if any(k not in record for k in keys):
        return {"weight_error": None, "decision_agreement": None, "read_snr": None,
                "fidelity_twin": "unavailable: the model file does not record its training"}
    config = TrainConfig(int(record["walks"]), int(record["steps"]), record["explore"],
                         record["schedule"])
    seed = int(record["seed"])
    size = int(record["arena"])
    train_arena = (GridArena.sensed(arena.sensors, size, arena.dims, arena.moves)
                   if arena.sensors else GridArena.empty(size, arena.dims, arena.moves))
    twin = float_twin(seed, train_arena, config, cml.config)
    fid = seed_fidelity(seed, cml, twin, arena, pairs.goals, res, planner, budget)
    return {**pool_seeds([fid]), "fidelity_twin": TWIN,
            "decisions": fid["decisions"], "decisions_agreed": fid["decisions_agreed"]}


def cmd_navigate(args: argparse.Namespace) -> dict[str, Any]:
    if args.plot:
        writable_file(args.plot, "--plot")
    if args.map and args.arena is not None:
        raise InputError(f"--arena {args.arena} cannot be combined with --map (the map sets "
                         f"the arena)")
    cml, record = load_model(args.model)
    dims, moves, sensors = _model_world(cml, record, args.model)
    grid, _ = _load_map_args(args, dims, moves)
    arena = (grid if grid is not None else _eval_arena(args, record, dims, moves)
             ).sensing(sensors)
    limits.recheck(args, arena=arena.size, dims=dims)
    axes = "X Y Z"[: 2 * dims - 1]
    for name, pos in (("start", args.start), ("goal", args.goal)):
        text = " ".join(map(str, pos))
        if len(pos) != dims:
            raise InputError(f"--{name} {text} is not a cell of the {dims}-D arena (allowed: "
                             f"{dims} coordinates, {axes})")
        if not arena.contains(pos):
            raise InputError(f"--{name} {text} is off the "
                             f"{' x '.join([str(arena.size)] * dims)} arena (allowed: "
                             f"0..{arena.size - 1})")
        if not arena.is_free(pos):
            raise InputError(f"--{name} {text} is on an obstacle")
    starts, goals = np.array([args.start]), np.array([args.goal])
    path = default_path(cml)
    say_estimate()
    res = plan(cml, arena, starts, goals, max_steps=_budget(args, arena.size, grid is not None),
               path=path, planner=args.planner)
    steps = int(res.steps[0])
    trajectory = res.paths[0, : steps + 1]
    pairs = Pairs(starts, goals, fewest_moves(starts, goals, moves),
                  geodesic_distances(arena, starts, goals))
    final = res.final[0]
    out = {"start": list(args.start), "goal": list(args.goal), "final": final.tolist(),
           "steps": steps, "reached": bool((final == goals[0]).all()),
           "e_pos": float(np.linalg.norm(final - goals[0])),
           "chebyshev": int(pairs.chebyshev[0]), "geodesic": int(pairs.geodesic[0]),
           "planner": args.planner, "compute_path": path, "trajectory": trajectory.tolist(),
           **_in_space(dims, moves, sensors)}
    out["path"] = out["trajectory"]  # the older name of the trajectory
    if args.plot:
        from cml_edge.grid.plots import plot_navigation

        plot_navigation(args.plot, arena, trajectory, args.start, args.goal)
        out["plot"] = args.plot
    return out


def cmd_emulate(args: argparse.Namespace) -> dict[str, Any]:
    _default_schedule(args)
    if args.drift_time < 0:
        raise InputError(f"--drift-time {args.drift_time} is negative (allowed: >= 0 seconds)")
    if args.out:
        writable_file(args.out, "--out")
    if args.chips_out:
        writable_folder(args.chips_out, "--chips-out")
    elif args.restart:
        raise InputError("--restart needs --chips-out (the chips' run folder to start over)")
    if getattr(args, "scheduler", None) is not None:
        from cml_edge.engine.sweep import check_scheduler

        check_scheduler(args.scheduler)
    options = backend_options(args)
    # checks --map and --scen; the protocol loads them
    grid, _ = _load_map_args(args, args.dims, args.moves)
    size = args.arena
    if grid is not None:
        if args.arena not in (30, grid.size):  # 30: the default, replaced by the map's side
            raise InputError(f"--arena {args.arena} conflicts with --map "
                             f"({' x '.join([str(grid.size)] * grid.dims)}); leave --arena out")
        size = grid.size
    config = TrainConfig(args.walks, args.steps, args.explore, args.schedule)
    on_map = grid is not None
    protocol = Protocol(
        backend=args.backend, seeds=range(args.seeds), trials=args.trials, arena_size=size,
        obstacles=args.obstacles, train=config, utility=args.utility,
        eval_seed=args.eval_seed, path=args.path, idle_s=args.drift_time,
        planner=args.planner, max_steps=_budget(args, size, on_map), backend_options=options,
        map=args.map if on_map else None, scen=args.scen if on_map else None,
        dims=args.dims, moves=args.moves)
    chips = chips_options(args)
    if chips is not None:
        if on_map:
            raise InputError("--chips runs the protocol's arenas; --map is not supported with it")
        # a chip's curve has one point, at the end of training
        return _emulate_chips(args, replace(protocol, epoch=config.walks), chips)
    warm_up(protocol_units(protocol))
    records: list[dict[str, Any]] = []
    result = run_protocol(protocol, progress=Progress(f"emulate {args.backend}"),
                          records=records)
    if records:  # the run's hardware budget, from its seeds' own counters
        from cml_edge.costs.budget import protocol_costs

        result["costs"] = protocol_costs(protocol, records, result["curve_e_pos_mean"])
    result["command"] = command_line()
    result["cml_edge_version"] = __version__
    if args.out:
        _write_out(args.out, result)
    return result


def _write_out(path: str, result: dict[str, Any]) -> None:
    """``--out``: the result as ``--json`` prints it, its ``timings`` up to the write."""
    with stage("write"):
        atomic_write(path, lambda f: f.write(dumps(
            {**result, "timings": timings.snapshot()}, indent=1).encode()))


def _emulate_chips(args: argparse.Namespace, protocol: Protocol,
                   chips: dict[str, Any]) -> dict[str, Any]:
    """``emulate --chips N``: the protocol on N chips (:mod:`cml_edge.grid.chips`)."""
    from cml_edge.grid.chips import run_chips

    result = {"backend": args.backend, **run_chips(
        protocol=protocol, progress=Progress(f"emulate {args.backend} chips"),
        restart=args.restart, **chips)}
    result["command"] = command_line()
    result["cml_edge_version"] = __version__
    if args.out:
        _write_out(args.out, result)
    return result


# what a person reads (--json: the result) ----------------------------------------
def show_train(r: dict[str, Any]) -> None:
    """``train``: what was trained, where it was saved, its final training error."""
    print(f"train: seed {r['seed']}, {arena_text(r['arena'], r)}, {r['walks']} walks x "
          f"{r['steps']} steps ({r['explore']} exploration, {r['schedule']} schedule)")
    print("\n".join(labelled([
        ("device", device_label(r["backend"], r.get("backend_options"))), *beyond_rows(r),
        ("model", r["model"]), ("compute path", r["compute_path"]),
        ("final training error", num(r["final_train_error"])),
        ("time", secs(r["wall_time_s"]))])))


def _cell(p: Sequence[int]) -> str:
    return f"({', '.join(str(v) for v in p)})"


def show_navigate(r: dict[str, Any]) -> None:
    """``navigate``: the outcome of one plan and its trajectory, wrapped."""
    import textwrap

    print(f"navigate: {_cell(r['start'])} -> {_cell(r['goal'])}, {r['planner']} planner, "
          f"{r['compute_path']} path")
    steps = plural(r["steps"], "step")
    if r["reached"]:
        metric = "Chebyshev" if r.get("moves", "king") == "king" else "Manhattan"
        outcome = f"yes, in {steps} ({metric} distance {r['chebyshev']}, overhead " \
                  f"{num(r['steps'] / max(r['chebyshev'], 1))})"
    else:
        outcome = f"no: stopped at {_cell(r['final'])} after {steps}, e_pos {num(r['e_pos'])}"
    path = textwrap.wrap(" ".join(",".join(map(str, p)) for p in r["trajectory"]), 76)
    print("\n".join(labelled([("reached", outcome), ("plot", r.get("plot"))])))
    axes = "x,y,z" if len(r["start"]) == 3 else "x,y"
    print(f"  trajectory ({axes}):\n" + "\n".join("    " + line for line in path))
