"""The reference report's figures beside a run's: how far the reference devices are from
their float64 twins on the same protocol.

The committed reference report (:data:`REFERENCE_REPORT`, ``cml-edge report --out
hw_reports/reference``) measures every device of the report on the scorecard's ``paper``
scenario: the paper's protocol on model seeds 0-2. A run of ``cml-edge emulate`` on that
protocol (whatever its seeds) is comparable: :func:`context` gives the reference devices'
figures (:data:`ANCHORS`, and the run's own device where the report has it), float64's
success and overhead to judge the run against, and the run's own mean over the
reference's seeds (0-2), so that a reader sees how much of a 10-seed figure's distance
from the reference's is the seeds it adds. The scorecard's models are its own: on the
same protocol and the same seed numbers they need not be ``emulate``'s.
"""

from __future__ import annotations

import json
from functools import lru_cache
from pathlib import Path
from typing import Any

from cml_edge.grid.planning import MAX_STEPS
from cml_edge.protocol import EVAL_SEED
from cml_edge.report.verdict import BASELINE
from cml_edge.scenarios.registry import BUDGETS

REFERENCE_REPORT = Path(__file__).resolve().parents[2] / "hw_reports" / "reference" / \
    "report.json"
"""The committed reference report (in a source checkout; a run without it gets no
reference figures)."""
ANCHORS = ("float32", "int8", "crossbar-pcm")
"""The reference devices every figure stands beside: the best digital device, the coarsest
digital one, the calibrated PCM crossbar."""
SCENARIO = "paper"
"""The scorecard scenario that is the paper's protocol (:mod:`cml_edge.scenarios`)."""
_FULL = BUDGETS["full"]
PROTOCOL = {"arena": 30, "eval_arena": 30, "walks": _FULL.walks, "steps": _FULL.steps,
            "trials": _FULL.trials, "eval_seed": EVAL_SEED, "explore": "random",
            "schedule": "walk", "planner": "paper", "obstacles": 0, "idle_s": 0.0,
            "utility": "normalized", "max_steps": MAX_STEPS, "map": None, "dims": 2,
            "moves": "king"}
"""The settings of the ``paper`` scenario as ``emulate``'s JSON names them."""


@lru_cache(maxsize=4)
def _load(path: str) -> dict[str, Any] | None:
    p = Path(path)
    return json.loads(p.read_text()) if p.is_file() else None


def reference_report(path: str | Path = REFERENCE_REPORT) -> dict[str, Any] | None:
    """The reference report's JSON (read once), or None where it is not there."""
    return _load(str(path))


def differences(result: dict[str, Any]) -> list[str]:
    """The settings of an ``emulate`` result that differ from the paper's protocol, each
    ``name value (reference: value)``."""
    return [f"{k} {result.get(k)} (reference: {v})" for k, v in PROTOCOL.items()
            if result.get(k, v) != v]


def _normal(backend: str, options: dict[str, Any] | None) -> tuple[str, str]:
    """(backend, options) comparable across spellings: the default preset named."""
    from cml_edge.backends import BACKENDS

    options = dict(options or {})
    spec = BACKENDS.get(backend)
    if "preset" not in options and spec is not None and spec.device is not None:
        preset = spec.device.default_preset(backend)
        if preset is not None:
            options["preset"] = preset
    return backend, json.dumps(options, sort_keys=True)


def label_of(report: dict[str, Any], backend: str, options: dict[str, Any] | None) -> str | None:
    """The label the report gives the device ``backend`` with ``options``, or None."""
    want = _normal(backend, options)
    return next((s["label"] for s in report["systems"] if s["kind"] == "cml"
                 and _normal(s["backend"], s.get("options")) == want), None)


def seed_mean(result: dict[str, Any], key: str, seeds: list[int]) -> float | None:
    """The mean of a per-seed figure (``decision_agreement``, ``weight_error``) of an
    ``emulate`` result over ``seeds``; None unless it has every one of them."""
    per = {s["seed"]: s.get(key) for s in result.get("per_seed") or []}
    values = [per.get(s) for s in seeds]
    values = [v.get("matrix_mean") if isinstance(v, dict) else v for v in values]
    if any(v is None for v in values):
        return None
    return sum(values) / len(values)


def context(result: dict[str, Any], report: dict[str, Any] | None = None
            ) -> dict[str, Any] | None:
    """The reference figures an ``emulate`` result stands beside: ``seeds`` (the
    reference's), ``own`` (the run's device's label there, or None), ``rows`` (label ->
    the reference's ``paper`` row, the run's device first), ``baseline`` (float64's row),
    ``on_seeds`` (the run's own ``weight_error`` and ``decision_agreement`` over the
    reference's seeds, where it ran more seeds than those and all of them), ``differs``
    (:func:`differences`: when not empty, the rows are not comparable and are empty);
    None without a reference report."""
    report = reference_report() if report is None else report
    if report is None:
        return None
    rows = {r["device"]: r for r in report["scorecard"] if r["scenario"] == SCENARIO}
    own = label_of(report, result["backend"], result.get("backend_options"))
    differs = differences(result)
    shown = [] if differs else [d for d in dict.fromkeys([own, *ANCHORS]) if d in rows]
    seeds = list(range(report["scorecard_plan"]["seeds"]))
    more = not differs and len(result.get("per_seed") or []) > len(seeds)
    on_seeds = {k: seed_mean(result, k, seeds) for k in ("weight_error", "decision_agreement")
                } if more else {}
    return {"seeds": seeds, "own": own, "rows": {d: rows[d] for d in shown},
            "baseline": rows.get(BASELINE), "on_seeds": on_seeds, "differs": differs,
            "source": "reference report"}
