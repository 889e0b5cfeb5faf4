"""``cml-edge dqn train | evaluate``: the DQN baseline (paper 2.3, 3.1; the ``dqn`` extra)."""

from __future__ import annotations

import argparse
from typing import Any

from cml_edge.baselines import load_results
from cml_edge.baselines.dqn import evaluate_runs, train_runs
from cml_edge.baselines.settings import DEFAULT_STEPS, EVAL_EVERY, RESULTS_PATH, DQNRun
from cml_edge.cli.args import Progress, arena_size, command_line, nonneg_int, positive_int
from cml_edge.cli.output import labelled, num, pct, plural, secs, table
from cml_edge.engine.timings import stage
from cml_edge.io.files import writable_file, writable_folder
from cml_edge.protocol import EVAL_SEED, REWARDS


def add_parsers(subparsers) -> None:
    """``dqn train|evaluate``."""
    p = subparsers.add_parser("dqn", help="DQN baseline (needs the dqn extra): train, or "
                              "evaluate beside the CML on the same pairs")
    p.set_defaults(run=cmd_dqn, show=show_dqn)
    sub = p.add_subparsers(dest="dqn_command", required=True, parser_class=type(p))
    for name, help_text in (("train", "train DQN seeds (resumes: skips seeds already done)"),
                            ("evaluate", "evaluate trained seeds and the CML on the same "
                             "pairs; training-time-to-convergence ratio")):
        q = sub.add_parser(name, help=help_text)
        q.add_argument("--reward", choices=REWARDS, default="simplified",
                       help="Eq. 6 simplified (default) or Eq. 7 tailored")
        q.add_argument("--goal-conditioned", action="store_true",
                       help="inputs (x, y, goal x, goal y), a new goal every episode")
        q.add_argument("--seeds", type=positive_int, default=10,
                       help="seeds 0..N-1 (10)")
        q.add_argument("--steps", type=positive_int, default=None,
                       help="training steps per seed (default 100000 simplified, "
                            "200000 tailored)")
        q.add_argument("--arena", type=arena_size, default=30)
        q.add_argument("--trials", type=positive_int, default=100,
                       help="evaluation pairs per seed (100)")
        q.add_argument("--eval-seed", type=nonneg_int, default=EVAL_SEED,
                       help=f"evaluation seed: goals and pairs ({EVAL_SEED})")
        q.add_argument("--eval-every", type=positive_int, default=EVAL_EVERY,
                       help=f"training steps between curve points ({EVAL_EVERY})")
        q.add_argument("--results", default=str(RESULTS_PATH),
                       help=f"results file ({RESULTS_PATH})")
        q.add_argument("--json", action="store_true", help="print one JSON object on stdout")
        if name == "train":
            q.add_argument("--models", required=True, metavar="FOLDER",
                           help="folder for the trained models")
        else:
            q.add_argument("--no-cml", action="store_true",
                           help="skip training and evaluating the CML beside it")


def _run_from_args(args: argparse.Namespace) -> DQNRun:
    steps = args.steps if args.steps is not None else DEFAULT_STEPS[args.reward]
    return DQNRun(args.reward, args.goal_conditioned, steps, args.arena, args.trials,
                  args.eval_seed, args.eval_every)


def cmd_dqn(args: argparse.Namespace) -> dict[str, Any]:
    """``cml-edge dqn train|evaluate``: the JSON-ready result."""
    run = _run_from_args(args)
    writable_file(args.results, "--results")
    load_results(args.results)  # a bad results file fails now, before any training
    command = getattr(args, "command_line", None) or command_line()
    seeds = range(args.seeds)
    if args.dqn_command == "train":
        writable_folder(args.models, "--models")
        with stage("train"):
            return train_runs(run, seeds, args.results, args.models, command,
                              Progress(f"dqn train {run.name}"))
    with stage("evaluate"):
        return evaluate_runs(run, seeds, args.results, command, with_cml=not args.no_cml)


# what a person reads (--json: the result) ----------------------------------------
def _run_row(name: str, s: dict[str, Any], convergence: dict[str, Any] | None) -> list[str]:
    return [name, pct(s["success_rate"]), num(s["overhead_mean"]), num(s["e_pos_mean"]),
            secs(convergence["cpu_s"]) if convergence else ""]


def show_dqn(r: dict[str, Any]) -> None:
    """``dqn train`` and ``dqn evaluate``: the DQN beside the CML on the same pairs."""
    steps = r.get("steps", r.get("train_steps"))
    print(f"dqn {'train' if 'trained' in r else 'evaluate'}: {r['config']}, "
          f"{plural(r['seeds'], 'seed')}, {num(steps)} training steps")
    rows = [_run_row("DQN", r, r.get("convergence"))]
    for path, c in (r.get("cml") or {}).items():
        rows.append(_run_row(f"CML {path}", c, c.get("convergence")))
    print("\n".join("  " + line for line in table(rows, [
        "", "success", "overhead", "e_pos", "CPU s to converge"])))
    extra = [("parameters", num(r.get("parameters"))),
             ("inference FLOPs", num(r.get("inference_flops")))]
    if "trained" in r:
        extra += [("trained", ", ".join(map(str, r["trained"])) or "none"),
                  ("skipped (done before)", ", ".join(map(str, r["skipped"])) or None),
                  ("results", r["results_file"]), ("time", secs(r["wall_time_s"]))]
    for path, ratio in (r.get("convergence_ratio") or {}).items():
        extra.append((f"DQN / CML {path}", f"{num(ratio['cpu'])} x the CPU time, "
                                           f"{num(ratio['steps'])} x the steps to converge"))
    print("\n".join(labelled(extra)))
