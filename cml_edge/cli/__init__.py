"""The ``cml-edge`` command: one module per command group, each adding its sub-commands.

- :mod:`~cml_edge.cli.grid`: ``train``, ``evaluate``, ``navigate``, ``emulate``;
- :mod:`~cml_edge.cli.robot`: ``robot train|evaluate|navigate``;
- :mod:`~cml_edge.cli.drone`: ``drone train|evaluate|navigate``;
- :mod:`~cml_edge.cli.dqn`: ``dqn train|evaluate``;
- :mod:`~cml_edge.cli.tools`: ``sweep``, ``report``, ``bench``;
- :mod:`~cml_edge.cli.scenario`: ``scenario``, ``breakpoint``;
- :mod:`~cml_edge.cli.device`: ``device characterize``;
- :mod:`~cml_edge.cli.export`: ``export`` (a loihi2 model's weights for Lava);
- :mod:`~cml_edge.cli.lava`: ``lava verify`` (a loihi2 model run in Lava itself);
- :mod:`~cml_edge.cli.args`: what they share (argument types, the progress bar, the
  synaptic-array options);
- :mod:`~cml_edge.cli.vehicle`: the robot's and the drone's ``train | evaluate |
  navigate`` parsers, built by one function;
- :mod:`~cml_edge.cli.vehicle_commands`: those commands and what a person reads of them,
  one implementation for both;
- :mod:`~cml_edge.cli.output`: what a person reads, each result as a short table;
- :mod:`~cml_edge.cli.compiling`: ``compile`` (a device's kernels ahead of any run), the
  warm-up that compiles a run's parts on every core first, and the line on stderr while
  Numba compiles on a cold cache.

Every command runs inside a recording of its stages (:mod:`cml_edge.engine.timings`): the
long ones (:data:`TIMED`) add it to their ``--json`` object as ``timings``, and
``--profile`` (before or after the command's name) prints its longest stages on stderr.

Bad input gets one line on stderr naming the value and what is allowed, exit status
2, no traceback, and nothing written; every output path is checked before any work.
Every count, size and seed option has a range (:data:`cml_edge.sizes.SIZES`), and
before any work a run's memory and time are estimated from its sizes
(:mod:`cml_edge.cli.limits`): a run that would not fit the machine's memory is refused,
a long one prints its estimate on stderr. A run stopped by its surroundings (a full disk,
a lost Dask scheduler) gets one line and exit status 1; so does a run whose device
produced NaN or infinity (:mod:`cml_edge.core.finite`: the line names the device, the
phase and the matrix or metric, and nothing is written). A run stopped by SIGINT or SIGTERM
ends its workers, drops any half-written file, says so in one line and exits with 128 + the
signal's number (:func:`run`). ``--json`` prints one JSON object
on stdout (strict JSON: :func:`~cml_edge.core.finite.dumps`) and nothing else there;
without it, the command's view of the result (:mod:`~cml_edge.cli.output`). Progress bars
go to stderr, only on a terminal.
"""

from __future__ import annotations

import argparse
import os
import sys

from cml_edge import __version__
from cml_edge.backends import plugins
from cml_edge.cli import (
    compiling,
    device,
    dqn,
    drone,
    export,
    grid,
    lava,
    limits,
    robot,
    scenario,
    tools,
)
from cml_edge.cli.args import distinct_outputs, hold_estimate, limit_options
from cml_edge.cli.compiling import announce_compiles
from cml_edge.cli.output import show_fields, show_profile
from cml_edge.core.finite import NonFiniteError, check_finite, dumps
from cml_edge.engine import timings
from cml_edge.engine.stop import interrupt_behind, raise_if_stopped, stop_on_signals, stop_signal
from cml_edge.errors import InputError, RunError

COMMAND_GROUPS = (grid, tools, compiling, scenario, robot, drone, dqn, device, export, lava)
TIMED = ("train", "evaluate", "emulate", "sweep", "report", "scenario", "breakpoint", "robot",
         "drone", "dqn", "compile")
"""The commands whose ``--json`` object carries ``timings``."""
PROFILE_HELP = "after the command, print its longest stages (wall, CPU and compile time) " \
               "on stderr"


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # one line, exit 2, as for every bad input
        raise InputError(message)


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="cml-edge", description="Cognitive Map Learner navigation on "
                     "emulated neuromorphic synaptic arrays.")
    parser.add_argument("--version", action="version", version=f"cml-edge {__version__}")
    parser.add_argument("--plugin", action="append", default=[], metavar="FILE_OR_MODULE",
                        help="load the devices of a plugin (a .py file or a module name; "
                        f"repeatable; also {plugins.ENV} and the entry points "
                        f"{plugins.GROUP}): docs/your-device.md")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    for group in COMMAND_GROUPS:
        group.add_parsers(sub)
    limit_options(parser)
    parser.add_argument("--profile", action="store_true", help=PROFILE_HELP)
    _profile_option(sub)
    return parser


def _profile_option(sub: argparse._SubParsersAction) -> None:
    """``--profile`` after a command's name too (set only when given, so that it does not
    hide the one given before)."""
    for p in sub.choices.values():
        p.add_argument("--profile", action="store_true", default=argparse.SUPPRESS,
                       help=PROFILE_HELP)
        for action in p._actions:
            if isinstance(action, argparse._SubParsersAction):
                _profile_option(action)


COMMANDS = {"train", "evaluate", "navigate", "emulate", "robot", "drone", "dqn", "sweep", "report",
            "bench", "compile", "scenario", "breakpoint", "device", "export", "lava"}
"""The command names (where ``--plugin`` options end)."""


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else [str(a) for a in argv]
    hold_estimate(None)
    try:
        with stop_on_signals():
            for line in plugins.load_given(plugins.given(argv, COMMANDS)):
                print(f"cml-edge: warning: {line}", file=sys.stderr)
            parser = build_parser()
            args = parser.parse_args(argv)
            distinct_outputs(args)
            hold_estimate(limits.check(args))  # refuses what will not fit; said at the start
            with announce_compiles(args), timings.recording() as recorded:
                result = args.run(args)
            raise_if_stopped()  # a stop that a finalizer swallowed is still a stop
            times = recorded.to_dict()
            text = None
            if getattr(args, "json", False):
                if args.command in TIMED and isinstance(result, dict):
                    result = {**result, "timings": times}
                text = dumps(result)
            check_finite(result)
            if text is not None:  # inside: a stop while printing is a stop, not a kill
                print(text)
            else:
                getattr(args, "show", show_fields)(result)
            if args.profile:
                show_profile(times, sys.stderr)
    except InputError as exc:  # bad input only: any other exception is a bug, not hidden
        print(f"cml-edge: error: {exc}", file=sys.stderr)
        return 2
    except (RunError, NonFiniteError) as exc:  # a full disk, a lost scheduler, a device
        print(f"cml-edge: error: {exc}", file=sys.stderr)  # that produced NaN: one line
        return 1
    except (KeyboardInterrupt, Exception) as exc:  # Ctrl-C or SIGTERM: workers ended, no
        stop = interrupt_behind(exc)  # half file; any other exception is a bug, not hidden
        if stop is None:
            raise
        sig = stop_signal(stop)
        print(f"cml-edge: stopped by {sig.name}; nothing was half-written", file=sys.stderr)
        return 128 + sig
    finally:
        hold_estimate(None)
    return 0


def run() -> None:
    """The ``cml-edge`` program: :func:`main`, then exit with its status. A stopped command
    (status 128 + a signal's number: its workers ended, its files whole) exits at once,
    without the interpreter's finalization: that finalization aborted a stopped ``sweep``
    with SIGABRT ("Fatal Python error: PyThreadState_Get", CPython 3.11) in two of three
    full CI runs, with no Python thread left but the main one."""
    code = main()
    if code > 128:
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(code)
    sys.exit(code)
