"""``cml-edge scenario | breakpoint``: the workloads that tell devices apart."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from cml_edge.cli.args import (
    Progress,
    add_backend,
    add_chip_flags,
    backend_options,
    chip_flags,
    command_line,
    finite_float,
    positive_int,
    say_estimate,
)
from cml_edge.cli.output import device_label, labelled, num, pct, plural, table
from cml_edge.core.finite import dumps
from cml_edge.engine.timings import stage
from cml_edge.grid.arena import DIMS, MOVE_SETS
from cml_edge.io.files import atomic_write_text, writable_file, writable_folder
from cml_edge.scenarios.breakpoint import MIN_SEEDS, find_breakpoint, knob_names
from cml_edge.scenarios.registry import BUDGETS, SCENARIOS, get
from cml_edge.scenarios.runner import run_scenario


def _add_common(p: argparse.ArgumentParser, seeds: int) -> None:
    add_backend(p)
    p.add_argument("--seeds", type=positive_int, default=seeds,
                   help=f"model seeds 0..N-1 ({seeds})")
    p.add_argument("--budget", choices=BUDGETS, default=None,
                   help="walks x steps and trials of every run: full (the paper's 100 x "
                        "900, 100 trials; default), quick (30 x 900, 50), tiny (3 x 100, "
                        "6: a smoke test)")
    p.add_argument("--quick", action="store_true", help="the quick budget (--budget quick)")
    p.add_argument("--workers", type=positive_int, default=None,
                   help="local worker processes (default: one per core)")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="run on this Dask distributed scheduler (tcp://host:8786)")
    p.add_argument("--dims", type=int, choices=DIMS, default=None,
                   help="2: the grid's N x N plane; 3: its N x N x N volume (the scenario's "
                        "3-D form: the empty 30^3 volume, 9,000 and 12,000 obstacles, the "
                        "shipped voxel maps, a 60^3 volume); default: the scenario's own (2)")
    p.add_argument("--moves", choices=MOVE_SETS, default="king",
                   help="the grid's moves: king, every neighbour (8 on the plane, 26 in "
                        "space); face, the axis neighbours only (4, 6) (default king)")
    p.add_argument("--json", action="store_true", help="print one JSON object on stdout")


def _add_restart(p: argparse.ArgumentParser) -> None:
    p.add_argument("--restart", action="store_true",
                   help="start the run in --out over (a run folder of other settings is "
                        "refused without it)")


def add_parsers(sub) -> None:
    """The scenario and break-point commands."""
    p = sub.add_parser("scenario", help="run a named scenario on a device (resumable sweep)")
    p.add_argument("name", help=f"scenario: {', '.join(SCENARIOS)}")
    _add_common(p, 10)
    p.add_argument("--out", default=None, help="folder: tasks/ (resumable) and results.json")
    _add_restart(p)
    add_chip_flags(p)
    p.set_defaults(run=cmd_scenario, show=show_scenario)

    p = sub.add_parser("breakpoint", help="the knob value where a scenario's success "
                       "crosses a target (bisection on a seeded grid)")
    p.add_argument("--knob", required=True, help=f"device setting: {', '.join(knob_names())}")
    p.add_argument("--scenario", required=True, help=f"scenario: {', '.join(SCENARIOS)}")
    p.add_argument("--target", type=finite_float, default=0.95,
                   help="success rate to cross (0.95)")
    p.add_argument("--range", type=finite_float, nargs=2, metavar=("LO", "HI"), default=None,
                   help="knob range (default: the knob's)")
    p.add_argument("--part", default=None,
                   help="the scenario part whose success counts (default: the worst part)")
    _add_common(p, 3)
    p.add_argument("--out", default=None,
                   help="folder: one resumable sweep per knob value, and breakpoint.json")
    _add_restart(p)
    p.set_defaults(run=cmd_breakpoint, show=show_breakpoint)


def _outputs(args: argparse.Namespace) -> None:
    """--out and --scheduler, checked before any work."""
    from cml_edge.engine.sweep import check_scheduler

    if args.scheduler is not None:
        check_scheduler(args.scheduler)
    if args.out is not None:
        writable_folder(args.out, "--out")
    elif getattr(args, "restart", False):
        from cml_edge.errors import InputError

        raise InputError("--restart needs --out (the run folder to start over)")


def _budget(args: argparse.Namespace) -> str:
    from cml_edge.errors import InputError

    if args.quick and args.budget not in (None, "quick"):
        raise InputError(f"--quick conflicts with --budget {args.budget}")
    return "quick" if args.quick else (args.budget or "full")


def cmd_scenario(args: argparse.Namespace) -> dict[str, Any]:
    chips = chip_flags(args)  # checked now, before any task
    on_chips = {} if chips is None else {"chips": chips["n"], "first_chip": chips["first"],
                                         "yield_target": chips["yield_target"]}
    get(args.name).space(args.dims, args.moves)  # before any work
    _outputs(args)
    result = run_scenario(args.name, args.backend, backend_options(args), args.seeds,
                          _budget(args), args.out, args.workers, args.scheduler,
                          Progress(f"scenario {args.name}"), command=command_line(),
                          restart=args.restart, dims=args.dims, moves=args.moves, **on_chips)
    return result


def _say_before_runs(notes: list[str]) -> None:
    say_estimate()
    for note in notes:
        print(f"cml-edge: note: {note}", file=sys.stderr)


def cmd_breakpoint(args: argparse.Namespace) -> dict[str, Any]:
    from cml_edge.errors import InputError

    if args.seeds < MIN_SEEDS:
        raise InputError(f"--seeds {args.seeds}: a break point needs at least {MIN_SEEDS}")
    _outputs(args)
    if args.out is not None:
        writable_file(f"{args.out}/breakpoint.json", "--out")
    result = find_breakpoint(args.scenario, args.backend, args.knob, backend_options(args),
                             args.target, args.seeds, tuple(args.range) if args.range else None,
                             _budget(args), args.part, args.out, args.workers, args.scheduler,
                             command_line(), args.restart,
                             on_start=_say_before_runs, dims=args.dims, moves=args.moves)
    if args.out is not None:
        with stage("write"):
            atomic_write_text(f"{args.out}/breakpoint.json", dumps(result, indent=1))
    return result


# what a person reads (--json: the result) ----------------------------------------
def _world(r: dict[str, Any]) -> str:
    """`` (3-D, king moves)`` off the plane's king moves; nothing on it."""
    return f" ({r['dims']}-D, {r['moves']} moves)" if "dims" in r else ""


def show_scenario(r: dict[str, Any]) -> None:
    """``scenario``: its parts as a table (success, overhead, the fidelity means, pulses
    and energy where the device counts them), and the yield over chips."""
    from cml_edge.experiments.common import markdown_table

    rows = [{"part": p["part"], "success": p["success_rate"], "overhead": p["overhead_mean"],
             "weight error": p["weight_error"]["matrix_mean"]["mean"],
             "agreement": p["decision_agreement"]["mean"],
             **({"pulses": p["pulses"]["mean"], "energy uJ": p["energy_uJ"]["mean"]}
                if "pulses" in p else {})} for p in r["parts"]]
    chips = f" x {plural(len(r['chip_seeds']), 'chip')}" if "chip_seeds" in r else ""
    print(f"{r['scenario']}{_world(r)} on {device_label(r['backend'], r['backend_options'])}: "
          f"{plural(r['seeds'], 'seed')}{chips}, {r['budget']} budget")
    print(markdown_table(rows, tuple(rows[0])))
    for p in r["parts"]:
        if "chips" in p:
            s = p["chips"]["success_rate"]
            print(f"{p['part']}: yield {p['yield']:.3f} (success >= {p['yield_target']:g}) "
                  f"over {p['chips']['n']} chips; success mean {s['mean']:.3f}, p05 "
                  f"{s['p05']:.3f}, median {s['median']:.3f}, p95 {s['p95']:.3f}")


def show_breakpoint(r: dict[str, Any]) -> None:
    """``breakpoint``: the knob value found, its bracket, and each value evaluated."""
    part = r["part"] or "the worst part"
    print(f"breakpoint: {r['knob']} ({r['field']}) on {r['scenario']}{_world(r)}, "
          f"{device_label(r['backend'], r['backend_options'])}; {plural(r['seeds'], 'seed')}, "
          f"{r['budget']} budget")
    if r.get("found", True):
        found = [("break point", f"{num(r['value'])}: the last value toward the {r['good']} "
                                 f"end whose success ({part}) is >= {r['target']:g}"),
                 ("bracket", f"{num(r['bracket'][0])} passes, {num(r['bracket'][1])} fails")]
    else:
        found = [("break point", r["note"])]
    rise = r.get("largest_rise")
    if rise is not None:
        found.append(("not monotone", f"success rose {rise['by']:.3f} from {num(rise['from'])} "
                                      f"to {num(rise['to'])}, toward the bad end (bisection "
                                      "assumes it falls)"))
    print("\n".join(labelled([
        *found,
        ("searched", f"{num(r['range'][0])} .. {num(r['range'][1])}, "
                     f"{plural(len(r['grid']), 'grid value')}")])))
    rows = [[num(e["value"]), pct(e["success_rate"])]
            for e in sorted(r["evaluations"], key=lambda e: e["value"])]
    print("\n".join("  " + line for line in table(rows, [r["knob"], "success"])))
