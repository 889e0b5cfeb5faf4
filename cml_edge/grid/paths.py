"""The one rule that picks the compute path of a grid run when none is given
(:func:`default_path`), and when the exact factored shortcut applies."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from cml_edge.core.cml import CML
from cml_edge.core.learning import schedule_defers
from cml_edge.grid.arena import GridArena


def factored_supported(cml: CML, schedule: str = "walk", arena: GridArena | None = None
                       ) -> bool:
    """Whether the exact factored shortcut applies: every array keeps float64 weights
    (``supports_factored``), the schedule applies updates at the end of each walk, and the
    training ``arena`` (if given) reads no range sensors (the shortcut needs an observation
    of the position alone, :mod:`cml_edge.grid.sensors`)."""
    return (schedule_defers(schedule) and (arena is None or not arena.n_sensors)
            and all(getattr(a, "supports_factored", False) for a in cml.arrays))


def default_path(cml: CML | str, schedule: str = "walk",
                 backend_options: Mapping[str, Any] | None = None, *,
                 counted: bool = False, arena: GridArena | None = None) -> str:
    """The compute path a run takes when none is given: the one rule of cml-edge.

    - ``direct`` when the run reports the arrays' operation counters (``counted``:
      ``cml-edge emulate``, :func:`run_protocol`, the hardware-budget report). The factored
      shortcut bypasses the arrays, so it would count nothing; and ``direct`` is the path
      a device array emulates operation by operation.
    - Otherwise ``factored`` where it applies (:func:`factored_supported`: float64 arrays
      and the per-walk schedule; it agrees with ``direct`` to rounding and is much faster,
      measured in benchmarks/README.md), else ``direct``: ``cml-edge train``, ``evaluate``,
      ``navigate``, the experiments, and the extra figures of ``cml-edge bench``.

    ``cml`` is a model, or a backend name (with ``backend_options``) whose model is made
    to ask; ``arena``: the training arena (:func:`factored_supported`). Planning has no
    schedule: leave ``schedule`` and ``arena`` at their defaults for it.
    """
    if counted or not schedule_defers(schedule):
        return "direct"
    if isinstance(cml, str):
        cml = CML.create(backend=cml, **(backend_options or {}))
    return "factored" if factored_supported(cml, schedule, arena) else "direct"

