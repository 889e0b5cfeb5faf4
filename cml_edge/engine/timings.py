"""Where a command's time goes: wall, CPU and Numba compile seconds per named stage.

:func:`recording` makes a :class:`Timings` the current recorder of this process and
:func:`stage` times a block of work into it (``with stage("train"): ...``; nothing is
recorded when no recorder is current, so library code names its stages freely). Per
stage:

- ``wall_s``: :func:`time.perf_counter` seconds;
- ``cpu_s``: CPU seconds of this process (:func:`time.process_time`) and of its child
  processes that finished meanwhile (:func:`os.times`: a process pool's workers count
  once they have exited);
- ``compile_s``: the seconds Numba spent compiling, measured on its ``numba:compile``
  event (``numba.core.event``'s timer, outermost compiles only, the event
  :mod:`cml_edge.cli.compiling` listens to) in compiles that ended inside the stage. The
  stage's run time is ``wall_s - compile_s``. Loading a kernel from Numba's cache is no
  compile: it counts as run time;
- ``calls``: how many times it was entered; a stage entered again accumulates.

Stages nest: a stage opened inside another is named ``"outer/inner"``; a stage opened
directly inside a stage of the same name is that stage (a library function and its caller
may both name their work ``train``). The stages at the top level do not overlap, so their
walls sum to at most the total.

Work done in other processes comes back as data: a sweep task records its own timings
(:func:`cml_edge.engine.sweep.run_task`) and the process that collects it adds them with
:func:`merge` under the stage open there (``tasks/train``...), in whichever process the
task ran. Tasks run in parallel add up: the sub-stages of a stage may then exceed its wall.
"""

from __future__ import annotations

import os
import time
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

from numba.core import event

COMPILE_EVENT = "numba:compile"


def _clocks() -> tuple[float, float]:
    """(wall, CPU of this process and of its finished children) in seconds."""
    t = os.times()
    return time.perf_counter(), time.process_time() + t.children_user + t.children_system


@dataclass
class Stage:
    """What one named stage took (module docstring)."""

    calls: int = 0
    wall_s: float = 0.0
    cpu_s: float = 0.0
    compile_s: float = 0.0

    def add(self, wall: float, cpu: float, compile_s: float, calls: int = 0) -> None:
        self.calls += calls
        self.wall_s += wall
        self.cpu_s += cpu
        self.compile_s += compile_s


class Timings:
    """The stages of one recording, in the order they were first entered, and its total."""

    def __init__(self) -> None:
        self.stages: dict[str, Stage] = {}
        self.open: list[str] = []
        self.total = Stage()
        self.started = _clocks()
        self._timer: event.TimingListener | None = None

    def compiled(self) -> float:
        """Seconds Numba has spent compiling since the recording started."""
        timer = self._timer
        return timer.duration if timer is not None and timer.done else 0.0

    @contextmanager
    def stage(self, name: str) -> Iterator[None]:
        """Time the block as stage ``name`` (nested: ``outer/name``)."""
        if self.open and self.open[-1].rsplit("/", 1)[-1] == name:
            yield
            return
        full = f"{self.open[-1]}/{name}" if self.open else name
        entry = self.stages.setdefault(full, Stage())
        entry.calls += 1
        self.open.append(full)
        wall, cpu = _clocks()
        compiled = self.compiled()
        try:
            yield
        finally:
            self.open.pop()
            wall2, cpu2 = _clocks()
            entry.add(wall2 - wall, cpu2 - cpu, self.compiled() - compiled)

    def merge(self, other: Mapping[str, Any] | None) -> None:
        """Add another recording's stages (:meth:`to_dict`, e.g. a task's run in a worker)
        under the stage open now."""
        prefix = f"{self.open[-1]}/" if self.open else ""
        for s in (other or {}).get("stages", []):
            self.stages.setdefault(prefix + s["name"], Stage()).add(
                s["wall_s"], s["cpu_s"], s["compile_s"], s["calls"])

    def to_dict(self) -> dict[str, Any]:
        """The JSON form: ``{"stages": [{"name", "calls", "wall_s", "cpu_s",
        "compile_s"}, ...], "wall_s", "cpu_s", "compile_s"}`` (totals of the recording)."""
        return {"stages": [{"name": name, "calls": s.calls, "wall_s": s.wall_s,
                            "cpu_s": s.cpu_s, "compile_s": s.compile_s}
                           for name, s in self.stages.items()],
                "wall_s": self.total.wall_s, "cpu_s": self.total.cpu_s,
                "compile_s": self.total.compile_s}


_CURRENT: list[Timings] = []


@contextmanager
def recording() -> Iterator[Timings]:
    """Record the block's stages into a new :class:`Timings`, the current one until the
    block ends (recordings nest: the innermost is current); its total is the block's."""
    timings = Timings()
    wall, cpu = _clocks()
    with event.install_timer(COMPILE_EVENT, lambda s: None) as timer:
        timings._timer = timer
        _CURRENT.append(timings)
        try:
            yield timings
        finally:
            _CURRENT.remove(timings)
            wall2, cpu2 = _clocks()
            timings.total.add(wall2 - wall, cpu2 - cpu, timings.compiled(), 1)


@contextmanager
def stage(name: str) -> Iterator[None]:
    """Time the block as stage ``name`` of the current recording (none: not timed)."""
    if not _CURRENT:
        yield
        return
    with _CURRENT[-1].stage(name):
        yield


def snapshot() -> dict[str, Any] | None:
    """The current recording so far (:meth:`Timings.to_dict`, its totals up to now), or
    None when nothing is recorded: what a command writes into its own result file before
    it ends (the stages still open count up to now)."""
    if not _CURRENT:
        return None
    timings = _CURRENT[-1]
    out = timings.to_dict()
    wall, cpu = _clocks()
    out.update(wall_s=wall - timings.started[0], cpu_s=cpu - timings.started[1],
               compile_s=timings.compiled())
    return out


def merge(other: Mapping[str, Any] | None) -> None:
    """Add ``other``'s stages to the current recording, under its open stage (none: nothing
    is recorded)."""
    if _CURRENT:
        _CURRENT[-1].merge(other)
