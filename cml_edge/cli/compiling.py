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

Before a command's work, :func:`warm_up` compiles the parts it lists on every core
(:mod:`cml_edge.engine.warmup`; the grid protocol's parts: :func:`protocol_units`), with
a moving progress line on a terminal. ``cml-edge compile`` runs the same warm-up for the
devices a user names, ahead of any run.
"""

from __future__ import annotations

import argparse
import multiprocessing
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import replace

from numba.core import event
from tqdm import tqdm

from cml_edge.backends import configurations
from cml_edge.cli.args import say_estimate
from cml_edge.core.learning import SCHEDULES
from cml_edge.engine.warmup import Unit, cores, tiny, warm
from cml_edge.grid.paths import default_path
from cml_edge.grid.protocol import Protocol
from cml_edge.grid.training import TrainConfig
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
    if args.command == "compile":
        return "the named devices' kernels and grid loops", BENCH_MINUTES
    robot = args.command == "robot" or getattr(args, "name", None) == "robot"  # a scenario
    world = "drone" if args.command == "drone" else "robot" if robot else "grid"
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
        if not (getattr(func, "__module__", None) or "").startswith(notice.OURS):
            return
        with self.said.get_lock():
            if self.said.value:
                return
            self.said.value = 1
        say_estimate()
        tqdm.write(f"cml-edge: first run: compiling {self.what} on {cores()} "
                   f"core{'s' * (cores() > 1)} ({self.minutes} min once, then cached)",
                   file=sys.stderr)

    def on_end(self, ev: event.Event) -> None:
        pass


@contextmanager
def announce_compiles(args: argparse.Namespace) -> Iterator[None]:
    """While the command of ``args`` runs, print the line of the module docstring at the
    first compile of a cml_edge function."""
    with event.install_listener("numba:compile", _Notice(*what_compiles(args))):
        yield


def protocol_units(protocol: Protocol) -> list[Unit]:
    """The parts of a grid protocol's run that compile apart (:mod:`cml_edge.grid.warmup`):
    its device's training, then its evaluation; the training is the heavier. Each is
    given the protocol made tiny (:func:`~cml_edge.engine.warmup.tiny`), so runs of other
    sizes share their markers."""
    d, on = tiny(protocol.to_dict()), protocol.backend
    return [Unit(f"training on {on}", "cml_edge.grid.warmup:training_part", {"protocol": d},
                 2.0),
            Unit(f"evaluation on {on}", "cml_edge.grid.warmup:evaluation_part",
                 {"protocol": d}, 1.0)]


class _Line:
    """The warm-up's moving line on stderr (a terminal only): units done, the cores, the
    seconds so far and what is compiling."""

    def __init__(self) -> None:
        self.bar: tqdm | None = None

    def __call__(self, done: int, total: int, running: str) -> None:
        if self.bar is None:
            self.bar = tqdm(total=total, desc=f"compiling on {cores()} cores", unit="part",
                            file=sys.stderr, disable=not sys.stderr.isatty(), leave=False,
                            bar_format="{desc}: {n}/{total} parts, {elapsed} {postfix}")
        self.bar.set_postfix_str(running, refresh=False)
        self.bar.update(done - self.bar.n)
        self.bar.refresh()
        if done >= total:
            self.bar.close()


def warm_up(units: list[Unit], workers: int | None = None) -> dict:
    """Compile ``units`` on every core before the command's work (:func:`warm`)."""
    return warm(units, workers, _Line())


def add_parsers(sub) -> None:
    p = sub.add_parser("compile", help="compile the kernels of the named devices ahead of "
                       "any run, on every core")
    p.add_argument("--backends", nargs="+", default=None, metavar="BACKEND",
                   help="the devices (default: every registered backend); BACKEND:PRESET "
                        "names a preset's configuration (crossbar:pcm)")
    p.add_argument("--schedules", nargs="+", choices=SCHEDULES, default=["walk"],
                   help="the update schedules to compile for (walk)")
    p.add_argument("--workers", type=int, default=None,
                   help="worker processes (default: one per core this process may use)")
    p.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    p.set_defaults(run=cmd_compile)


def compile_units(configs: list[tuple[str, str, dict]], schedules: list[str]) -> list[Unit]:
    """The units of ``emulate``'s protocol, and of ``train`` and ``evaluate`` where their
    compute path differs (the float64 shortcut), for each configuration (label, backend,
    options) and schedule."""
    units = []
    for _, backend, options in configs:
        for schedule in schedules:
            p = Protocol(backend=backend, backend_options=options,
                         train=TrainConfig(schedule=schedule))
            paths = {default_path(backend, schedule, options, counted=counted)
                     for counted in (True, False)}
            units += [u for path in sorted(paths) for u in protocol_units(replace(p, path=path))]
    return units


def cmd_compile(args: argparse.Namespace) -> dict:
    configs = configurations(args.backends, presets=False)
    units = compile_units(configs, args.schedules)
    t0 = time.perf_counter()
    done = warm_up(units, args.workers)
    return {"backends": [label for label, _, _ in configs],
            "schedules": args.schedules, "parts": len(units), "compiled": done["units"],
            "workers": done["workers"], "ended": done["ended"],
            "workers_cpu_s": done["cpu_s"], "workers_compile_s": done["compile_s"],
            "wall_time_s": time.perf_counter() - t0}
