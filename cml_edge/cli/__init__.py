"""The ``cml-edge`` command: one module per command group, each adding its sub-commands.

- :mod:`~cml_edge.cli.grid`: ``train``, ``evaluate``, ``navigate``, ``emulate``;
- :mod:`~cml_edge.cli.robot`: ``robot train|evaluate|navigate``;
- :mod:`~cml_edge.cli.dqn`: ``dqn train|evaluate``;
- :mod:`~cml_edge.cli.tools`: ``sweep``, ``report``, ``bench``;
- :mod:`~cml_edge.cli.scenario`: ``scenario``, ``breakpoint``;
- :mod:`~cml_edge.cli.device`: ``device characterize``;
- :mod:`~cml_edge.cli.export`: ``export`` (a loihi2 model's weights for Lava);
- :mod:`~cml_edge.cli.args`: what they share (argument types, the progress bar, the
  synaptic-array options).

Bad input gets one line on stderr naming the value and what is allowed, exit status
2, no traceback, and nothing written. ``--json`` prints one JSON object on stdout and
nothing else there; progress goes to stderr, only on a terminal.
"""

from __future__ import annotations

import argparse
import json
import sys
from typing import Any

from cml_edge import __version__
from cml_edge.cli import device, dqn, export, grid, robot, scenario, tools
from cml_edge.errors import InputError

COMMAND_GROUPS = (grid, tools, scenario, robot, dqn, device, export)


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # one line, exit 2, as for every bad input
        raise InputError(message)


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="cml-edge", description="Cognitive Map Learner navigation on "
                     "emulated neuromorphic synaptic arrays.")
    parser.add_argument("--version", action="version", version=f"cml-edge {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    for group in COMMAND_GROUPS:
        group.add_parsers(sub)
    return parser


def _print_human(command: str, result: dict[str, Any]) -> None:
    # "path" is the older name of "compute_path" (and of navigate's "trajectory")
    skip = {"per_seed", "curve_e_pos_mean", "train_error", "path", "seed_list", "counters"}
    if command == "navigate":
        skip = {"path"}
    for k, v in result.items():
        if k in skip or isinstance(v, dict):
            continue
        if isinstance(v, float):
            v = f"{v:.4f}"
        print(f"{k:>24}: {v}")
    for group in ("counters", "backends", "ratios"):
        if isinstance(result.get(group), dict):
            print(f"{group}:")
            for k, v in result[group].items():
                print(f"{k:>24}: {v}")
    chips = result.get("chips")
    if isinstance(chips, dict):  # emulate --chips: the distribution over chips
        print(f"chips: {chips['n']} (mean, std, min, p05, median, p95, max)")
        for k, stats in chips["distribution"].items():
            print(f"{k:>24}: " + " ".join(f"{v:.4g}" for v in stats.values()))


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
        result = args.run(args)
    except InputError as exc:  # bad input only: any other exception is a bug, not hidden
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
