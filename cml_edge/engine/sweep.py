"""The sweep engine: a grid of (configuration x seed) tasks, on a local pool or on Dask.

An experiment (:mod:`cml_edge.experiments`) lists its tasks; each :class:`Task` names a
top-level function by ``"module:function"`` and the JSON-able keyword arguments it is
called with, so a task is cheap to ship to another process or machine and runs the
same there. :func:`run_sweep`:

- writes each task's result to ``OUT/tasks/KEY.json`` atomically as soon as it
  finishes (:func:`cml_edge.io.files.atomic_write_text`), so an interrupted sweep
  loses only the tasks that were running;
- skips every task whose result file is already there (a rerun resumes);
- runs the rest in-process (``workers=1``), in a local process pool (``workers`` > 1,
  default: one per core), or on a Dask distributed cluster when ``scheduler`` is an
  address (``tcp://host:8786``; the ``distributed`` extra, imported only then). The
  workers only compute; this process writes every file, so the workers need no
  shared file system;
- reports progress as ``progress(done, total)``.

Tasks are deterministic functions of their arguments (every random number comes from
a seed in them), so the pool, Dask and a rerun give the same numbers. ``wall_time_s``
in a result is the only field that varies.
"""

from __future__ import annotations

import importlib
import json
import os
import time
from collections.abc import Callable, Iterable
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from cml_edge.core.finite import dumps
from cml_edge.errors import InputError
from cml_edge.io.files import atomic_write_text

TASK_FORMAT = "cml-edge-sweep-task"
CONNECT_TIMEOUT = "10s"  # to reach a Dask scheduler


@dataclass(frozen=True)
class Task:
    """One unit of a sweep: ``fn(**params)`` identified by ``key`` (a file-safe name)."""

    key: str
    fn: str
    params: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if not self.key or any(c in self.key for c in "/\\\0") or self.key.startswith("."):
            raise InputError(f"task key {self.key!r} is not a file-safe name")
        if ":" not in self.fn:
            raise InputError(f"task function {self.fn!r} is not 'module:function'")


def run_task(task: Task) -> tuple[str, dict[str, Any]]:
    """Import and call the task's function; returns (key, result document)."""
    module, name = task.fn.split(":")
    fn = getattr(importlib.import_module(module), name)
    t0 = time.perf_counter()
    result = fn(**task.params)
    return task.key, {"format": TASK_FORMAT, "key": task.key, "fn": task.fn,
                      "params": task.params, "result": result,
                      "wall_time_s": time.perf_counter() - t0}


def task_path(out: str | Path, key: str) -> Path:
    return Path(out) / "tasks" / f"{key}.json"


def load_done(out: str | Path, task: Task) -> dict[str, Any] | None:
    """The stored result of ``task`` if it is complete and for the same call, else None."""
    path = task_path(out, task.key)
    try:
        doc = json.loads(path.read_text())
    except (OSError, ValueError):
        return None
    if doc.get("format") != TASK_FORMAT or doc.get("fn") != task.fn \
            or doc.get("params") != json.loads(json.dumps(task.params)):
        return None
    return doc


def run_sweep(tasks: Iterable[Task], out: str | Path, workers: int | None = None,
              scheduler: str | None = None,
              progress: Callable[[int, int], None] | None = None) -> dict[str, dict[str, Any]]:
    """Run every task not yet done under ``out``; returns {key: result} for all tasks."""
    tasks = list(tasks)
    keys = [t.key for t in tasks]
    if len(set(keys)) != len(keys):
        raise InputError("task keys are not unique")
    if workers is not None and workers < 1:
        raise InputError(f"workers {workers!r} is not an integer >= 1")
    results: dict[str, dict[str, Any]] = {}
    todo = []
    for task in tasks:
        doc = load_done(out, task)
        if doc is None:
            todo.append(task)
        else:
            results[task.key] = doc["result"]
    total = len(tasks)

    def finish(key: str, doc: dict[str, Any]) -> None:
        atomic_write_text(task_path(out, key), dumps(doc, indent=1))
        results[key] = doc["result"]
        if progress is not None:
            progress(len(results), total)

    if progress is not None:
        progress(len(results), total)
    if todo:
        if scheduler:
            _run_dask(todo, scheduler, finish)
        else:
            n = workers or os.cpu_count() or 1
            if n == 1 or len(todo) == 1:
                for task in todo:
                    finish(*run_task(task))
            else:
                with ProcessPoolExecutor(max_workers=min(n, len(todo))) as pool:
                    futures = [pool.submit(run_task, task) for task in todo]
                    try:
                        for fut in as_completed(futures):
                            finish(*fut.result())
                    except BaseException:
                        for fut in futures:
                            fut.cancel()
                        raise
    return {k: results[k] for k in keys}


def _run_dask(todo: list[Task], scheduler: str, finish: Callable[[str, dict], None]) -> None:
    try:
        from distributed import Client
        from distributed import as_completed as dask_completed
    except ImportError:
        raise InputError("--scheduler needs Dask: pip install 'cml-edge[distributed]'") from None
    try:
        client = Client(scheduler, timeout=CONNECT_TIMEOUT, set_as_default=False)
    except (OSError, TimeoutError) as exc:
        raise InputError(f"cannot reach the Dask scheduler {scheduler!r} ({exc})") from None
    try:
        with client.as_current():
            futures = client.map(run_task, todo, pure=False)
            for fut in dask_completed(futures):
                finish(*fut.result())
    finally:
        client.close()
