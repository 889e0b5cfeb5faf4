"""The one rule that picks the compute path of a grid run when none is given
(:func:`default_path`), and when the exact factored shortcut applies."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from cml_edge.core.cml import CML
from cml_edge.core.learning import schedule_defers


def factored_supported(cml: CML, schedule: str = "walk") -> bool:
    """Whether the exact factored shortcut applies: every array keeps float64 weights
    (``supports_factored``) and the schedule applies updates at the end of each walk."""
    return schedule_defers(schedule) and all(getattr(a, "supports_factored", False)
                                             for a in cml.arrays)


def default_path(cml: CML | str, schedule: str = "walk",
                 backend_options: Mapping[str, Any] | None = None, *,
                 counted: bool = False) -> str:
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
    to ask. Planning has no schedule: leave ``schedule`` at its default for it.
    """
    if counted or not schedule_defers(schedule):
        return "direct"
    if isinstance(cml, str):
        cml = CML.create(backend=cml, **(backend_options or {}))
    return "factored" if factored_supported(cml, schedule) else "direct"

