"""The report's tasks, stage by stage, on one set of workers.

A :class:`Batch` keeps one :class:`~cml_edge.engine.sweep.Workers` for the whole report, so
its worker processes compile or load each kernel once, not once per scenario; each stage
(:meth:`Batch.run`) is a sweep (:func:`~cml_edge.engine.sweep.run_sweep`) of the stage's
tasks into the report's run folder, each task's result kept there as it ends, so a report
run again into the same folder resumes from every task that had ended. Tasks are grouped
by device, then by run (:func:`device_group`): on a local pool each device's first task
runs first, spread over the workers, and the rest of its tasks once its kernels are
compiled; of those, each kind of run's first, then the rest of that kind.
"""

from __future__ import annotations

import json
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

from cml_edge.backends import backend_spec
from cml_edge.engine import timings
from cml_edge.engine.sweep import Task, Workers, run_sweep

_NUMBER_TYPE = ("dtype", "bits")
"""The backend options that choose a device's number type (float's dtype, fixed point's
bits; two bit widths stored in one integer type are two groups on the same kernels, which
only lets their first tasks compile them side by side)."""

_NOT_KERNELS = ("seed", "backend", "backend_options", "options")
"""Task parameters that choose no kernel (the device's are in the first group)."""


def _run_kind(params: dict[str, Any]) -> dict[str, Any]:
    return {k: _run_kind(v) if isinstance(v, dict) else v for k, v in params.items()
            if k not in _NOT_KERNELS}


def device_group(task: Task) -> tuple[tuple[str, Any], str]:
    """The kernels a task compiles (:meth:`~cml_edge.engine.sweep.Workers.run`'s group):
    those of the device it runs on and its number type (Numba compiles a kernel for each:
    int8 and int16 have their own fixed-point kernels, float32 and float64 their own;
    the presets of a crossbar share the crossbar's), then those of the kind of run
    (world, schedule, planner, arena: its parameters but the seed and the device's), so
    two seeds of a robot run, or two presets' robot runs, do not compile the robot's
    loops at once."""
    spec = backend_spec(task.params.get("protocol", task.params)["backend"])
    return ((spec.device.name, tuple(spec.options.get(k) for k in _NUMBER_TYPE)),
            json.dumps(_run_kind(task.params), sort_keys=True, default=str))


class Batch:
    """Run the report's stages on ``workers`` processes (or the Dask ``scheduler``) into
    run folder ``folder`` (None: a temporary one), a run of ``settings``
    (:mod:`cml_edge.engine.runs`: a folder of other settings is refused unless
    ``restart``). ``progress(stage, done, total)`` counts each stage's tasks."""

    def __init__(self, workers: int | None = None, scheduler: str | None = None,
                 folder: str | Path | None = None, settings: dict[str, Any] | None = None,
                 progress: Callable[[str, int, int], None] | None = None,
                 restart: bool = False) -> None:
        self.pool = Workers(workers, scheduler)
        self._tmp = tempfile.TemporaryDirectory(prefix="cml-edge-report-") \
            if folder is None else None
        self.folder = Path(self._tmp.name if self._tmp is not None else folder)
        self.settings = settings or {"run": "report"}
        self.progress = progress
        self.restart = restart

    def __enter__(self) -> Batch:
        return self

    def __exit__(self, kind: Any, exc: Any, tb: Any) -> None:
        self.pool.close(failed=kind is not None)
        if self._tmp is not None:
            self._tmp.cleanup()

    def run(self, stage: str, tasks: list[Task], part: str | None = None
            ) -> dict[str, dict[str, Any]]:
        """The results of ``tasks`` by key, as stage ``stage`` (its timings); ``part``: which
        of the stage's batches this is, for the progress (each round of the break points'
        bisection is a batch whose size is known only when it starts)."""
        label = stage if part is None else f"{stage}, {part}"
        tick = None if self.progress is None else \
            (lambda done, total: self.progress(label, done, total))
        with timings.stage(stage):
            results = run_sweep(tasks, self.folder, progress=tick, settings=self.settings,
                                restart=self.restart, pool=self.pool, group=device_group,
                                resumable=self._tmp is None)
        self.restart = False  # the run folder is started over once, by the first stage
        return results
