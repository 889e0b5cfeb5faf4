"""One line on stderr when a command starts compiling kernels: a cold cache.

Every kernel and loop of cml_edge is compiled by Numba with ``cache=True``
(:mod:`cml_edge.jit.kernel`) into the cache folder that :func:`cml_edge._numba_cache_dir`
keys by a hash of the package's sources. Numba compiles a function only when that cache
holds no entry for it (a first run after installing or changing cml_edge, or the first
run of a device or a compute path), and then broadcasts the event ``numba:compile``;
loading from the cache broadcasts nothing. :func:`announce_compiles` listens for that
event while a command runs: at the first compile of a cml_edge function it prints one
line saying what is being compiled and roughly how long it takes. On a warm cache nothing
compiles and nothing is printed.
"""

from __future__ import annotations

import argparse
import multiprocessing
import sys
from collections.abc import Iterator
from contextlib import contextmanager

from numba.core import event
from tqdm import tqdm

from cml_edge.cli.args import say_estimate
from cml_edge.jit import notice

COLD_MINUTES = "1-3"
"""Rough minutes a command's kernels take to compile on a cold cache: ``emulate`` on the
crossbar (its kernels, the training and planning loops, the float64 twin and the
replay) took about 75 s on an idle two-core machine when it also compiled the update
its schedule does not run; without it, a fifth less: 2.3 min of CPU time instead of 2.9
on two cores under a load of 3-5 (benchmarks/README.md, "First run: compile time").
``bench`` compiles every backend's: :data:`BENCH_MINUTES`."""
BENCH_MINUTES = "5-10"


def what_compiles(args: argparse.Namespace) -> tuple[str, str]:
    """(what the command of ``args`` compiles, in words; the minutes it takes)."""
    backend = getattr(args, "backend", None)
    if args.command in ("bench", "report"):
        return "every backend's kernels and loops", BENCH_MINUTES
    if args.command == "device":
        return f"the {backend} kernels", COLD_MINUTES
    robot = args.command == "robot" or getattr(args, "name", None) == "robot"  # a scenario
    world = "robot" if robot else "grid"
    device = f"the {backend} kernels and " if backend else "the "
    return f"{device}{world} loops", COLD_MINUTES


class _Notice(event.Listener):
    """Prints the line at the first compile of a cml_edge function, and nothing after; in
    the command's process or in any worker process forked from it (the flag is in shared
    memory), so a pool of workers says it once."""

    def __init__(self, what: str, minutes: str) -> None:
        self.what, self.minutes = what, minutes
        self.said = multiprocessing.Value("b", 0)

    def on_start(self, ev: event.Event) -> None:
        if self.said.value:
            return
        func = getattr(ev.data["dispatcher"], "py_func", None)
        if not getattr(func, "__module__", "").startswith(notice.OURS):
            return
        with self.said.get_lock():
            if self.said.value:
                return
            self.said.value = 1
        say_estimate()
        tqdm.write(f"cml-edge: first run: compiling {self.what} ({self.minutes} min once, "
                   "then cached)", file=sys.stderr)

    def on_end(self, ev: event.Event) -> None:
        pass


@contextmanager
def announce_compiles(args: argparse.Namespace) -> Iterator[None]:
    """While the command of ``args`` runs, print the line of the module docstring at the
    first compile of a cml_edge function."""
    with event.install_listener("numba:compile", _Notice(*what_compiles(args))):
        yield
