"""``cml-edge sweep | report | bench``: experiments, the hardware-budget report, speed."""

from __future__ import annotations

import argparse
import inspect
import json
import sys
import time
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

from cml_edge.backends import BACKENDS, configurations, report_systems
from cml_edge.cli import limits
from cml_edge.cli.args import Progress, command_line, positive_int, say_estimate
from cml_edge.cli.output import labelled, num, plural, secs, table
from cml_edge.errors import InputError
from cml_edge.experiments import EXPERIMENTS
from cml_edge.grid.arena import DIMS, MOVE_SETS
from cml_edge.grid.planning import PLANNERS
from cml_edge.io.files import writable_folder
from cml_edge.robot.sim import SIMS


def add_parsers(sub) -> None:
    """The experiment, report and benchmark commands."""
    p = sub.add_parser("sweep", help="run an experiment's (configuration x seed) tasks on a "
                       "local process pool or a Dask cluster; resumable")
    p.add_argument("experiment", help=", ".join(EXPERIMENTS[:-1]) + " or " + EXPERIMENTS[-1])
    p.add_argument("--out", required=True, metavar="FOLDER",
                   help="folder: tasks/ (resumable), results.json, .csv and the figure")
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
    p.add_argument("--dims", type=int, choices=DIMS, default=2,
                   help="2: the paper's N x N plane; 3: the N x N x N volume (the experiments "
                        "on empty arenas and obstacles; not the plane's maps) (default 2)")
    p.add_argument("--moves", choices=MOVE_SETS, default="king",
                   help="king: every neighbour (8 on the plane, 26 in space); face: the axis "
                        "neighbours only (4, 6) (default king)")
    p.add_argument("--backends", nargs="+", default=None, metavar="NAME",
                   help="only these devices (backend or backend:preset names): the sensors "
                        "experiment (default: every registered device)")
    p.add_argument("--restart", action="store_true",
                   help="start the run in --out over (a run folder of other settings is "
                        "refused without it)")
    p.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    p.set_defaults(run=cmd_sweep, show=show_sweep)

    p = sub.add_parser("report", help="write the hardware-budget report (an HTML page, "
                       "markdown, JSON, figures)")
    p.add_argument("--out", default=None, metavar="FOLDER",
                   help="report folder (report.html, report.md, report.json, figures)")
    p.add_argument("--render", default=None, metavar="FOLDER",
                   help="render a report folder again from its report.json, running nothing "
                        "(instead of --out)")
    p.add_argument("--compare", default=None, metavar="OLD_FOLDER",
                   help="show what changed since the report in this folder (per device and "
                        "scenario, in report.html and report.md)")
    p.add_argument("--quick", action="store_true",
                   help="every section on 2 seeds at the quick budget (30 walks, 50 "
                        "pairs): a fraction of the full protocol's time")
    p.add_argument("--dqn-results", default=None, metavar="FILE",
                   help="DQN baseline results written by 'cml-edge dqn' (default: the "
                        "repository's hw_reports/baselines/dqn_results.json)")
    p.add_argument("--workers", type=positive_int, default=None,
                   help="local worker processes (default: one per core)")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="run on this Dask distributed scheduler (e.g. tcp://host:8786; needs "
                        "the distributed extra)")
    p.add_argument("--restart", action="store_true",
                   help="start over a report interrupted in --out (it resumes without)")
    p.add_argument("--with", dest="with_", action="append", default=[],
                   metavar="BACKEND[:PRESET]",
                   help="also run this device in the budget and the scorecard (repeatable: a "
                        "plugin's device, or a configuration the report leaves out)")
    p.add_argument("--json", action="store_true", help="print the report JSON on stdout")
    p.set_defaults(run=cmd_report, show=show_report)

    p = sub.add_parser("bench", help="time the training and planning loops")
    p.add_argument("--backends", nargs="+", default=None,
                   help="backends to time (default: all registered); BACKEND:PRESET "
                        "times one preset (crossbar:reram)")
    p.add_argument("--presets", action="store_true",
                   help="time every preset of a backend that takes one (crossbar: ideal, pcm, "
                        "reram, pcm-symmetric, reram-symmetric)")
    p.add_argument("--set", dest="settings", action="append", default=[],
                   metavar="FIELD=VALUE",
                   help="set a device field of every named backend, repeatable (e.g. "
                        "crossbar:pcm --set out_noise=0: the preset without its read noise); "
                        "float64, the ratios' denominator, is timed as it is")
    p.add_argument("--repeats", type=positive_int, default=5, help="timed repeats (5)")
    p.add_argument("--dims", type=int, choices=DIMS, default=2,
                   help="3: also time each backend's direct path in the 30 x 30 x 30 volume "
                        "and its training step per synapse against the plane's (default 2)")
    p.add_argument("--moves", choices=MOVE_SETS, default="king",
                   help="the volume's moves with --dims 3: king (26) or face (6) (king)")
    p.add_argument("--robot", nargs="+", choices=SIMS, default=None, metavar="SIM",
                   help="also time the wheeled robot on these simulators (kinematic, mujoco)")
    p.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    p.set_defaults(run=cmd_bench, show=show_bench)


def _report_folders(args: argparse.Namespace) -> tuple[dict[str, Any], str] | None:
    """Check --out / --render and --compare before any work; the report to compare with
    and its folder (None without --compare)."""
    from cml_edge.report import check_report_folder, load_report

    if (args.out is None) == (args.render is None):
        raise InputError("give one of --out FOLDER (run the report) and --render FOLDER "
                         "(render a report folder again from its report.json)")
    if args.render is not None:
        load_report(args.render, "--render")
    out, flag = (args.out, "--out") if args.out else (args.render, "--render")
    writable_folder(out, flag)
    writable_folder(Path(out).parent, f"{flag}'s folder")  # the report is renamed there
    check_report_folder(out, flag)
    if args.compare is None:
        return None
    return load_report(args.compare, "--compare"), args.compare


def cmd_report(args: argparse.Namespace) -> dict[str, Any]:
    from cml_edge.baselines import load_results
    from cml_edge.baselines.settings import RESULTS_PATH
    from cml_edge.engine import timings
    from cml_edge.engine.sweep import check_scheduler
    from cml_edge.report import build_report, render_report, write_report
    from cml_edge.report.scorecard import ScorecardPlan

    old = _report_folders(args)
    if args.render is not None:
        folder = render_report(args.render, old)
        return _written(folder, json.loads((folder / "report.json").read_text()))
    if args.dqn_results is not None and not Path(args.dqn_results).is_file():
        raise InputError(f"--dqn-results {args.dqn_results!r}: no such file")
    load_results(args.dqn_results or RESULTS_PATH)  # a bad file fails now, not after the runs
    if args.scheduler is not None:
        check_scheduler(args.scheduler)
    extra = [c for c in configurations(args.with_) if c not in report_systems()]
    plan = ScorecardPlan.of(args.quick)
    say_estimate()
    report = build_report(quick=args.quick, command=command_line(),
                          systems=report_systems() + extra,
                          scorecard=replace(plan, devices=plan.devices + extra),
                          progress=StageProgress("report"),
                          dqn_results=args.dqn_results or RESULTS_PATH, folder=args.out,
                          workers=args.workers, scheduler=args.scheduler,
                          restart=args.restart)
    report["timings"] = timings.snapshot()  # the run's stages, in report.json too
    folder = write_report(report, args.out, old)
    return report if args.json else _written(folder, report)


def _written(folder: Path, report: dict[str, Any]) -> dict[str, Any]:
    """What ``report`` prints without --json: where the files are, the verdicts."""
    from cml_edge.report.verdict import device_verdicts

    worst = device_verdicts(report.get("scorecard") or [])
    return {"page": str(folder / "report.html"), "report": str(folder / "report.md"),
            "json": str(folder / "report.json"), "systems": len(report["systems"]),
            "verdicts": {d: v.text() for d, v in worst.items()},
            "wall_time_s": report["wall_time_s"]}


class StageProgress:
    """Progress of a command's stages ``(stage, done, total)`` on any stderr: a bar per
    stage on a terminal (:class:`~cml_edge.cli.args.Progress`); elsewhere (a log, a CI
    job) a line when a stage starts, at every tenth of it and when it ends, with the
    minutes since the command started."""

    def __init__(self, label: str) -> None:
        self.label = label
        self.bars: dict[str, Progress] = {}
        self.said: dict[str, int] = {}
        self.t0 = time.perf_counter()

    def __call__(self, stage: str, done: int, total: int) -> None:
        if sys.stderr.isatty():
            self.bars.setdefault(stage, Progress(f"{self.label}: {stage}"))(done, total)
            return
        tenth = 10 * done // max(total, 1)
        if self.said.get(stage) == tenth:
            return
        self.said[stage] = tenth
        minutes = (time.perf_counter() - self.t0) / 60
        print(f"{self.label}: {stage}: {done}/{total} tasks ({minutes:.1f} min)",
              file=sys.stderr, flush=True)


def cmd_bench(args: argparse.Namespace) -> dict[str, Any]:
    from cml_edge.bench.timing import bench_names, run_bench

    names = bench_names(args.backends or sorted(BACKENDS), args.presets)
    result = run_bench(names, repeats=args.repeats, progress=Progress("bench"),
                       settings=args.settings, dims=args.dims, moves=args.moves)
    if args.robot:
        from cml_edge.bench.timing import bench_robot

        result["robot"] = bench_robot(args.robot, args.repeats)
    return result


def cmd_sweep(args: argparse.Namespace) -> dict[str, Any]:
    from cml_edge import experiments
    from cml_edge.engine.sweep import check_scheduler
    from cml_edge.experiments.common import run_experiment

    module = experiments.get(args.experiment)
    space = {} if (args.dims, args.moves) == (2, "king") else {"dims": args.dims,
                                                                "moves": args.moves}
    if space:
        from cml_edge.experiments.common import space_tasks

        space_tasks(module, [], **space)  # an experiment of the plane only fails now
        if args.map:
            raise InputError(f"--map with --dims {args.dims}: the experiments' maps are "
                             "MovingAI plane maps (voxel maps: cml-edge emulate --dims 3 --map)")
    if args.scheduler is not None:
        check_scheduler(args.scheduler)
    writable_folder(args.out, "--out")
    if args.scen and not args.map:
        raise InputError("--scen needs --map")
    if args.map:  # fail on a bad file now, before any task runs
        from cml_edge.grid.maps import load_map, load_scen, resolve_map

        grid = load_map(resolve_map(args.map))
        problems = {"trials": len(load_scen(args.scen))} if args.scen else {}
        limits.recheck(args, arena=grid.side, **problems)
    devices = {}
    if args.backends is not None:
        if "backends" not in inspect.signature(module.tasks).parameters:
            raise InputError(f"experiment {args.experiment!r} does not take --backends")
        configurations(args.backends)  # an unknown name fails now, before any task runs
        devices = {"backends": args.backends}
    summary = run_experiment(module, args.out, workers=args.workers, scheduler=args.scheduler,
                             progress=Progress(f"sweep {args.experiment}"), seeds=args.seeds,
                             planner=args.planner, map=args.map, scen=args.scen,
                             restart=args.restart, **devices, **space)
    summary["command"] = command_line()
    return summary


# what a person reads (--json: the result) ----------------------------------------
def show_bench(r: dict[str, Any]) -> None:
    """``bench``: CPU microseconds per step of each backend, and the ratios measured in
    the same run (float64 to the hand-fused yardstick, any other backend to float64)
    against their goals."""
    ratios = r["ratios"]
    print(f"bench: CPU us per step, median of {plural(r['repeats'], 'run')} ({r['walks']} x "
          f"{r['steps']}-step training, 100 plans)")
    rows = []

    def row(name: str, figs: dict[str, float], keys: Sequence[str], vs: str | None) -> None:
        ratio = ratios.get(vs, {}) if vs else {}
        met = [ratio[k] <= ratio["goal"] for k in ("train", "plan") if k in ratio]
        rows.append([name, *("" if figs.get(k) is None else num(figs[k]) for k in keys),
                     *("" if ratio.get(k) is None else num(ratio[k]) for k in ("train", "plan")),
                     f"<= {ratio['goal']:g} {'met' if all(met) else 'missed'}" if met else ""])

    direct = ("train_step_us_random", "train_step_us_mixed", "plan_step_us")
    figs = r["backends"]
    row("float", figs.get("float", {}), direct, "float64 direct / fused")
    row("float factored", figs.get("float", {}),
        ("train_step_us_factored", "", "plan_step_us_factored"), "factored / fused factored")
    for name, f in figs.items():
        if name != "float":
            row(name, f, direct, f"{name} / float64 direct")
    fused = ("train_step_us_fused", "", "plan_step_us_fused")
    row("yardstick (fused)", r["yardstick"], fused, None)
    row("yardstick factored", r["yardstick"], ("train_step_us_fused_factored", "", ""), None)
    print("\n".join("  " + line for line in table(rows, [
        "backend", "train", "mixed", "plan", "train x", "plan x", "goal"])))
    print("  mixed: training with mixed exploration; train x, plan x: over float's step, "
          "and\n  float's over the hand-fused yardstick's (factored: the fused factored's)")
    for sim, f in (r.get("robot") or {}).items():
        print(f"  robot on {sim}: {num(f['train_actions_per_s'])} training and "
              f"{num(f['plan_actions_per_s'])} planning actions/s")
    if "space" in r:
        space = r["space"]
        rows = [[name, num(f["train_step_us_random"]), num(f["plan_step_us"]),
                 num(f["train_step_ns_per_synapse_2d"]), num(f["train_step_ns_per_synapse_3d"]),
                 num(f["ratio"]),
                 f"<= {f['goal']:g} {'met' if f['ratio'] <= f['goal'] else 'missed'}"]
                for name, f in space["backends"].items()]
        print(f"  in {space['dims']}-D ({space['moves']} moves), 30 x 30 x 30: CPU us per step, "
              "and the training step per synapse (ns) against the plane's")
        print("\n".join("  " + line for line in table(rows, [
            "backend", "train", "plan", "ns/syn 2-D", "ns/syn 3-D", "3-D / 2-D", "goal"])))


def show_report(r: dict[str, Any]) -> None:
    """``report``: where its page and files are, and each device's worst verdict."""
    print(f"report: {r['page']} (open it in a browser), {r['report']}, {r['json']}")
    rows = [(device, verdict) for device, verdict in r["verdicts"].items()]
    if rows:
        print("  worst verdict of each device over the scorecard's scenarios:")
        print("\n".join("  " + line for line in labelled(rows)))
    print(f"  {plural(r['systems'], 'system')} in the budget; the report took "
          f"{secs(r['wall_time_s'])}")


def show_sweep(r: dict[str, Any]) -> None:
    """``sweep``: the experiment's table and where its files are."""
    from cml_edge import experiments
    from cml_edge.experiments.common import markdown_table

    print(markdown_table(r["rows"], experiments.get(r["experiment"]).COLUMNS))
    print(f"results: {r['out']}/results.json, results.csv, figure.png")
