"""The scorecard of the report: every device on every scenario, break points,
recovery curves.

Read top to bottom: :func:`build_scorecard` runs each scenario of
:data:`cml_edge.scenarios.SCENARIOS` on each device of the report (the systems of
:func:`cml_edge.backends.report_systems`, the earlier crossbar presets under their new
names among them) as one batch of sweep tasks (:class:`~cml_edge.report.batch.Batch`:
the report's workers; the scenarios that start from the same training share one model
per seed, :func:`cml_edge.scenarios.runner.shared_training`, with the numbers of their own
runs), then each break point the devices declare for the report
(:func:`reference_breakpoints`; the bisection of
:func:`cml_edge.scenarios.breakpoint.find_breakpoint`, all break points in lockstep,
:func:`run_searches`), and returns the three lists the report keeps under stable keys:

- ``scorecard``: one row per device x scenario x part (a scenario's evaluation
  condition, e.g. retention's ``1y``): ``device``, ``scenario``, ``part``,
  ``success_rate``, ``overhead_mean``, ``weight_error`` (the seed mean of the three
  matrices' mean relative error against the float64 twin), ``decision_agreement`` (seed
  mean), ``seeds``, with the seed spreads beside them;
- ``breakpoints``: ``device``, ``knob``, ``scenario``, ``value`` (None when the knob's
  range does not bracket the target: ``note`` then says why, with both ends' success),
  ``target``, ``seeds``, ``log`` (the knob is swept on a log scale, and drawn on one),
  and every evaluation the bisection took;
- ``space_scorecard`` and ``space_breakpoints`` (with :attr:`ScorecardPlan.space`): the
  scorecard's rows of the 3-D scenarios (each with its ``dims``) and the same break points
  in the volume (:func:`space_breakpoints`; rows with ``dims``), for the report's 3-D
  section;
- ``recovery``: one row per device x K (walks of in-situ relearning after a year of
  drift): ``device``, ``walks``, ``success_rate``, ``pulses``, ``energy_uJ`` (seed means
  of what the relearning cost), with ``writes`` and ``decision_agreement``.

Every number is measured here, on the seeds listed in the rows; nothing is carried over
from an earlier run.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field, replace
from typing import Any

from cml_edge.backends import backend_spec, report_breakpoints, report_systems
from cml_edge.engine.sweep import Task
from cml_edge.report.batch import Batch
from cml_edge.scenarios import SCENARIOS
from cml_edge.scenarios.breakpoint import Search, get_knob
from cml_edge.scenarios.breakpoint import breakpoint_search as breakpoint_search_of
from cml_edge.scenarios.registry import SPACE_SCENARIOS
from cml_edge.scenarios.runner import (
    scenario_result,
    scenario_tasks,
    shared_result,
    shared_training,
)


@dataclass(frozen=True)
class Breakpoint:
    """One break point of the report: ``knob`` of device ``device`` (a label) on
    ``backend`` with ``options``, for ``scenario``; ``value_range`` None: the knob's."""

    device: str
    backend: str
    options: dict[str, Any]
    knob: str
    scenario: str = "paper"
    value_range: tuple[float, float] | None = None
    dims: int | None = None
    """The scenario's dimensions (None: its default, the plane)."""


def reference_breakpoints() -> tuple[Breakpoint, ...]:
    """The report's break points, all on the paper scenario at target 0.95, each over its
    knob's default range, as the devices declare them
    (:attr:`cml_edge.backends.device.Report.breakpoints`, in the order of
    :func:`cml_edge.backends.report_breakpoints`); InputError for a knob the device does
    not have."""
    out = []
    for label, backend, options, knob in report_breakpoints():
        get_knob(knob, backend_spec(backend).device.name)
        out.append(Breakpoint(label, backend, options, knob))
    return tuple(out)


TARGET = 0.95
SPACE_DIMS = 3
"""The dimensions of the scorecard's 3-D scenarios (the grid's N x N x N volume)."""


@dataclass(frozen=True)
class ScorecardPlan:
    """What the scorecard runs: devices (label, backend, options), scenarios, the
    scenario budget (:data:`cml_edge.scenarios.BUDGETS`), seeds, break points."""

    seeds: int
    budget: str
    breakpoint_seeds: int
    devices: list[tuple[str, str, dict[str, Any]]] = field(default_factory=report_systems)
    scenarios: tuple[str, ...] = tuple(n for n, s in SCENARIOS.items() if 2 in s.dims)
    """The plane's scenarios (every scenario that runs in 2-D)."""
    breakpoints: tuple[Breakpoint, ...] = field(default_factory=reference_breakpoints)
    workers: int | None = None
    space: tuple[str, ...] = ()
    """Scenarios run again in 3-D (:data:`SPACE_DIMS`; the report's 3-D section), on the
    same devices, seeds and budget."""

    @classmethod
    def of(cls, quick: bool) -> ScorecardPlan:
        """The reference plan (3 model seeds at the full budget, the paper's protocol;
        break points on 3 as well; benchmarks/README.md times it) or the quick one (2
        seeds at the quick budget, every section kept); both with the 3-D scenarios
        (:data:`~cml_edge.scenarios.registry.SPACE_SCENARIOS`)."""
        return (cls(2, "quick", 2, space=SPACE_SCENARIOS) if quick
                else cls(3, "full", 3, space=SPACE_SCENARIOS))


def _mean(stats: dict[str, Any] | None) -> float | None:
    return None if stats is None else stats["mean"]


def _std(stats: dict[str, Any] | None) -> float | None:
    return None if stats is None else stats["std"]


def scorecard_rows(device: str, result: dict[str, Any]) -> list[dict[str, Any]]:
    """The scorecard rows of one scenario result (module docstring)."""
    rows = []
    for p in result["parts"]:
        we = p["weight_error"]["matrix_mean"]
        rows.append({
            "device": device, "scenario": result["scenario"], "part": p["part"],
            "success_rate": p["success_rate"], "overhead_mean": p["overhead_mean"],
            "weight_error": _mean(we), "weight_error_std": _std(we),
            "decision_agreement": _mean(p["decision_agreement"]),
            "decision_agreement_std": _std(p["decision_agreement"]),
            "success_rate_std": _std(p["success_rate_seeds"]),
            "seeds": result["seeds"], "budget": result["budget"]})
    return rows


def recovery_rows(device: str, result: dict[str, Any]) -> list[dict[str, Any]]:
    """The recovery curve of one device from its recovery scenario result."""
    return [{"device": device, "walks": int(p["relearn_walks"]),
             "success_rate": p["success_rate"], "pulses": _mean(p["pulses"]),
             "writes": _mean(p["writes"]), "energy_uJ": _mean(p["energy_uJ"]),
             "decision_agreement": _mean(p["decision_agreement"]),
             "weight_error": _mean(p["weight_error"]["matrix_mean"]),
             "seeds": result["seeds"]} for p in result["parts"]]


def breakpoint_search(bp: Breakpoint, plan: ScorecardPlan) -> Search:
    """The search of one break point of the report (its inputs checked)."""
    return breakpoint_search_of(bp.scenario, bp.backend, bp.knob, bp.options, TARGET,
                                plan.breakpoint_seeds, bp.value_range, plan.budget,
                                dims=bp.dims)


def breakpoint_row(bp: Breakpoint, plan: ScorecardPlan,
                   search: Search | None = None) -> dict[str, Any]:
    """One break point, or the reason there is none (the range does not bracket):
    ``search`` done already, or run here on ``plan.workers``."""
    if search is None:
        search = breakpoint_search(bp, plan)
        with Batch(plan.workers) as batch:
            run_searches([(bp, search)], batch)
    res = search.result()
    row: dict[str, Any] = {"device": bp.device, "backend": bp.backend, "options": bp.options,
                           "knob": bp.knob, "scenario": bp.scenario, "target": TARGET,
                           "seeds": plan.breakpoint_seeds, "budget": plan.budget,
                           "log": search.knob.log,
                           **({} if bp.dims is None else {"dims": bp.dims})}
    if not res["found"]:  # not bracketed: a finding, reported as measured
        return {**row, "value": None, "note": res["note"], "evaluations": res["evaluations"],
                "n_evaluations": res["n_evaluations"]}
    return {**row, "value": res["value"], "bracket": res["bracket"], "good": res["good"],
            "range": res["range"], "evaluations": res["evaluations"],
            "n_evaluations": res["n_evaluations"]}


def run_searches(searches: list[tuple[Breakpoint, Search]], batch: Batch) -> None:
    """Every search's bisection in lockstep: each round runs the evaluations every search
    has pending (its two ends first, then one middle value each) as one batch of tasks."""
    for n in itertools.count(1):
        round_: list[tuple[Search, float, dict[str, Any], float, list[Task]]] = []
        for bp, search in searches:
            for k in search.bisection.pending:
                value = search.grid[k]
                options, idle = search.setting(value)
                tasks = scenario_tasks(search.scenario, search.backend, options, search.seeds,
                                       search.budget, idle,
                                       prefix=f"bp-{bp.device}-{bp.knob}={value}-",
                                       dims=search.dims, moves=search.moves)
                round_.append((search, value, options, idle, tasks))
        if not round_:
            return
        results = batch.run("breakpoints", [t for *_, tasks in round_ for t in tasks],
                            part=f"round {n}")
        passed: dict[int, list[bool]] = {}
        for search, value, options, idle, tasks in round_:
            res = scenario_result(search.scenario, search.backend, options, search.seeds,
                                  search.budget, idle, tasks, results)
            passed.setdefault(id(search), []).append(search.record(value, res))
        for _, search in searches:
            if search.bisection.pending:
                search.bisection.record(passed[id(search)])


def scorecard_tasks(plan: ScorecardPlan) -> dict[tuple[str, str], list[Task]]:
    """The tasks of each (device label, scenario) of the scorecard."""
    own: dict[tuple[str, str], list[Task]] = {}
    for label, backend, options in plan.devices:
        for name in plan.scenarios:
            own[label, name] = scenario_tasks(name, backend, options, plan.seeds,
                                              plan.budget, prefix=f"card-{label}-")
    return own


def space_tasks(plan: ScorecardPlan) -> dict[tuple[str, str], list[Task]]:
    """The tasks of each (device label, scenario) of the scorecard's 3-D scenarios."""
    return {(label, name): scenario_tasks(name, backend, options, plan.seeds, plan.budget,
                                          prefix=f"card-{label}-", dims=SPACE_DIMS)
            for label, backend, options in plan.devices for name in plan.space}


def space_breakpoints(plan: ScorecardPlan) -> list[Breakpoint]:
    """The plan's break points again in 3-D (:data:`SPACE_DIMS`), when it has 3-D scenarios:
    the same knobs, ranges, target and seeds on the paper scenario in the volume."""
    return [replace(bp, dims=SPACE_DIMS) for bp in plan.breakpoints] if plan.space else []


def build_scorecard(plan: ScorecardPlan, batch: Batch | None = None) -> dict[str, Any]:
    """The ``scorecard``, ``breakpoints`` and ``recovery`` sections (module docstring),
    and the plan they were measured with (``scorecard_plan``); on ``batch`` (else on
    ``plan.workers``)."""
    if batch is None:
        with Batch(plan.workers) as batch:
            return build_scorecard(plan, batch)
    own = scorecard_tasks(plan)
    own3 = space_tasks(plan)
    tasks, owner = shared_training([t for ts in [*own.values(), *own3.values()] for t in ts])
    searches = [(bp, breakpoint_search(bp, plan)) for bp in plan.breakpoints]
    searches3 = [(bp, breakpoint_search(bp, plan)) for bp in space_breakpoints(plan)]
    done = batch.run("scorecard", tasks)
    scorecard: list[dict[str, Any]] = []
    recovery: list[dict[str, Any]] = []
    dqn_retrain = None
    for label, backend, options in plan.devices:
        for name in plan.scenarios:
            ts = own[label, name]
            results = {t.key: shared_result(t, done[owner[t.key]]) for t in ts}
            res = scenario_result(name, backend, options, plan.seeds, plan.budget, 0.0, ts,
                                  results)
            scorecard += scorecard_rows(label, res)
            if name == "recovery":
                recovery += recovery_rows(label, res)
                dqn_retrain = res["dqn_retrain"]
    space: list[dict[str, Any]] = []
    for (label, name), ts in own3.items():
        backend, options = next((b, o) for d, b, o in plan.devices if d == label)
        results = {t.key: shared_result(t, done[owner[t.key]]) for t in ts}
        res = scenario_result(name, backend, options, plan.seeds, plan.budget, 0.0, ts,
                              results)
        space += [{**row, "dims": res["dims"]} for row in scorecard_rows(label, res)]
    run_searches(searches + searches3, batch)
    breakpoints = [breakpoint_row(bp, plan, search) for bp, search in searches]
    return {"scorecard": scorecard, "breakpoints": breakpoints, "recovery": recovery,
            **({"space_scorecard": space,
                "space_breakpoints": [breakpoint_row(bp, plan, search)
                                      for bp, search in searches3]} if plan.space else {}),
            "dqn_retrain": dqn_retrain,
            "scorecard_plan": {"seeds": plan.seeds, "budget": plan.budget,
                               "breakpoint_seeds": plan.breakpoint_seeds,
                               "target": TARGET, "scenarios": list(plan.scenarios),
                               "devices": [d[0] for d in plan.devices]}}
