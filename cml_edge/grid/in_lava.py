"""The navigator with every planning read computed in Intel Lava (``cml-edge lava run``).

A plan's decision reads four things through the arrays: s* - s = W_q (o* - o), the utility
W_v^T (s* - s), the embedding s = W_q o and the affordance's W_k s (and, once, W_v's
columns for the utility's norms). Here each of those reads is Lava's: the input vector,
encoded as graded-spike payloads as the emulation's pre neurons encode it, goes through a
``Dense`` built from the model's export and a ``LIF`` in Lava 0.10's CPU simulator
(:func:`cml_edge.backends.loihi2.conformance.run_lava`), and the float read is the LIF's
integer ``u`` scaled as the emulation scales its own. The sigmoid (the array's table), the
winner-take-all and the move are the emulation's rule applied to those values, on the
host: :func:`cml_edge.grid.planning.plan` on the reference path, unchanged.

Lava runs batches, not one read at a time: the plans run in rounds. In a round each read
whose input Lava has not seen is taken from the emulation and listed; the listed inputs
then run in Lava (W_q's and W_v's first, then those that depend on them), and the plans
run again. A round in which every read was Lava's ends it: its plans are the result. Each
decision of that round is then compared with the emulation's decision in the same cell
(``decisions_equal``).
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable
from typing import Any

import numpy as np

from cml_edge.backends import array_from_state_dict
from cml_edge.backends.loihi2 import conformance
from cml_edge.core.cml import CML
from cml_edge.errors import InputError
from cml_edge.grid.arena import GridArena
from cml_edge.grid.metrics import Pairs, summarize
from cml_edge.grid.planning import plan
from cml_edge.grid.training import TrainConfig, train

MAX_ROUNDS = 12
"""Rounds before giving up (each adds the reads the previous round's plans reached)."""


class LavaReads:
    """An array whose reads are Lava's where Lava has read that input (looked up by the
    input's bytes, per direction), else the emulation's, listed in ``missing``."""

    def __init__(self, arr: Any, name: str) -> None:
        self.arr, self.name = arr, name
        self.read: dict[bool, dict[bytes, np.ndarray]] = {False: {}, True: {}}
        self.missing: dict[bool, dict[bytes, np.ndarray]] = {False: {}, True: {}}

    def matvec(self, x: np.ndarray) -> np.ndarray:
        return self._read(x, False)

    def rmatvec(self, y: np.ndarray) -> np.ndarray:
        return self._read(y, True)

    def _read(self, x: np.ndarray, transposed: bool) -> np.ndarray:
        x = np.ascontiguousarray(x, dtype=np.float64)
        got = self.read[transposed].get(x.tobytes())
        if got is not None:
            return got.copy()
        self.missing[transposed][x.tobytes()] = x.copy()
        return self.arr.rmatvec(x) if transposed else self.arr.matvec(x)

    def __getattr__(self, name: str) -> Any:  # shape, sigmoid, options, ...: the array's
        return getattr(self.arr, name)


def run_in_lava(cml: CML, arena: GridArena, pairs: Pairs, max_steps: int,
                progress: Callable[[str, int, int], None] | None = None) -> dict[str, Any]:
    """Plan ``pairs`` on ``arena`` with every read computed in Lava (module docstring):
    the summary of :func:`~cml_edge.grid.metrics.summarize`, ``decisions``,
    ``decisions_equal`` (the emulation's decision in the same cell), ``lava_reads`` and
    ``rounds``. ``progress(stage, done, total)`` is told each stage's start and end."""
    names = ("W_q", "W_k", "W_v")
    reads = tuple(LavaReads(arr, name) for arr, name in zip(cml.arrays, names))
    lava = CML(cml.config, reads, cml.backend)
    tick = progress or (lambda stage, done, total: None)
    for rounds in range(1, MAX_ROUNDS + 1):
        for r in reads:
            r.missing = {False: {}, True: {}}
        tick(f"round {rounds}: plans", 0, 1)
        res = plan(lava, arena, pairs.starts, pairs.goals, max_steps=max_steps,
                   path="reference")
        tick(f"round {rounds}: plans", 1, 1)
        work: dict[str, np.ndarray] = {}
        batches = []
        for r in reads:
            for transposed, todo in r.missing.items():
                if todo:
                    key = r.name + ("^T" if transposed else "")
                    X = np.array(list(todo.values()))
                    work.update(conformance.read_work(r.arr, key, X, transposed))
                    batches.append((r, transposed, key, X))
        if not batches:
            break
        work["reads"] = np.array([key for *_, key, _ in batches])
        stage = f"round {rounds}: {sum(len(X) for *_, X in batches)} reads in Lava"
        tick(stage, 0, 1)
        got = conformance.run_lava(work)
        tick(stage, 1, 1)
        for r, transposed, key, X in batches:
            floats = conformance.lava_floats(r.arr, X, got[f"{key}/u"])
            for x, y in zip(X, floats):
                r.read[transposed][x.tobytes()] = y
    else:
        raise InputError(f"the plans still reached reads Lava had not run after {MAX_ROUNDS} "
                         "rounds")
    tick("decisions against the emulation", 0, 1)
    decisions, equal = _decisions(cml, arena, pairs, res)
    tick("decisions against the emulation", 1, 1)
    return {**summarize(res.final, res.steps, pairs), "decisions": decisions,
            "decisions_equal": equal, "rounds": rounds,
            "lava_reads": sum(len(v) for r in reads for v in r.read.values())}


def _decisions(cml: CML, arena: GridArena, pairs: Pairs, res: Any) -> tuple[int, int]:
    """(decisions, how many the emulation takes alike in the same cell): each decision of
    ``res`` replanned by the emulation for one step from its cell."""
    starts, goals, nexts = [], [], []
    for t in range(len(pairs.starts)):
        path = res.paths[t, :res.steps[t] + 1]
        starts += [p for p in path[:-1]]
        nexts += [p for p in path[1:]]
        goals += [pairs.goals[t]] * (len(path) - 1)
    if not starts:
        return 0, 0
    one = plan(cml, arena, np.array(starts), np.array(goals), max_steps=1, path="reference")
    return len(starts), int(np.all(one.final == np.array(nexts), axis=1).sum())


class _RecordedError(Exception):
    """Every matrix has recorded its stretch of updates: training stops."""


class UpdateRecorder:
    """An array that records its next ``count`` updates after the first ``skip``: its
    state before them, then each ``(post, pre, lr, stream)``, ``stream`` its random stream
    just before the update. Everything else is the array's own."""

    def __init__(self, arr: Any, skip: int, count: int, all_: list[UpdateRecorder]) -> None:
        self.arr, self.skip, self.count, self.all = arr, skip, count, all_
        self.seen = 0
        self.start: Any = None
        self.calls: list[tuple] = []

    def outer_update(self, post: np.ndarray, pre: np.ndarray, lr: float, defer: bool) -> None:
        if self.skip <= self.seen < self.skip + self.count:
            if self.start is None:
                self.start = array_from_state_dict(self.arr.state_dict())
            self.calls.append((np.array(post, dtype=np.float64),
                               np.array(pre, dtype=np.float64), float(lr),
                               self.arr.state.rng.copy()))
        self.seen += 1
        self.arr.outer_update(post, pre, lr, defer)
        if all(len(r.calls) == r.count for r in self.all):
            raise _RecordedError

    def __getattr__(self, name: str) -> Any:
        return getattr(self.arr, name)


def training_updates(cml: CML, training: dict[str, Any], epochs: int,
                     skip: int = 0) -> dict[str, tuple[Any, list[tuple]]]:
    """The model's own training rerun from its record (seed, arena, walks, steps,
    exploration, schedule and device options; the reference path) until each matrix has
    made ``skip`` + ``epochs`` updates: per matrix, its array before update ``skip`` and
    updates ``skip`` .. ``skip + epochs - 1`` (:class:`UpdateRecorder`). InputError when
    the record does not rebuild the model's arrays, or its training ends first."""
    try:
        fresh = CML.create(cml.config, cml.backend, int(training["seed"]),
                           **training.get("backend_options", {}))
        config = TrainConfig(int(training["walks"]), int(training["steps"]),
                             training.get("explore", "random"), training["schedule"])
        size = int(training["arena"])
    except (KeyError, TypeError, ValueError) as exc:
        raise InputError(f"the model's training record cannot be rerun ({exc})") from None
    if [a.options() for a in fresh.arrays] != [a.options() for a in cml.arrays]:
        raise InputError("the model's training record does not rebuild its arrays (other "
                         "options)")
    recorders: list[UpdateRecorder] = []
    recorders += [UpdateRecorder(a, skip, epochs, recorders) for a in fresh.arrays]
    with contextlib.suppress(_RecordedError):
        train(CML(cml.config, tuple(recorders), cml.backend), GridArena.empty(size), config,
              int(training["seed"]), path="reference")
    if any(len(r.calls) < epochs for r in recorders):
        raise InputError(f"the model's training makes fewer than {skip + epochs} updates")
    return {name: (r.start, r.calls) for name, r in zip(("W_q", "W_k", "W_v"), recorders)}


__all__ = ["LavaReads", "UpdateRecorder", "run_in_lava", "training_updates"]
