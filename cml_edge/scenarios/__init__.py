"""Scenarios: named, documented, seeded workloads that tell devices apart.

``SCENARIOS`` (:mod:`cml_edge.scenarios.registry`) holds the eight scenarios as data;
:func:`run_scenario` (:mod:`cml_edge.scenarios.runner`) runs one on any device through
the sweep engine; :mod:`cml_edge.scenarios.breakpoint` finds the knob value at which a
scenario's success crosses a target. ``cml-edge scenario`` and ``cml-edge breakpoint``
are their command lines.
"""

from cml_edge.scenarios.registry import BUDGETS, SCENARIOS, Budget, Scenario
from cml_edge.scenarios.runner import run_scenario

__all__ = ["BUDGETS", "SCENARIOS", "Budget", "Scenario", "run_scenario"]
