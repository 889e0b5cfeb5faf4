"""Break points: the knob value at which a scenario's success crosses a target.

A **knob** (:data:`KNOBS`) is one device setting (a config field, or the time the arrays
sit idle before planning), with a default range and a direction: the ``good`` end, where
a device is closer to ideal. Its range is laid on a fixed grid of :data:`GRID_POINTS`
values (evenly spaced, on a log scale for times, the distinct integers of such a grid for
integer fields), ordered from the good end to the bad end, so a break point is always
one of the grid's values and a rerun takes the same evaluations.

:func:`find_breakpoint` runs the scenario (:func:`cml_edge.scenarios.runner.run_scenario`,
every evaluation on the same seeds) at both ends. The range brackets the target when
success at the good end is >= the target and at the bad end below it; otherwise bad input
(naming both ends' values). Then bisection on the grid indices: the middle index passes
or fails, and the bracket halves until its two values are neighbours. The result:
``value``, the last grid value (from the good end) at which success met the target;
``bracket`` (that value and the first failing neighbour); and every evaluation (knob
value, success) in the order it ran. Bisection assumes success falls monotonically
along the grid; the evaluations are all reported so a reader can see where it did not.

Success of a scenario is its worst part's ``success_rate`` (or the named ``part``'s).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from cml_edge.backends import backend_spec
from cml_edge.errors import InputError
from cml_edge.scenarios.registry import get
from cml_edge.scenarios.runner import run_scenario

GRID_POINTS = 17
"""Grid values per range: 2^4 + 1, so bisection takes at most 4 evaluations between the
two ends (6 in all)."""
MIN_SEEDS = 2
IDLE = "idle_s"
"""The pseudo-field of the drift-time knob: seconds idle before planning."""


@dataclass(frozen=True)
class Knob:
    """A device setting swept for a break point."""

    name: str
    fields: dict[str, str]
    """Device name -> the config field the knob sets (``idle_s``: the idle time, on any
    device: key ``*``)."""
    lo: float
    hi: float
    good: str
    """``low`` or ``high``: the end where the device is closer to ideal."""
    integer: bool = False
    log: bool = False
    doc: str = ""

    def field(self, device: str) -> str:
        name = self.fields.get(device, self.fields.get("*"))
        if name is None:
            raise InputError(f"knob {self.name!r} does not apply to the {device} device; its "
                             f"knobs: {', '.join(knobs_of(device))}")
        return name

    def grid(self, lo: float, hi: float) -> list[float]:
        """The grid on [lo, hi], from the good end to the bad end (module docstring)."""
        values = (np.geomspace(lo, hi, GRID_POINTS) if self.log
                  else np.linspace(lo, hi, GRID_POINTS))
        if self.integer:
            values = np.unique(np.round(values).astype(int))
        out = [int(v) if self.integer else float(v) for v in values]
        return out if self.good == "low" else out[::-1]


KNOBS: dict[str, Knob] = {k.name: k for k in (
    Knob("read_noise", {"crossbar": "read_noise"}, 0.0, 0.5, "low",
         doc="crossbar read_noise: conductance fluctuation per read, std relative to the "
             "conductance range"),
    Knob("prog_noise", {"crossbar": "prog_noise"}, 0.0, 20.0, "low",
         doc="crossbar prog_noise: scale of the programming-noise model (aihwkit "
             "prog_noise_scale)"),
    Knob("levels", {"crossbar": "levels"}, 2, 1001, "high", integer=True, log=True,
         doc="crossbar conductance levels per device"),
    Knob("bits", {"fixed": "bits", "loihi2": "num_weight_bits"}, 2, 16, "high",
         integer=True, doc="fixed: weight mantissa bits (2..16); loihi2: num_weight_bits "
                           "(give --range within 1..8)"),
    Knob("drift_time", {"*": IDLE}, 1.0, 3.15576e9, "low", log=True,
         doc="seconds idle between the end of training and planning (100 years at the "
             "bad end); drifts only a device that drifts"),
    Knob("stuck", {"crossbar": "stuck"}, 0.0, 0.5, "low",
         doc="crossbar fraction of stuck devices, half at g_min (stuck_low) and half at "
             "g_max (stuck_high)"),
    Knob("adc_bits", {"crossbar": "adc_bits"}, 2, 14, "high", integer=True,
         doc="crossbar ADC bits on the outputs"),
)}


def knobs_of(device: str) -> list[str]:
    return [k.name for k in KNOBS.values() if device in k.fields or "*" in k.fields]


def get_knob(name: str) -> Knob:
    if name not in KNOBS:
        raise InputError(f"unknown knob {name!r}; allowed: {', '.join(KNOBS)}")
    return KNOBS[name]


def knob_setting(knob: Knob, device: str, value: float) -> tuple[dict[str, Any], float]:
    """(device options, idle seconds) that set ``knob`` to ``value`` on ``device``."""
    field = knob.field(device)
    if field == IDLE:
        return {}, float(value)
    if field == "stuck":
        return {"stuck_low": value / 2, "stuck_high": value / 2}, 0.0
    return {field: value}, 0.0


def scenario_success(result: dict[str, Any], part: str | None = None) -> float:
    """The worst part's success rate, or the named part's."""
    rates = {p["part"]: p["success_rate"] for p in result["parts"]}
    if part is not None:
        if part not in rates:
            raise InputError(f"scenario {result['scenario']!r} has no part {part!r}; its "
                             f"parts: {', '.join(rates)}")
        return rates[part]
    return min(rates.values())


def bisect(grid: list[float], passes: Callable[[float], bool]
           ) -> tuple[int, int, list[tuple[float, bool]]]:
    """Bisection on ``grid`` (good end first) for the last value that passes: returns
    (last passing index, first failing index, the evaluations in order). The two ends
    are evaluated first; InputError when they do not bracket (the good end fails or the
    bad end passes)."""
    seen: list[tuple[float, bool]] = []

    def check(i: int) -> bool:
        ok = passes(grid[i])
        seen.append((grid[i], ok))
        return ok

    good, bad = check(0), check(len(grid) - 1)
    if not good or bad:
        raise NotBracketedError(seen)
    i, j = 0, len(grid) - 1
    while j - i > 1:
        m = (i + j) // 2
        if check(m):
            i = m
        else:
            j = m
    return i, j, seen


class NotBracketedError(InputError):
    """The range's two ends do not bracket the target."""

    def __init__(self, seen: list[tuple[float, bool]]) -> None:
        super().__init__("range does not bracket the target")
        self.seen = seen


def find_breakpoint(scenario: str, backend: str, knob: str, options: dict[str, Any] | None = None,
                    target: float = 0.95, seeds: int = 3, value_range: tuple[float, float]
                    | None = None, budget: str = "full", part: str | None = None,
                    out: str | Path | None = None, workers: int | None = None,
                    scheduler: str | None = None, command: str | None = None
                    ) -> dict[str, Any]:
    """The break point of ``knob`` for ``scenario`` on ``backend`` (module docstring).
    ``options``: the device's other settings (the knob's field overrides them); ``out``:
    each evaluation's sweep under ``out/KNOB=VALUE`` (resumable)."""
    get(scenario)
    spec = backend_spec(backend)
    device = spec.device.name if spec.device is not None else backend
    k = get_knob(knob)
    if spec.device is not None and k.field(device) in spec.device.fixes(backend):
        raise InputError(f"--backend {backend} fixes {k.field(device)}, the field of knob "
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
    grid = k.grid(lo, hi)
    if len(grid) < 2:
        raise InputError(f"range {lo!r} {hi!r} holds fewer than two values of {knob!r}")
    evaluations: list[dict[str, Any]] = []

    def passes(value: float) -> bool:
        setting, idle = knob_setting(k, device, value)
        res = run_scenario(scenario, backend, {**(options or {}), **setting}, seeds, budget,
                           Path(out) / f"{knob}={value}" if out is not None else None,
                           workers, scheduler, idle_s=idle)
        success = scenario_success(res, part)
        evaluations.append({"value": value, "success_rate": success,
                            "parts": {p["part"]: p["success_rate"] for p in res["parts"]}})
        return success >= target

    try:
        i, j, _ = bisect(grid, passes)
    except NotBracketedError:
        ends = ", ".join(f"{e['value']:g}: success {e['success_rate']:.3f}"
                         for e in evaluations)
        raise InputError(f"the {knob} range {lo:g}..{hi:g} does not bracket target {target} on "
                         f"{scenario} ({ends}; the good end, {k.good}, must reach the target "
                         f"and the other end fall below it)") from None
    return {"scenario": scenario, "backend": backend, "backend_options": dict(options or {}),
            "knob": knob, "field": k.field(device), "good": k.good, "target": target,
            "value": grid[i], "bracket": [grid[i], grid[j]], "range": [lo, hi],
            "grid": grid, "seeds": int(seeds), "seed_list": list(range(int(seeds))),
            "budget": budget, "part": part, "evaluations": evaluations,
            "n_evaluations": len(evaluations), "command": command}
