"""What every ``cml-edge`` command shares: argument types, the bad-input error, the
progress bar, and the synaptic-array options.

An argument type raises ``argparse.ArgumentTypeError`` naming the value and what is
allowed; the parser turns that into one line on stderr and exit status 2.
"""

from __future__ import annotations

import argparse
import math
import sys
from typing import Any

from tqdm import tqdm

from cml_edge.backends import BACKENDS, backend_spec
from cml_edge.errors import InputError


def int_at_least(lo: int, what: str):
    """An argparse type: an integer ``>= lo``; ``what`` says so in the error."""
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not an integer {what}") from None
        if value < lo:
            raise argparse.ArgumentTypeError(f"{text!r} is not an integer {what}")
        return value

    return parse


positive_int = int_at_least(1, ">= 1")
nonneg_int = int_at_least(0, ">= 0")
arena_size = int_at_least(2, ">= 2 (the arena side)")


def finite_float(text: str) -> float:
    """An argparse type: a finite number."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"{text!r} is not a finite number")
    return value


def positive_float(text: str) -> float:
    """An argparse type: a finite number > 0."""
    value = finite_float(text)
    if value <= 0:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number > 0")
    return value


class Progress:
    """A progress callback ``(done, total)``: a tqdm bar on stderr, drawn only when stderr
    is a terminal."""

    def __init__(self, label: str) -> None:
        self.label = label
        self.bar: tqdm | None = None

    def __call__(self, done: int, total: int) -> None:
        if self.bar is None:
            self.bar = tqdm(total=total, desc=self.label, file=sys.stderr, leave=True,
                            disable=not sys.stderr.isatty())
        self.bar.update(done - self.bar.n)
        if done >= total:
            self.bar.close()


def command_line() -> str:
    """The command as typed, for the provenance of a result."""
    return "cml-edge " + " ".join(sys.argv[1:])


# the synaptic-array options -------------------------------------------------------------
# the option names each array class adds, to refuse one given to another backend
_BACKEND_OPTIONS: dict[type, list[str]] = {}


def add_backend(p: argparse.ArgumentParser) -> None:
    """``--backend NAME`` and every array class's own options, in one group each."""
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


def backend_options(args: argparse.Namespace) -> dict[str, Any]:
    """The options of ``--backend``'s array class; refuses another class's options."""
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
