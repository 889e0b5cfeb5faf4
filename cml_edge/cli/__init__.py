"""The ``cml-edge`` command: one module per command group, each adding its sub-commands.

- :mod:`~cml_edge.cli.grid`: ``train``, ``evaluate``, ``navigate``, ``emulate``;
- :mod:`~cml_edge.cli.robot`: ``robot train|evaluate|navigate``;
- :mod:`~cml_edge.cli.dqn`: ``dqn train|evaluate``;
- :mod:`~cml_edge.cli.tools`: ``sweep``, ``report``, ``bench``;
- :mod:`~cml_edge.cli.scenario`: ``scenario``, ``breakpoint``;
- :mod:`~cml_edge.cli.device`: ``device characterize``;
- :mod:`~cml_edge.cli.export`: ``export`` (a loihi2 model's weights for Lava);
- :mod:`~cml_edge.cli.args`: what they share (argument types, the progress bar, the
  synaptic-array options);
- :mod:`~cml_edge.cli.output`: what a person reads, each result as a short table;
- :mod:`~cml_edge.cli.compiling`: the line on stderr while Numba compiles on a cold cache.

Bad input gets one line on stderr naming the value and what is allowed, exit status
2, no traceback, and nothing written. A run whose device produced NaN or infinity
(:mod:`cml_edge.core.finite`) fails with one line naming the device, the phase and the
matrix or metric, exit status 1, and nothing written. ``--json`` prints one JSON object
on stdout (strict JSON: :func:`~cml_edge.core.finite.dumps`) and nothing else there;
without it, the command's view of the result (:mod:`~cml_edge.cli.output`). Progress bars
go to stderr, only on a terminal.
"""

from __future__ import annotations

import argparse
import sys

from cml_edge import __version__
from cml_edge.cli import device, dqn, export, grid, robot, scenario, tools
from cml_edge.cli.compiling import announce_compiles
from cml_edge.cli.output import show_fields
from cml_edge.core.finite import NonFiniteError, check_finite, dumps
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


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
        with announce_compiles(args):
            result = args.run(args)
        text = dumps(result) if getattr(args, "json", False) else None
        check_finite(result)
    except InputError as exc:  # bad input only: any other exception is a bug, not hidden
        print(f"cml-edge: error: {exc}", file=sys.stderr)
        return 2
    except NonFiniteError as exc:  # the run failed: its device produced NaN or infinity
        print(f"cml-edge: error: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("cml-edge: interrupted", file=sys.stderr)
        return 130
    if text is not None:
        print(text)
    else:
        getattr(args, "show", show_fields)(result)
    return 0
