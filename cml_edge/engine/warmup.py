"""The first run's compiles spread over every core: the warm-up.

Numba compiles a function inside one process, and a compile nests the compiles of the
functions it calls; a run's kernels compiled one after another took a cold
``cml-edge emulate --backend crossbar`` a minute or more of one core
(benchmarks/README.md, "First run: compile time"). Its parts, though, compile apart: the
training loop on a device, the planning loop, the float64 twin. A command that would
compile therefore lists its parts as :class:`Unit` s first (each a tiny run of one part,
through the same code as the command, so it compiles the same functions for the same
types), and :func:`warm` runs the units the kernel cache lacks in a pool of one worker
process per core, heaviest first, while the command's process waits; each worker saves
what it compiles into the cache, and the command then loads everything from it. Two
workers never compile the same function and signature at once (the compile lock,
:mod:`cml_edge.jit.cache_lock`): the second waits and loads it.

A unit that ended writes a marker (``.warm/KEY`` in the cache folder): a later command
of the same parts starts no worker. A unit that fails is left to its command, which
meets the same error and reports it as it always does. With one core (``taskset``, a
one-core machine) there is nothing to spread and nothing is started: the command
compiles as it runs.
"""

from __future__ import annotations

import hashlib
import importlib
import json
import os
from collections.abc import Callable, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from dataclasses import dataclass, field
from typing import Any

from numba.core import config

from cml_edge.engine import timings
from cml_edge.engine.stop import end_pool, signals_held, worker_init
from cml_edge.io.files import atomic_write_text

STEPS = 20
"""The steps of the one walk a unit trains (:func:`tiny`)."""
_SET = {"seed": 0, "seeds": [0], "walks": 1, "epoch": 1}
_CAP = {"steps": STEPS, "trials": 2, "relearn_walks": 1}
TICK_S = 1.0
"""Seconds between two calls of :func:`warm`'s ``progress`` while the workers compile."""


@dataclass(frozen=True)
class Unit:
    """One part of a run to compile: ``task`` (``"module:function"``) called with the
    JSON-able ``kwargs``; ``what`` says it in words; ``weight``: its rough share of the
    compile seconds (the heaviest start first)."""

    what: str
    task: str
    kwargs: dict[str, Any] = field(default_factory=dict)
    weight: float = 1.0

    def key(self) -> str:
        """The unit's marker name: a hash of its task and arguments."""
        text = json.dumps([self.task, self.kwargs], sort_keys=True, default=str)
        return hashlib.sha256(text.encode()).hexdigest()[:24]


def tiny(params: Any) -> Any:
    """A task's JSON-able parameters made tiny, at every depth: model seed 0 (``seed``,
    ``seeds``), one walk (``walks``, and ``epoch``: a curve point per walk) of at most
    :data:`STEPS` steps, at most two pairs (``trials``) and one walk of relearning
    (``relearn_walks``, 0 kept). The numbers change; the functions a task runs, and the
    types they run on, do not."""
    if isinstance(params, dict):
        out = {}
        for k, v in params.items():
            if k in _SET and isinstance(v, (int, list, tuple)) and not isinstance(v, bool):
                out[k] = _SET[k]
            elif k in _CAP and isinstance(v, int) and not isinstance(v, bool):
                out[k] = min(v, _CAP[k])
            else:
                out[k] = tiny(v)
        return out
    if isinstance(params, (list, tuple)):
        return [tiny(v) for v in params]
    return params


def task_units(tasks: Sequence[Any]) -> list[Unit]:
    """One unit per sweep task (:class:`~cml_edge.engine.sweep.Task`): the task run
    :func:`tiny`; tasks whose tiny forms are equal share a unit. The devices take turns
    (each device's first unit, then each one's second...), so that every device's kernels
    start compiling early and none is left alone at the end."""
    units, turn, seen = [], [], {}
    for t in tasks:
        p = t.params.get("protocol", t.params)
        where = f"{p['world']} " if "world" in p else ""
        device = json.dumps([p.get("backend"), p.get("backend_options", p.get("options"))],
                            sort_keys=True, default=str)
        seen[device] = seen.get(device, 0) + 1
        turn.append(seen[device])
        units.append(Unit(f"{where}{t.fn.rsplit(':', 1)[1]} on {p.get('backend')}", t.fn,
                          tiny(t.params)))
    return [u for _, _, u in sorted(zip(turn, range(len(units)), units))]


def cores() -> int:
    """The cores this process may run on (``taskset`` respected)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not on Linux
        return os.cpu_count() or 1


def _marker(unit: Unit) -> str:
    return os.path.join(config.CACHE_DIR, ".warm", unit.key())


def pending(units: Sequence[Unit]) -> list[Unit]:
    """The units whose marker the cache lacks, each once, heaviest first."""
    seen: dict[str, Unit] = {}
    for u in units:
        if u.key() not in seen and not os.path.exists(_marker(u)):
            seen[u.key()] = u
    return sorted(seen.values(), key=lambda u: -u.weight)


def run_unit(unit: Unit) -> tuple[str, bool, dict[str, Any]]:
    """Run ``unit`` here (in a worker); write its marker if it ended. Returns (its key,
    whether it ended, its stages: :meth:`~cml_edge.engine.timings.Timings.to_dict`, with
    the seconds it compiled)."""
    module, name = unit.task.split(":")
    ok = True
    with timings.recording() as recorded:
        try:
            getattr(importlib.import_module(module), name)(**unit.kwargs)
        except Exception:  # noqa: BLE001 - its command meets the error (module docstring)
            ok = False
    if ok:
        atomic_write_text(_marker(unit), unit.what + "\n")
    return unit.key(), ok, recorded.to_dict()


def warm(units: Sequence[Unit], workers: int | None = None,
         progress: Callable[[int, int, str], None] | None = None) -> dict[str, Any]:
    """Compile the :func:`pending` ``units`` in a pool of ``workers`` processes (default:
    :func:`cores`), waiting for all; ``progress(done, total, what)`` after each. Nothing is
    started with one worker or nothing pending. Returns ``{"units": n, "workers": w,
    "ended": k, "cpu_s": ..., "compile_s": ...}`` (the workers' CPU and compile
    seconds), timed as the stage ``compile`` with the workers' own stages under it
    (``compile/train``...). ``progress`` is also called every :data:`TICK_S` while they work, with
    the units running then."""
    todo = pending(units)
    n = min(workers or cores(), len(todo))
    if n < 2:
        return {"units": len(todo), "workers": 0, "ended": 0, "cpu_s": 0.0, "compile_s": 0.0}
    tick = progress or (lambda done, total, what: None)
    ended, cpu, compiled = 0, 0.0, 0.0
    with timings.stage("compile"):
        tick(0, len(todo), ", ".join(u.what for u in todo[:n]))
        with signals_held():  # the workers are forked here (cml_edge.engine.stop)
            pool = ProcessPoolExecutor(max_workers=n, initializer=worker_init,
                                       initargs=(os.getpid(),))
        try:
            with signals_held():
                futures: dict[Future, Unit] = {pool.submit(run_unit, u): u for u in todo}
            left = set(futures)
            while left:  # (every TICK_S, so that a progress line's clock moves)
                done, left = wait(left, timeout=TICK_S, return_when=FIRST_COMPLETED)
                for fut in done:
                    _, ok, stages = fut.result()
                    timings.merge(stages)
                    ended += ok
                    cpu, compiled = cpu + stages["cpu_s"], compiled + stages["compile_s"]
                running = [futures[f].what for f in left if f.running()]
                tick(len(todo) - len(left), len(todo), ", ".join(running))
        except BaseException:  # a stop (SIGINT, SIGTERM) or a failure: end the workers now
            end_pool(pool)
            raise
        pool.shutdown()
    return {"units": len(todo), "workers": n, "ended": ended, "cpu_s": cpu,
            "compile_s": compiled}
