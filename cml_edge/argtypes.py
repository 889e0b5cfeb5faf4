"""Command-line argument types and the progress bar, shared by every ``cml-edge`` command.

An argument type raises ``argparse.ArgumentTypeError`` naming the value and what is
allowed; the parser turns that into one line on stderr and exit status 2.
"""

from __future__ import annotations

import argparse
import math
import sys
import time


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
    """A one-line progress bar on stderr, drawn only when stderr is a terminal."""

    def __init__(self, label: str) -> None:
        self.label = label
        self.on = sys.stderr.isatty()
        self.t0 = time.perf_counter()

    def __call__(self, done: int, total: int) -> None:
        if not self.on:
            return
        width = 30
        filled = int(width * done / max(total, 1))
        elapsed = time.perf_counter() - self.t0
        sys.stderr.write(f"\r{self.label} [{'#' * filled}{'.' * (width - filled)}] "
                         f"{done}/{total} {elapsed:5.1f}s")
        if done >= total:
            sys.stderr.write("\n")
        sys.stderr.flush()
