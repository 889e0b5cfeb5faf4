"""The ``cml-edge`` command (DESIGN.md, "Command line contract").

Bad input gets one line on stderr naming the value and what is allowed, exit status
2, no traceback, and nothing written. ``--json`` prints one JSON object on stdout and
nothing else there; progress goes to stderr, only on a terminal.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from cml_edge import __version__
from cml_edge.arena import GridArena
from cml_edge.argtypes import Progress, arena_size, finite_float, nonneg_int, positive_int
from cml_edge.backends import BACKENDS, backend_spec
from cml_edge.baselines.dqn import add_dqn_parser, cmd_dqn
from cml_edge.cml import CML, UTILITIES, CMLConfig
from cml_edge.evaluation import EVAL_SEED, evaluate_model, run_protocol
from cml_edge.exploration import EXPLORATIONS
from cml_edge.learning import SCHEDULES
from cml_edge.metrics import Pairs, draw_pairs, geodesic_distances
from cml_edge.planning import MAX_STEPS, PLANNERS, plan
from cml_edge.robot import add_robot_parser, cmd_robot
from cml_edge.robot_sim import SIMS
from cml_edge.storage import ModelFileError, atomic_write, load_model, save_model
from cml_edge.training import PATHS, TrainConfig, train


class InputError(ValueError):
    """Bad command-line input: reported as one line, exit status 2."""


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # one line, exit 2, as for every bad input
        raise InputError(message)


# shared options -------------------------------------------------------------------
# the option names each array class adds, to refuse one given to another backend
_BACKEND_OPTIONS: dict[type, list[str]] = {}


def _add_backend(p: argparse.ArgumentParser) -> None:
    p.add_argument("--backend", default="float",
                   help=f"synaptic array: {', '.join(sorted(BACKENDS))} (default float)")
    seen: set[type] = set()
    for spec in BACKENDS.values():
        cls = spec.array_class
        if cls not in seen and hasattr(cls, "add_cli_arguments"):
            seen.add(cls)
            group = p.add_argument_group(f"{cls.name} array options")
            cls.add_cli_arguments(group)
            _BACKEND_OPTIONS[cls] = [a.dest for a in group._group_actions]


def _backend_options(args: argparse.Namespace) -> dict[str, Any]:
    spec = backend_spec(args.backend)
    cls = spec.array_class
    for other, dests in _BACKEND_OPTIONS.items():
        if other is cls:
            continue
        for dest in dests:
            if getattr(args, dest, None) not in (None, False, []):
                raise InputError(f"--{dest.replace('_', '-')} is an option of the {other.name} "
                                 f"arrays, not of --backend {args.backend}")
    return cls.cli_options(args) if hasattr(cls, "cli_options") else {}


def _add_training(p: argparse.ArgumentParser) -> None:
    p.add_argument("--arena", type=arena_size, default=30, help="arena side (default 30)")
    p.add_argument("--walks", type=positive_int, default=100, help="exploration walks (100)")
    p.add_argument("--steps", type=positive_int, default=900, help="steps per walk (900)")
    p.add_argument("--explore", choices=EXPLORATIONS, default="random",
                   help="exploration strategy (random)")
    p.add_argument("--schedule", choices=SCHEDULES, default="walk",
                   help="walk: updates summed over a walk, applied at its end (the paper); "
                        "step: applied in place every step")
    p.add_argument("--utility", choices=UTILITIES, default="normalized",
                   help="planning utility: W_v columns normalised (default) or raw")
    p.add_argument("--path", choices=PATHS, default=None,
                   help="compute path: factored (float fast path), direct (compiled, through "
                        "the array), reference (plain Python); default factored for float "
                        "with the walk schedule, else direct")


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
                        "(boundary following, LRTA* fallback; see cml_edge.planning)")


def _add_map(p: argparse.ArgumentParser) -> None:
    p.add_argument("--map", default=None, metavar="FILE",
                   help="plan on a MovingAI .map file (or a shipped map: rooms, utrap, "
                        "maze); the CML never sees it in training")
    p.add_argument("--scen", default=None, metavar="FILE",
                   help="MovingAI .scen file: its (start, goal) problems replace the drawn "
                        "pairs (needs --map)")


def _load_map_args(args: argparse.Namespace):
    """(GridMap, Pairs or None) of --map / --scen, or (None, None); checks the options."""
    from cml_edge.maps import load_map, load_scen, resolve_map, scenario_pairs

    if getattr(args, "scen", None) and not args.map:
        raise InputError("--scen needs --map")
    if not args.map:
        return None, None
    if getattr(args, "obstacles", 0):
        raise InputError(f"--obstacles {args.obstacles} cannot be combined with --map (the map "
                         f"is the evaluation arena)")
    grid = load_map(resolve_map(args.map))
    pairs = None
    if getattr(args, "scen", None):
        pairs = scenario_pairs(grid, load_scen(args.scen), args.scen)
    return grid, pairs


def _budget(args: argparse.Namespace, side: int, on_map: bool) -> int:
    """--max-steps, or by default 100 (the paper's) and step_budget(side) on a map."""
    from cml_edge.maps import step_budget

    if args.max_steps is not None:
        return args.max_steps
    return step_budget(side) if on_map else MAX_STEPS


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="cml-edge", description="Cognitive Map Learner navigation on "
                     "emulated neuromorphic synaptic arrays.")
    parser.add_argument("--version", action="version", version=f"cml-edge {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)

    p = sub.add_parser("train", help="train one CML and save it")
    _add_training(p)
    _add_backend(p)
    p.add_argument("--seed", type=nonneg_int, default=0, help="model seed (0)")
    p.add_argument("--out", required=True, help="model file to write (.npz)")
    p.add_argument("--json", action="store_true", help="print one JSON object on stdout")

    p = sub.add_parser("evaluate", help="evaluate a saved model on fixed (start, goal) pairs")
    p.add_argument("model", help="model file (.npz)")
    p.add_argument("--arena", type=arena_size, default=None,
                   help="arena side (default: the training arena)")
    _add_eval(p)
    p.add_argument("--seed", type=nonneg_int, default=EVAL_SEED,
                   help=f"evaluation seed: pairs and obstacles ({EVAL_SEED})")
    p.add_argument("--path", choices=PATHS, default=None, help="compute path (see train)")
    _add_planner(p)
    _add_map(p)

    p = sub.add_parser("navigate", help="plan one path with a saved model, optionally plot it")
    p.add_argument("model", help="model file (.npz)")
    p.add_argument("--start", type=int, nargs=2, metavar=("X", "Y"), required=True)
    p.add_argument("--goal", type=int, nargs=2, metavar=("X", "Y"), required=True)
    p.add_argument("--arena", type=arena_size, default=None,
                   help="arena side (default: the training arena)")
    p.add_argument("--obstacles", type=nonneg_int, default=0, help="point obstacles (0)")
    p.add_argument("--seed", type=nonneg_int, default=EVAL_SEED, help="obstacle seed")
    p.add_argument("--max-steps", type=positive_int, default=None,
                   help="step budget (100; with --map: max(100, ceil(100 x side / 30)))")
    _add_planner(p)
    _add_map(p)
    p.add_argument("--plot", help="write a PNG of the arena and the path")
    p.add_argument("--json", action="store_true", help="print one JSON object on stdout")

    p = sub.add_parser("emulate", help="train and evaluate models on a synaptic array "
                       "(the evaluation protocol)")
    _add_training(p)
    _add_backend(p)
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

    p = sub.add_parser("sweep", help="run an experiment's (configuration x seed) tasks on a "
                       "local process pool or a Dask cluster; resumable")
    p.add_argument("experiment", help="convergence, hyperparams, exploration, generalization, "
                   "obstacles, maps or backends")
    p.add_argument("--out", default=None, help="folder (default runs/experiments/EXPERIMENT)")
    p.add_argument("--workers", type=positive_int, default=None,
                   help="local worker processes (default: one per core)")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="run on this Dask distributed scheduler (e.g. tcp://host:8786; needs "
                        "the distributed extra)")
    p.add_argument("--seeds", type=positive_int, default=10, help="model seeds 0..N-1 (10)")
    p.add_argument("--planner", choices=PLANNERS, default=None,
                   help="only this planner (default: the experiment's: both for obstacles "
                        "and maps, paper elsewhere)")
    p.add_argument("--map", default=None, metavar="FILE",
                   help="a MovingAI .map file (or shipped map name): maps and exploration "
                        "experiments")
    p.add_argument("--scen", default=None, metavar="FILE", help="its .scen file")
    p.add_argument("--json", action="store_true", help="print one JSON object on stdout")

    p = sub.add_parser("report", help="write the hardware-budget report (markdown, JSON, "
                       "figures)")
    p.add_argument("--out", default="hw_reports/latest",
                   help="report folder (default hw_reports/latest)")
    p.add_argument("--quick", action="store_true",
                   help="few seeds and trials: minutes instead of the full protocol")
    p.add_argument("--dqn-results", default=None, metavar="FILE",
                   help="DQN baseline results written by 'cml-edge dqn' (default: the "
                        "repository's hw_reports/baselines/dqn_results.json)")
    p.add_argument("--json", action="store_true", help="print the report JSON on stdout")

    p = sub.add_parser("bench", help="time the training and planning loops")
    p.add_argument("--backends", nargs="+", default=None,
                   help="backends to time (default: all registered)")
    p.add_argument("--repeats", type=positive_int, default=5, help="timed repeats (5)")
    p.add_argument("--robot", nargs="+", choices=SIMS, default=None, metavar="SIM",
                   help="also time the wheeled robot on these simulators (kinematic, mujoco)")
    p.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    add_robot_parser(sub)
    add_dqn_parser(sub)
    return parser


# commands -------------------------------------------------------------------------
def _default_path(backend: str, schedule: str, path: str | None) -> str:
    if path is not None:
        return path
    factored_ok = backend == "float" and schedule == "walk"
    return "factored" if factored_ok else "direct"


def cmd_train(args: argparse.Namespace) -> dict[str, Any]:
    options = _backend_options(args)
    path = _default_path(args.backend, args.schedule, args.path)
    config = TrainConfig(args.walks, args.steps, args.explore, args.schedule)
    cml = CML.create(CMLConfig.for_arena(args.arena, utility=args.utility), args.backend,
                     args.seed, **options)
    arena = GridArena.empty(args.arena)
    t0 = time.perf_counter()
    bar = Progress("train")
    errors = train(cml, arena, config, args.seed, path=path,
                   on_epoch=lambda done: bar(done, config.walks))
    record = {"arena": args.arena, "walks": args.walks, "steps": args.steps,
              "explore": args.explore, "schedule": args.schedule, "seed": args.seed,
              "path": path, "backend_options": options, "train_error": errors.tolist(),
              "wall_time_s": time.perf_counter() - t0, "cml_edge_version": __version__,
              "command": "cml-edge " + " ".join(sys.argv[1:])}
    save_model(args.out, cml, record)
    out = {"model": args.out, "backend": args.backend, **{k: record[k] for k in (
        "arena", "walks", "steps", "explore", "schedule", "seed", "path", "wall_time_s")},
        "final_train_error": float(errors[-1])}
    if path != "factored":  # the factored shortcut bypasses the arrays: nothing to count
        out["counters"] = cml.counters()
    return out


def _load(path: str) -> tuple[CML, dict[str, Any]]:
    return load_model(path)


def _eval_arena(args: argparse.Namespace, record: dict[str, Any]) -> GridArena:
    size = args.arena if args.arena is not None else int(record.get("arena", 30))
    if args.obstacles:
        return GridArena.with_obstacles(size, args.obstacles, args.seed)
    return GridArena.empty(size)


def cmd_evaluate(args: argparse.Namespace) -> dict[str, Any]:
    grid, scen_pairs = _load_map_args(args)
    if grid is not None and args.arena is not None:
        raise InputError(f"--arena {args.arena} cannot be combined with --map (the map sets "
                         f"the arena)")
    cml, record = _load(args.model)
    arena = grid.arena() if grid is not None else _eval_arena(args, record)
    pairs = scen_pairs or draw_pairs(arena, args.trials, args.seed)
    path = _default_path(cml.backend, "walk", args.path)
    budget = _budget(args, arena.size, grid is not None)
    result = evaluate_model(cml, arena, pairs, path=path, max_steps=budget,
                            planner=args.planner)
    out = {"model": args.model, "backend": cml.backend, "seeds": 1, **result,
           "arena": arena.size, "obstacles": args.obstacles, "eval_seed": args.seed,
           "path": path, "planner": args.planner, "max_steps": budget}
    if grid is not None:
        out.update({"map": args.map, "scen": args.scen})
    return out


def cmd_navigate(args: argparse.Namespace) -> dict[str, Any]:
    if args.scen:
        raise InputError("--scen is not used by navigate (give --start and --goal)")
    grid, _ = _load_map_args(args)
    if grid is not None and args.arena is not None:
        raise InputError(f"--arena {args.arena} cannot be combined with --map (the map sets "
                         f"the arena)")
    cml, record = _load(args.model)
    arena = grid.arena() if grid is not None else _eval_arena(args, record)
    for name, pos in (("start", args.start), ("goal", args.goal)):
        if not arena.contains(pos):
            raise InputError(f"--{name} {pos[0]} {pos[1]} is off the {arena.size} x "
                             f"{arena.size} arena (allowed: 0..{arena.size - 1})")
        if not arena.is_free(pos):
            raise InputError(f"--{name} {pos[0]} {pos[1]} is on an obstacle")
    starts, goals = np.array([args.start]), np.array([args.goal])
    res = plan(cml, arena, starts, goals, max_steps=_budget(args, arena.size, grid is not None),
               path=_default_path(cml.backend, "walk", None), planner=args.planner)
    steps = int(res.steps[0])
    trajectory = res.paths[0, : steps + 1]
    pairs = Pairs(starts, goals, np.abs(starts - goals).max(1),
                  geodesic_distances(arena, starts, goals))
    final = res.final[0]
    out = {"start": list(args.start), "goal": list(args.goal), "final": final.tolist(),
           "steps": steps, "reached": bool((final == goals[0]).all()),
           "e_pos": float(np.linalg.norm(final - goals[0])),
           "chebyshev": int(pairs.chebyshev[0]), "geodesic": int(pairs.geodesic[0]),
           "planner": args.planner, "path": trajectory.tolist()}
    if args.plot:
        from cml_edge.plots import plot_navigation

        plot_navigation(args.plot, arena, trajectory, args.start, args.goal)
        out["plot"] = args.plot
    return out


def cmd_emulate(args: argparse.Namespace) -> dict[str, Any]:
    if args.drift_time < 0:
        raise InputError(f"--drift-time {args.drift_time} is negative (allowed: >= 0 seconds)")
    options = _backend_options(args)
    grid, scen_pairs = _load_map_args(args)
    size = args.arena
    if grid is not None:
        if args.arena not in (30, grid.side):  # 30: the default, replaced by the map's side
            raise InputError(f"--arena {args.arena} conflicts with --map ({grid.side} x "
                             f"{grid.side}); leave --arena out")
        size = grid.side
    config = TrainConfig(args.walks, args.steps, args.explore, args.schedule)
    path = args.path or "direct"
    result = run_protocol(args.backend, range(args.seeds), args.trials, size,
                          args.obstacles, config,
                          CMLConfig.for_arena(size, utility=args.utility),
                          eval_seed=args.eval_seed, path=path, idle_s=args.drift_time,
                          progress=Progress(f"emulate {args.backend}"),
                          planner=args.planner,
                          max_steps=_budget(args, size, grid is not None),
                          eval_arena=grid.arena() if grid is not None else None,
                          pairs=scen_pairs, **options)
    if grid is not None:
        result.update({"map": args.map, "scen": args.scen})
    result["command"] = "cml-edge " + " ".join(sys.argv[1:])
    result["cml_edge_version"] = __version__
    if args.out:
        atomic_write(args.out, lambda f: f.write(json.dumps(result, indent=1).encode()))
    return result


def cmd_report(args: argparse.Namespace) -> dict[str, Any]:
    from cml_edge.report import build_report, write_report
    from cml_edge.report.build import DQN_RESULTS

    def progress(message: str) -> None:
        if sys.stderr.isatty():
            print(f"report: {message}", file=sys.stderr, flush=True)

    if args.dqn_results is not None and not Path(args.dqn_results).is_file():
        raise InputError(f"--dqn-results {args.dqn_results!r}: no such file")
    report = build_report(quick=args.quick, command="cml-edge " + " ".join(sys.argv[1:]),
                          progress=progress, dqn_results=args.dqn_results or DQN_RESULTS)
    folder = write_report(report, args.out)
    if args.json:
        return report
    return {"report": str(folder / "report.md"), "systems": len(report["systems"]),
            "wall_time_s": report["wall_time_s"]}


def cmd_bench(args: argparse.Namespace) -> dict[str, Any]:
    from cml_edge.bench import run_bench

    names = args.backends or sorted(BACKENDS)
    for name in names:
        backend_spec(name)
    result = run_bench(names, repeats=args.repeats, progress=Progress("bench"))
    if args.robot:
        from cml_edge.bench import bench_robot

        result["robot"] = bench_robot(args.robot, args.repeats)
    return result


def cmd_sweep(args: argparse.Namespace) -> dict[str, Any]:
    from cml_edge import experiments
    from cml_edge.experiments.common import markdown_table, run_experiment

    module = experiments.get(args.experiment)
    if args.scen and not args.map:
        raise InputError("--scen needs --map")
    if args.map:  # fail on a bad file now, before any task runs
        from cml_edge.maps import load_map, load_scen, resolve_map

        load_map(resolve_map(args.map))
        if args.scen:
            load_scen(args.scen)
    summary = run_experiment(module, args.out, workers=args.workers, scheduler=args.scheduler,
                             progress=Progress(f"sweep {args.experiment}"), seeds=args.seeds,
                             planner=args.planner, map=args.map, scen=args.scen)
    summary["command"] = "cml-edge " + " ".join(sys.argv[1:])
    if not args.json:
        print(markdown_table(summary["rows"], module.COLUMNS))
        print(f"results: {summary['out']}/results.json, results.csv, figure.png")
        summary["_printed"] = True
    return summary


COMMANDS = {"train": cmd_train, "evaluate": cmd_evaluate, "navigate": cmd_navigate,
            "emulate": cmd_emulate, "report": cmd_report, "bench": cmd_bench,
            "sweep": cmd_sweep}
COMMANDS["dqn"] = cmd_dqn
COMMANDS["robot"] = cmd_robot


def _print_human(command: str, result: dict[str, Any]) -> None:
    skip = {"per_seed", "curve_e_pos_mean", "train_error", "path", "seed_list", "counters"}
    for k, v in result.items():
        if k in skip and command != "navigate" or isinstance(v, dict):
            continue
        if isinstance(v, float):
            v = f"{v:.4f}"
        print(f"{k:>24}: {v}")
    for group in ("counters", "backends"):
        if isinstance(result.get(group), dict):
            print(f"{group}:")
            for k, v in result[group].items():
                print(f"{k:>24}: {v}")


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
        result = COMMANDS[args.command](args)
    except (InputError, ModelFileError, ValueError) as exc:
        print(f"cml-edge: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("cml-edge: interrupted", file=sys.stderr)
        return 130
    if getattr(args, "json", False):
        print(json.dumps(result))
    elif not result.get("_printed"):
        _print_human(args.command, result)
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
