"""``cml-edge lava verify MODEL --epochs K``: a saved loihi2 model run in Intel Lava's own
CPU simulator and compared integer for integer (:mod:`cml_edge.backends.loihi2.conformance`);
``cml-edge lava run MODEL --trials N``: the navigator planning with every read computed in
Lava (:mod:`cml_edge.grid.in_lava`).

Lava 0.10.0 runs on Python 3.10 in an environment of its own: ``bash scripts/lava_env.sh``
builds it; without it the command stops with one line naming that command (exit 2).
"""

from __future__ import annotations

import argparse
from typing import Any

from cml_edge.cli.args import nonneg_int, positive_int
from cml_edge.errors import InputError

MAX_COUNT = 1000  # epochs and reads: each epoch is one Lava run step of a few milliseconds


def add_parsers(sub) -> None:
    """The lava command group."""
    p = sub.add_parser("lava", help="run a loihi2 model in Intel Lava (optional environment: "
                       "bash scripts/lava_env.sh)")
    lava_sub = p.add_subparsers(dest="lava_command", required=True)
    v = lava_sub.add_parser("verify", help="compare a loihi2 model's reads and K updates of "
                            "its own training with Lava 0.10.0's fixed_pt simulator, integer "
                            "for integer")
    v.add_argument("model", help="model file (.npz) trained with --backend loihi2")
    v.add_argument("--epochs", type=positive_int, default=20, metavar="K",
                   help="updates of the model's own training replayed per matrix, one epoch "
                        "each, 1..1000 (default 20)")
    v.add_argument("--skip", type=nonneg_int, default=0, metavar="N",
                   help="start the replay after the training's first N updates (default 0)")
    v.add_argument("--reads", type=positive_int, default=16, metavar="N",
                   help="input vectors per read (W_q, W_k, W_v, W_v^T), 1..1000 (default 16)")
    v.add_argument("--seed", type=nonneg_int, default=0,
                   help="seed of the vectors and updates (default 0)")
    v.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    v.set_defaults(run=cmd_verify, show=show_verify)
    r = lava_sub.add_parser("run", help="plan the protocol's pairs with every read (utility, "
                            "affordance) computed in Lava 0.10.0; decisions against the "
                            "emulation's")
    r.add_argument("model", help="model file (.npz) trained with --backend loihi2")
    r.add_argument("--trials", type=positive_int, default=100,
                   help="(start, goal) pairs of the protocol, on the model's training arena, "
                        "1..1000 (default 100)")
    r.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    r.set_defaults(run=cmd_run)


def cmd_verify(args: argparse.Namespace) -> dict[str, Any]:
    from cml_edge.backends.loihi2.conformance import check_replayable, venv_python, verify
    from cml_edge.core.model_file import load_model
    from cml_edge.grid.in_lava import training_updates

    for flag, value in (("--epochs", args.epochs), ("--reads", args.reads)):
        if value > MAX_COUNT:
            raise InputError(f"{flag} {value} is beyond {MAX_COUNT} (allowed: 1..{MAX_COUNT})")
    cml, training = load_model(args.model)
    check_replayable(cml, args.model, training.get("schedule", "step"))
    venv_python()  # before any work
    updates = training_updates(cml, training, args.epochs, skip=args.skip)
    return verify(cml, args.model, updates, reads=args.reads, seed=args.seed)


def cmd_run(args: argparse.Namespace) -> dict[str, Any]:
    from cml_edge.backends.loihi2.array import Loihi2Array
    from cml_edge.backends.loihi2.conformance import venv_python
    from cml_edge.cli.tools import StageProgress
    from cml_edge.core.model_file import load_model
    from cml_edge.grid.condition import Condition
    from cml_edge.grid.in_lava import run_in_lava
    from cml_edge.grid.metrics import summarize
    from cml_edge.grid.planning import plan
    from cml_edge.protocol import EVAL_SEED

    if args.trials > MAX_COUNT:
        raise InputError(f"--trials {args.trials} is beyond {MAX_COUNT} (allowed: "
                         f"1..{MAX_COUNT})")
    cml, training = load_model(args.model)
    if any(not isinstance(arr, Loihi2Array) for arr in cml.arrays):
        raise InputError(f"{args.model!r} is a {cml.backend} model; lava run plans with "
                         "loihi2 models (allowed: a model trained with --backend loihi2)")
    if "arena" not in training:
        raise InputError(f"{args.model!r} does not record its training arena (allowed: a "
                         "model written by cml-edge train)")
    venv_python()  # before any work
    ev = Condition(trials=args.trials, eval_seed=EVAL_SEED).evaluation(int(training["arena"]))
    arena, pairs, budget = ev.arena, ev.pairs, ev.max_steps
    emulated = plan(cml, arena, pairs.starts, pairs.goals, max_steps=budget)
    result = run_in_lava(cml, arena, pairs, budget, progress=StageProgress("lava run"))
    return {"model": str(args.model), "arena": arena.size, "trials": args.trials,
            "max_steps": budget, **result,
            "emulation_success_rate": summarize(emulated.final, emulated.steps,
                                                pairs)["success_rate"]}


def show_verify(r: dict[str, Any]) -> None:
    """``lava verify``: per read and per matrix's replayed updates, how many match Lava."""
    from cml_edge.cli.output import labelled

    print(f"lava verify: {r['model']} in {r['lava']}")
    rows = [(f"read {name}", f"{x['read_equal']} of {x['vectors']} vectors equal (a_out "
             f"{x['a_out_equal']}, u {x['u_equal']})") for name, x in r["reads"].items()]
    rows += [(f"learning {name}", f"{x['equal']} of {x['replayed']} replayed updates end on "
              f"the emulation's weights ({x['negative_pre']:,} negative pre trace entries "
              f"sent, {x['offset']} epochs offset, {x['decayed']} traces decayed; "
              f"{x['not_expressible']} not expressible)")
             for name, x in r["learning"].items()]
    print("\n".join(labelled([*rows, ("bit exact", "yes" if r["bit_exact"] else "no")])))
