"""The sweep engine: a grid of (configuration x seed) tasks, on a local pool or on Dask.

An experiment (:mod:`cml_edge.experiments`) lists its tasks; each :class:`Task` names a
top-level function by ``"module:function"`` and the JSON-able keyword arguments it is
called with, so a task is cheap to ship to another process or machine and runs the
same there. :func:`run_sweep`:

- writes each task's result to ``OUT/tasks/KEY.json`` atomically as soon as it
  finishes (:func:`cml_edge.io.files.atomic_write_text`), so an interrupted sweep
  loses only the tasks that were running;
- skips every task whose result file is already there and checks (a rerun resumes); a
  run folder records its settings first and refuses a run of other settings
  (:mod:`cml_edge.engine.runs`);
- runs the rest in-process (``workers=1``), in a local process pool (``workers`` > 1,
  default: one per core), or on a Dask distributed cluster when ``scheduler`` is an
  address (``tcp://host:8786``; the ``distributed`` extra, imported only then). The
  workers only compute; this process writes every file, so the workers need no
  shared file system;
- checks a scheduler address's form before any task (:func:`check_scheduler`); a
  scheduler lost mid-run ends with :class:`SchedulerLostError`, one line naming how many tasks
  finished and where they are kept (a rerun resumes from them);
- stops cleanly: on Ctrl-C or SIGTERM (:mod:`cml_edge.engine.stop`) the pool's workers
  are ended before the run stops, and a worker dies with its parent, even a SIGKILLed
  one, so no process is left behind;
- reports progress as ``progress(done, total)``;
- times its tasks (:mod:`cml_edge.engine.timings`): each task records its own stages
  where it runs (``timings`` in its document), and this process adds them to its stage
  ``tasks``.

Tasks are deterministic functions of their arguments (every random number comes from
a seed in them), so the pool, Dask and a rerun give the same numbers. ``wall_time_s``
and ``timings`` in a task's document are the only fields that vary.
"""

from __future__ import annotations

import contextlib
import importlib
import logging
import os
import re
import time
from collections.abc import Callable, Iterable
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from cml_edge.core.finite import dumps
from cml_edge.engine import timings
from cml_edge.engine.runs import checksum, open_run, plain
from cml_edge.engine.stop import end_pool, signals_held, worker_init
from cml_edge.engine.warmup import cores
from cml_edge.errors import InputError, RunError
from cml_edge.io.files import atomic_write_text, folder_path
from cml_edge.io.reading import MiB, read_text, strict_json

TASK_FORMAT = "cml-edge-sweep-task"
CONNECT_TIMEOUT = "10s"  # to reach a Dask scheduler
SCHEMES = ("tcp", "tls", "ws", "wss", "ucx", "inproc")
"""The Dask communication protocols an address may name (``tcp`` when it names none)."""
_HOST_PORT = re.compile(r"(?:[A-Za-z0-9](?:[A-Za-z0-9.-]*[A-Za-z0-9])?|\[[0-9A-Fa-f:.]+\])"
                        r":([0-9]{1,5})")


def check_scheduler(address: str) -> str:
    """``address`` if it has the form of a Dask scheduler's address: ``host:port`` or
    ``PROTOCOL://host:port`` (a protocol of :data:`SCHEMES`; ``inproc://NAME`` for one in
    this process); InputError naming the forms otherwise. Whether it answers is known
    only when connecting."""
    scheme, sep, rest = address.partition("://")
    if not sep:
        scheme, rest = "tcp", address
    ok = scheme in SCHEMES and (bool(rest) if scheme == "inproc" else bool(
        (m := _HOST_PORT.fullmatch(rest)) and 1 <= int(m.group(1)) <= 65535))
    if not ok:
        raise InputError(f"--scheduler {address!r} is not a Dask scheduler address (allowed: "
                         f"HOST:PORT or PROTOCOL://HOST:PORT, PROTOCOL one of "
                         f"{', '.join(SCHEMES[:-1])}; e.g. tcp://127.0.0.1:8786)")
    return address


class SchedulerLostError(RunError):
    """The Dask scheduler (or the connection to it) was lost before every task finished."""

    def __init__(self, scheduler: str, reason: str, done: int, total: int,
                 kept: Path | None) -> None:
        where = (f"they are kept in {str(kept)!r}: run the same command again to resume"
                 if kept is not None else "they were not kept (no output folder): give "
                 "--out to make a run resumable")
        super().__init__(f"lost the Dask scheduler {scheduler!r} ({reason}) with {done} of "
                         f"{total} tasks finished; {where}")


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
    """Import and call the task's function; returns (key, result document), the document
    with the task's own stages (``timings``: :meth:`~cml_edge.engine.timings.Timings.to_dict`,
    measured in the process that ran it)."""
    module, name = task.fn.split(":")
    fn = getattr(importlib.import_module(module), name)
    t0 = time.perf_counter()
    with timings.recording() as recorded:
        result = fn(**task.params)
    return task.key, {"format": TASK_FORMAT, "key": task.key, "fn": task.fn,
                      "params": task.params, "result": result,
                      "wall_time_s": time.perf_counter() - t0,
                      "timings": recorded.to_dict()}


def task_path(out: str | Path, key: str) -> Path:
    return Path(out) / "tasks" / f"{key}.json"


def load_done(out: str | Path, task: Task,
              settings: dict[str, Any] | None = None) -> dict[str, Any] | None:
    """The stored result of ``task`` if it is complete, for the same call and its checksum
    matches (:mod:`cml_edge.engine.runs`; ``settings``: the run's), else None."""
    path = task_path(out, task.key)
    if not path.exists() and not path.is_symlink():
        return None
    try:  # strict JSON: a NaN or an infinity is no result (it is computed again)
        doc = strict_json(read_text(path, "task file", TASK_BYTES))
    except ValueError as exc:
        if isinstance(exc, InputError):  # a special file, a loop, too large: refused
            raise
        return None
    if not isinstance(doc, dict) or doc.get("format") != TASK_FORMAT \
            or doc.get("fn") != task.fn or doc.get("params") != plain(task.params) \
            or not isinstance(doc.get("result"), dict) \
            or doc.get("checksum") != checksum(doc, plain(settings)):
        return None
    return doc


TASK_BYTES = 256 * MiB
"""The largest task file read: a scenario's task holds its models' curves and counters
(~100 kB; a chip run's ten seeds, a few MB)."""


def run_sweep(tasks: Iterable[Task], out: str | Path, workers: int | None = None,
              scheduler: str | None = None,
              progress: Callable[[int, int], None] | None = None,
              resumable: bool = True, settings: dict[str, Any] | None = None,
              restart: bool = False, pool: Workers | None = None,
              group: Callable[[Task], Any] | None = None) -> dict[str, dict[str, Any]]:
    """Run every task not yet done under ``out``; returns {key: result} for all tasks.
    ``resumable`` False: ``out`` is a temporary folder (what a lost scheduler's line says).
    With ``settings``, ``out`` is a run folder of those settings (``restart``: start it
    over; :func:`cml_edge.engine.runs.open_run`). ``pool``: the :class:`Workers` to run
    on, kept by the caller for several sweeps (``workers`` and ``scheduler`` are then
    its); ``group``: :meth:`Workers.run`'s."""
    tasks = list(tasks)
    keys = [t.key for t in tasks]
    if len(set(keys)) != len(keys):
        raise InputError("task keys are not unique")
    folder_path(Path(out) / "tasks", "the run folder's tasks")  # before any work
    for task in tasks:
        if task_path(out, task.key).is_dir():
            raise InputError(f"task file {str(task_path(out, task.key))!r} is a folder "
                             "(allowed: a file cml-edge writes)")
    own = pool is None
    workers_ = Workers(workers, scheduler) if pool is None else pool
    if settings is not None:
        open_run(out, settings, tasks, restart)
    settings = plain(settings)
    results: dict[str, dict[str, Any]] = {}
    todo = []
    for task in tasks:
        doc = load_done(out, task, settings)
        if doc is None:
            todo.append(task)
        else:
            results[task.key] = doc["result"]
    total = len(tasks)

    def finish(key: str, doc: dict[str, Any]) -> None:
        timings.merge(doc.get("timings"))
        doc["checksum"] = checksum(doc, settings)
        atomic_write_text(task_path(out, key), dumps(doc, indent=1))
        results[key] = doc["result"]
        if progress is not None:
            progress(len(results), total)

    if progress is not None:
        progress(len(results), total)
    if todo:
        with timings.stage("tasks"):  # where the tasks' own stages are added (finish)
            try:
                workers_.run(todo, finish, group)
            except _LostError as exc:
                kept = task_path(out, "x").parent if resumable else None
                raise SchedulerLostError(workers_.scheduler or "", str(exc), len(results),
                                         total, kept) from None
            finally:
                if own:
                    workers_.close()
    return {k: results[k] for k in keys}


class Workers:
    """Where tasks run, kept for as many sweeps as its ``with`` block lasts: this process
    (``workers=1``), a local process pool (``workers`` > 1, default one per core this
    process may run on, :func:`~cml_edge.engine.warmup.cores`; started
    by the first sweep that needs it, so its workers keep what they compiled or loaded
    from Numba's cache from one sweep to the next) or a Dask cluster (``scheduler``, an
    address; :func:`check_scheduler`). A block left by an exception (a stop request too)
    ends the pool's workers first."""

    def __init__(self, workers: int | None = None, scheduler: str | None = None) -> None:
        if scheduler is not None:
            check_scheduler(scheduler)
        if workers is not None and (isinstance(workers, bool) or workers < 1):
            raise InputError(f"workers {workers!r} is not an integer >= 1")
        self.n = workers or cores()
        self.scheduler = scheduler
        self._pool: ProcessPoolExecutor | None = None

    def __enter__(self) -> Workers:
        return self

    def __exit__(self, kind: Any, exc: Any, tb: Any) -> None:
        self.close(failed=kind is not None)

    def close(self, failed: bool = False) -> None:
        """Shut the local pool down (``failed``: end its workers now, :func:`end_pool`)."""
        if self._pool is not None:
            if failed:
                end_pool(self._pool)
            else:
                self._pool.shutdown()
            self._pool = None

    def run(self, todo: list[Task], finish: Callable[[str, dict[str, Any]], None],
            group: Callable[[Task], Any] | None = None) -> None:
        """Run ``todo``, calling ``finish(key, document)`` here as each task ends. A lone
        task runs in this process unless a pool is up already. ``group(task)``: which
        kernels a task compiles, as one group or a tuple of nested ones, coarse to fine
        (:class:`_Gates`: on a local pool a group's first task is queued at first and the
        rest of it once that one has ended); None (or no ``group``) queues a task at
        once."""
        if self.scheduler is not None:
            _run_dask(todo, self.scheduler, finish)
        elif self.n == 1 or (len(todo) == 1 and self._pool is None):
            for task in todo:
                finish(*run_task(task))
        else:
            try:
                self._run_pool(todo, finish, group)
            except BaseException:
                self.close(failed=True)
                raise

    def _run_pool(self, todo: list[Task], finish: Callable[[str, dict[str, Any]], None],
                  group: Callable[[Task], Any] | None) -> None:
        if self._pool is None:
            self._pool = ProcessPoolExecutor(max_workers=self.n, initializer=worker_init,
                                             initargs=(os.getpid(),))
        pool = self._pool
        futures: dict[Future, Task] = {}
        gates = _Gates(group)

        def submit(batch: list[Task]) -> None:
            with signals_held():  # the workers are forked here (module stop)
                for task in batch:
                    futures[pool.submit(run_task, task)] = task

        submit(gates.ready(todo))
        submit(gates.spare(self.n - len(futures)))
        while futures:
            done, _ = wait(futures, return_when=FIRST_COMPLETED)
            for fut in done:
                task = futures.pop(fut)
                finish(*fut.result())
                submit(gates.ended(task))
            submit(gates.spare(self.n - len(futures)))


class _Gates:
    """Which tasks may be queued, so that two workers do not compile the same kernels at
    once. ``group(task)`` names the kernels a task compiles as a path of groups, coarse to
    fine (the report's: the device and its number type, then the kind of run,
    :func:`cml_edge.report.batch.device_group`); a task compiles what each group of its
    path holds that the groups above do not. The first task of a group is queued (the
    first tasks of several groups spread over the workers, each compiling its own
    group's kernels); the other tasks of the group wait until it has ended, then pass on
    to the next group of their path (a robot run waits for the device's first task, then
    for the first robot run on that device). A worker never idles while tasks are held
    (:meth:`spare`): it takes a held task, even if that means compiling kernels another
    worker is compiling too."""

    def __init__(self, group: Callable[[Task], Any] | None) -> None:
        self.group = group
        self.started: set[tuple] = set()  # groups whose first task is queued
        self.open: set[tuple] = set()  # groups whose first task has ended
        self.held: dict[tuple, list[Task]] = {}  # group -> its tasks waiting
        self.firsts: dict[str, list[tuple]] = {}  # a task's key -> the groups it opens

    def _path(self, task: Task) -> tuple:
        g = None if self.group is None else self.group(task)
        return () if g is None else g if isinstance(g, tuple) else (g,)

    def ready(self, tasks: list[Task]) -> list[Task]:
        """Of ``tasks``, those to queue now; the rest are held."""
        now = []
        for task in tasks:
            path = self._path(task)
            shut = [path[:i] for i in range(1, len(path) + 1) if path[:i] not in self.open]
            if not shut:
                now.append(task)
            elif shut[0] in self.started:
                self.held.setdefault(shut[0], []).append(task)
            else:  # the first task of this group and of every group below it on its path
                self.started.update(shut)
                self.firsts[task.key] = shut
                now.append(task)
        return now

    def spare(self, idle: int) -> list[Task]:
        """Up to ``idle`` held tasks, for workers that would otherwise wait: the oldest
        group's first."""
        out: list[Task] = []
        for g in list(self.held):
            while self.held[g] and len(out) < idle:
                out.append(self.held[g].pop(0))
            if not self.held[g]:
                del self.held[g]
        return out

    def ended(self, task: Task) -> list[Task]:
        """The tasks to queue now that ``task`` has ended."""
        opened = self.firsts.pop(task.key, [])
        self.open.update(opened)
        return self.ready([t for g in opened for t in self.held.pop(g, [])])


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
    quiet = _quiet_dask()  # a lost scheduler is reported in one line, not Dask's log
    try:
        with client.as_current():
            futures = client.map(run_task, todo, pure=False)
            for fut in dask_completed(futures):
                try:
                    key, doc = fut.result()
                except Exception as exc:
                    if fut.status == "error":  # the task itself raised: a bug, shown as one
                        raise
                    raise _LostError(_lost_reason(exc)) from None
                finish(key, doc)
    finally:
        with contextlib.suppress(Exception):  # a client whose scheduler is gone: no matter
            client.close(timeout=2)
        for logger, level in quiet:
            logger.setLevel(level)


def _quiet_dask() -> list[tuple[logging.Logger, int]]:
    """Silence Dask's loggers; returns (logger, level) to restore."""
    names = ["distributed", *(n for n in logging.root.manager.loggerDict
                              if n.startswith("distributed."))]
    saved = [(logging.getLogger(n), logging.getLogger(n).level) for n in names]
    for logger, _ in saved:
        logger.setLevel(logging.CRITICAL + 1)
    return saved


class _LostError(Exception):
    """The scheduler went away while tasks were running."""


def _lost_reason(exc: Exception) -> str:
    reason = getattr(exc, "reason", None)  # a cancelled future's, e.g. scheduler-connection-lost
    return str(reason) if reason else f"{type(exc).__name__}: {exc}".splitlines()[0][:160]
