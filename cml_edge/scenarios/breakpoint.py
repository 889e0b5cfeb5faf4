"""Break points: the knob value at which a scenario's success crosses a target.

A **knob** (:class:`cml_edge.backends.device.Knob`) is one device setting, with a default
range and a direction: the ``good`` end, where a device is closer to ideal. A device
declares its own in its folder (a config field, or a compound such as the crossbar's
``stuck``); the generic ones (:data:`GENERIC_KNOBS`: the time the arrays sit idle before
planning) apply to every device; :func:`knobs_of` reads both from the registry. A knob's
range is laid on a fixed grid of :data:`GRID_POINTS` values (evenly spaced, on a log
scale for times and levels, the distinct integers of such a grid for integer fields),
ordered from the good end to the bad end, so a break point is always one of the grid's
values and a rerun takes the same evaluations.

:func:`find_breakpoint` runs the scenario (:func:`cml_edge.scenarios.runner.run_scenario`,
every evaluation on the same seeds) at both ends. The range brackets the target when
success at the good end is >= the target and at the bad end below it; otherwise the
result says there is no break point within the range (``found`` False, ``value`` None,
``note`` naming both ends' success): a finding, not an error. Then bisection on the grid
indices: the middle index passes or fails, and the bracket halves until its two values
are neighbours. The result:
``value``, the last grid value (from the good end) at which success met the target;
``bracket`` (that value and the first failing neighbour); and every evaluation (knob
value, success) in the order it ran. Bisection assumes success falls monotonically
along the grid; the evaluations are all reported so a reader can see where it did not, and
:func:`largest_rise` (``largest_rise`` of the result, None when success never rises toward
the bad end) names the largest rise among them.

Success of a scenario is its worst part's ``success_rate`` (or the named ``part``'s).

In space (``dims`` 3, ``moves``; :meth:`cml_edge.scenarios.registry.Scenario.runs`) the
same search runs the scenario's 3-D form: ``cml-edge breakpoint --dims 3 --knob KNOB
--scenario paper`` is the knob's break point in the 30 x 30 x 30 volume.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from cml_edge.backends import DEVICES, Knob, backend_spec
from cml_edge.backends.base import MAX_IDLE_S
from cml_edge.errors import InputError
from cml_edge.scenarios.registry import BUDGETS, get
from cml_edge.scenarios.runner import in_space, run_scenario

GRID_POINTS = 17
"""Grid values per range: 2^4 + 1, so bisection takes at most 4 evaluations between the
two ends (6 in all)."""
MIN_SEEDS = 2
IDLE = "idle_s"
"""The pseudo-field of the drift-time knob: seconds idle before planning."""

GENERIC_KNOBS: dict[str, Knob] = {k.name: k for k in (
    Knob("drift_time", IDLE, 1.0, MAX_IDLE_S, "low", log=True,
         doc="seconds idle between the end of training and planning (100 years at the "
             "bad end); drifts only a device that drifts"),
)}
"""The knobs of every device (a device's own are declared in its folder,
:attr:`cml_edge.backends.device.DeviceSpec.knobs`)."""


def knobs_of(device: str) -> dict[str, Knob]:
    """The knobs of ``device`` (a registered device's name): its own, then the generic
    ones it does not declare itself."""
    own = {k.name: k for k in DEVICES[device].knobs}
    return {**own, **{name: k for name, k in GENERIC_KNOBS.items() if name not in own}}


def knob_names() -> list[str]:
    """Every knob name of the registered devices and the generic ones."""
    return list(dict.fromkeys([k.name for d in DEVICES.values() for k in d.knobs]
                              + list(GENERIC_KNOBS)))


def get_knob(name: str, device: str) -> Knob:
    """The knob ``name`` of ``device``; InputError naming the knobs there are."""
    knobs = knobs_of(device)
    if name in knobs:
        return knobs[name]
    if name not in knob_names():
        raise InputError(f"unknown knob {name!r}; allowed: {', '.join(knob_names())}")
    raise InputError(f"knob {name!r} does not apply to the {device} device; its knobs: "
                     f"{', '.join(knobs)}")


def knob_grid(knob: Knob, lo: float, hi: float) -> list[float]:
    """The grid of ``knob`` on [lo, hi], from the good end to the bad end (module
    docstring)."""
    values = np.geomspace(lo, hi, GRID_POINTS) if knob.log else np.linspace(lo, hi, GRID_POINTS)
    if knob.integer:
        values = np.unique(np.round(values).astype(int))
    out = [int(v) if knob.integer else float(v) for v in values]
    return out if knob.good == "low" else out[::-1]


def knob_setting(knob: Knob, value: float) -> tuple[dict[str, Any], float]:
    """(device options, idle seconds) that set ``knob`` to ``value``."""
    if knob.field == IDLE:
        return {}, float(value)
    return knob.setting(value), 0.0


def scenario_success(result: dict[str, Any], part: str | None = None) -> float:
    """The worst part's success rate, or the named part's."""
    rates = {p["part"]: p["success_rate"] for p in result["parts"]}
    if part is not None:
        if part not in rates:
            raise InputError(f"scenario {result['scenario']!r} has no part {part!r}; its "
                             f"parts: {', '.join(rates)}")
        return rates[part]
    return min(rates.values())


class Bisection:
    """Bisection on ``grid`` (good end first) for the last value that passes, a batch of
    evaluations at a time: :attr:`pending` holds the grid indices to evaluate next (the
    two ends first, then each middle index), :meth:`record` takes whether they passed.
    When :attr:`pending` is empty, :attr:`bracketed` says whether the two ends bracket
    the target (the good end passes, the bad end fails) and :attr:`i` / :attr:`j` are the
    last passing and the first failing index; :attr:`seen` is every (value, passed) in
    the order evaluated."""

    def __init__(self, grid: list[float]) -> None:
        self.grid = grid
        self.seen: list[tuple[float, bool]] = []
        self.pending = [0, len(grid) - 1]
        self.bracketed = False
        self.i, self.j = 0, len(grid) - 1

    def record(self, passed: list[bool]) -> None:
        """Whether the values at :attr:`pending` passed, in its order."""
        if len(passed) != len(self.pending):
            raise ValueError(f"{len(passed)} outcomes for {len(self.pending)} evaluations")
        self.seen += [(self.grid[k], ok) for k, ok in zip(self.pending, passed)]
        if self.pending == [0, len(self.grid) - 1]:  # the two ends
            self.bracketed = passed[0] and not passed[1]
            if not self.bracketed:
                self.pending = []
                return
        else:
            (m,), (ok,) = self.pending, passed
            self.i, self.j = (m, self.j) if ok else (self.i, m)
        self.pending = [(self.i + self.j) // 2] if self.j - self.i > 1 else []


def bisect(grid: list[float], passes: Callable[[float], bool]
           ) -> tuple[int, int, list[tuple[float, bool]]]:
    """:class:`Bisection` one evaluation at a time: returns (last passing index, first
    failing index, the evaluations in order); :class:`NotBracketedError` when the two
    ends do not bracket (the good end fails or the bad end passes)."""
    b = Bisection(grid)
    while b.pending:
        b.record([passes(grid[k]) for k in b.pending])
    if not b.bracketed:
        raise NotBracketedError(b.seen)
    return b.i, b.j, b.seen


class NotBracketedError(InputError):
    """The range's two ends do not bracket the target."""

    def __init__(self, seen: list[tuple[float, bool]]) -> None:
        super().__init__("range does not bracket the target")
        self.seen = seen

TINY_NOTE = ("--budget tiny is a smoke test (3 walks x 100 steps a model): its models reach "
             "little success, so a break point is rarely found")


@dataclass
class Search:
    """One break point's search with its inputs checked (:func:`breakpoint_search`): the
    knob's grid and its :class:`Bisection`, and every evaluation so far (knob value,
    success, each part's success) in the order it ran."""

    scenario: str
    backend: str
    options: dict[str, Any]
    knob: Knob
    target: float
    seeds: int
    budget: str
    part: str | None
    lo: float
    hi: float
    physical: bool
    """The range is the knob's default."""
    grid: list[float]
    bisection: Bisection
    evaluations: list[dict[str, Any]] = field(default_factory=list)
    dims: int | None = None
    """The scenario's dimensions (None: its default)."""
    moves: str = "king"
    """The grid's move set."""

    def setting(self, value: float) -> tuple[dict[str, Any], float]:
        """(device options, idle seconds) of an evaluation at knob ``value``."""
        setting, idle = knob_setting(self.knob, value)
        return {**self.options, **setting}, idle

    def record(self, value: float, result: dict[str, Any]) -> bool:
        """Keep the scenario ``result`` at ``value``; whether it met the target."""
        success = scenario_success(result, self.part)
        self.evaluations.append({"value": value, "success_rate": success, "parts": {
            p["part"]: p["success_rate"] for p in result["parts"]}})
        return success >= self.target

    def result(self, command: str | None = None) -> dict[str, Any]:
        """The break point once :attr:`bisection` has no evaluation pending (module
        docstring)."""
        b = self.bisection
        out = {"scenario": self.scenario, "backend": self.backend,
               "backend_options": dict(self.options), "knob": self.knob.name,
               "field": self.knob.field, "good": self.knob.good, "target": self.target,
               "range": [self.lo, self.hi], "grid": self.grid, "seeds": int(self.seeds),
               "seed_list": list(range(int(self.seeds))), "budget": self.budget,
               "part": self.part, "evaluations": self.evaluations,
               **in_space(self.scenario, self.dims, self.moves)}
        out["largest_rise"] = largest_rise(self.evaluations)
        if not b.bracketed:
            return {**out, "value": None, "bracket": None, "found": False,
                    "note": no_break_point(self.knob, self.lo, self.hi, self.target,
                                           self.evaluations, self.physical),
                    "n_evaluations": len(self.evaluations), "command": command}
        return {**out, "value": self.grid[b.i], "bracket": [self.grid[b.i], self.grid[b.j]],
                "found": True, "n_evaluations": len(self.evaluations), "command": command}


def breakpoint_search(scenario: str, backend: str, knob: str,
                      options: dict[str, Any] | None = None, target: float = 0.95,
                      seeds: int = 3, value_range: tuple[float, float] | None = None,
                      budget: str = "full", part: str | None = None,
                      dims: int | None = None, moves: str = "king") -> Search:
    """The :class:`Search` of a break point, every input checked (InputError naming the
    first bad one) before any run; ``dims`` and ``moves``: the scenario's world (None:
    its default dimensions)."""
    scen = get(scenario)
    scen.space(dims, moves)
    if budget not in BUDGETS:
        raise InputError(f"unknown budget {budget!r}; known: {', '.join(BUDGETS)}")
    names = [p["name"] for _, run in scen.runs(BUDGETS[budget], dims, moves)
             for p in run["parts"]]
    if part is not None and part not in names:
        raise InputError(f"scenario {scenario!r} has no part {part!r}; its parts: "
                         f"{', '.join(dict.fromkeys(names))}")
    spec = backend_spec(backend)
    device = spec.device.name
    k = get_knob(knob, device)
    given = [name for name in k.fields if name in (options or {})]
    if given:
        raise InputError(f"{given[0]} is given ({given[0]}={options[given[0]]!r}) and set by "
                         f"--knob {knob}: the knob sweeps it; drop one")
    if any(name in spec.device.fixes(backend) for name in k.fields):
        raise InputError(f"--backend {backend} fixes {k.field}, the field of knob "
                         f"{knob!r}; use --backend {device}")
    if isinstance(seeds, bool) or int(seeds) != seeds or seeds < MIN_SEEDS:
        raise InputError(f"a break point needs at least {MIN_SEEDS} seeds (got {seeds!r})")
    if not (math.isfinite(target) and 0 < target <= 1):
        raise InputError(f"target {target!r} is not a success rate in (0, 1]")
    lo, hi = value_range if value_range is not None else (k.lo, k.hi)
    if not (math.isfinite(lo) and math.isfinite(hi)) or lo >= hi:
        raise InputError(f"range {lo!r} {hi!r} is not two finite numbers LO < HI")
    if k.log and lo <= 0:
        raise InputError(f"knob {knob!r} is swept on a log scale: its range must be > 0 "
                         f"(got {lo!r})")
    for end in (lo, hi):  # both ends within the field's documented range
        if k.field == IDLE and not 0 <= end <= MAX_IDLE_S:
            raise InputError(f"range end {end:g} of {knob!r} is outside 0..{MAX_IDLE_S:g} "
                             "seconds (100 years idle at most)")
        if k.field != IDLE:
            spec.device.given(backend, {**(options or {}), **k.setting(end)})
    grid = knob_grid(k, lo, hi)
    if len(grid) < 2:
        raise InputError(f"range {lo!r} {hi!r} holds fewer than two values of {knob!r}")
    return Search(scenario, backend, dict(options or {}), k, target, int(seeds), budget, part,
                  lo, hi, value_range is None, grid, Bisection(grid), dims=dims, moves=moves)


def find_breakpoint(scenario: str, backend: str, knob: str, options: dict[str, Any] | None = None,
                    target: float = 0.95, seeds: int = 3, value_range: tuple[float, float]
                    | None = None, budget: str = "full", part: str | None = None,
                    out: str | Path | None = None, workers: int | None = None,
                    scheduler: str | None = None, command: str | None = None,
                    restart: bool = False, on_start: Callable[[list[str]], None] | None = None,
                    dims: int | None = None, moves: str = "king") -> dict[str, Any]:
    """The break point of ``knob`` for ``scenario`` on ``backend`` (module docstring).
    ``options``: the device's other settings (the knob's field overrides them); ``out``:
    each evaluation's sweep under ``out/KNOB=VALUE`` (resumable; a sweep of other settings
    there is refused unless ``restart``, which starts each over). ``on_start`` is called
    once the inputs are checked, before the first run, with notes the user should read
    first. ``dims`` and ``moves``: the scenario's world (:func:`breakpoint_search`)."""
    search = breakpoint_search(scenario, backend, knob, options, target, seeds, value_range,
                               budget, part, dims, moves)
    if on_start is not None:
        on_start([TINY_NOTE] if budget == "tiny" else [])
    b = search.bisection
    space = {} if (dims or 2, moves) == (2, "king") else {"dims": dims, "moves": moves}
    while b.pending:
        passed = []
        for k in b.pending:
            value = search.grid[k]
            opts, idle = search.setting(value)
            res = run_scenario(scenario, backend, opts, seeds, budget,
                               Path(out) / f"{knob}={value}" if out is not None else None,
                               workers, scheduler, idle_s=idle, restart=restart, **space)
            passed.append(search.record(value, res))
        b.record(passed)
    return search.result(command)


def largest_rise(evaluations: list[dict[str, Any]]) -> dict[str, float] | None:
    """The largest rise in success from one evaluated knob value to another farther toward
    the bad end (``from``, ``to``, ``by``), over a search's ``evaluations`` (the good end
    first, the bad end second, as :class:`Bisection` runs them); None when success never
    rises toward the bad end, as the bisection assumes."""
    if len(evaluations) < 2:
        return None
    toward_bad = 1.0 if evaluations[1]["value"] > evaluations[0]["value"] else -1.0
    along = sorted(evaluations, key=lambda e: toward_bad * e["value"])
    best, lowest = None, along[0]
    for e in along[1:]:
        rise = e["success_rate"] - lowest["success_rate"]
        if rise > 0 and (best is None or rise > best["by"]):
            best = {"from": lowest["value"], "to": e["value"], "by": rise}
        if e["success_rate"] < lowest["success_rate"]:
            lowest = e
    return best


def no_break_point(knob: Knob, lo: float, hi: float, target: float,
                   evaluations: list[dict[str, Any]], physical: bool) -> str:
    """Why a range holds no break point (its two ends do not bracket ``target``): the
    device meets the target at both ends, at neither, or only at the bad end; with both
    ends' success. ``physical``: the range is the knob's default."""
    good, bad = evaluations[0]["success_rate"], evaluations[-1]["success_rate"]
    where = "the physical range" if physical else "the range"
    why = ("success is below the target even at the good end" if max(good, bad) < target
           else "success meets the target across it" if good >= target
           else "success rises toward the bad end")
    ends = ", ".join(f"{e['value']:g}: success {e['success_rate']:.3f}" for e in evaluations)
    return (f"no break point within {where} {lo:g}..{hi:g} of {knob.name} at target "
            f"{target:g}: {why} ({ends})")
