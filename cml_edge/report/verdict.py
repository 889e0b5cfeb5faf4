"""Verdicts: does a device survive a workload, degrade on it, or fail it, and on what.

A device is judged against float64 on the same workload (the same scenario part, or the
same protocol), so a workload that defeats the navigator itself (the maze: 41 % of the
goals in float64) does not count against the device. Three figures, each with documented
thresholds (:data:`SUCCESS_LOSS_DEGRADES` ...):

- **success**: the share of the goals reached, in points below float64's;
- **overhead**: the mean path overhead of the successes over float64's;
- **agreement**: the decision agreement with the float64 twin (a device may reach every
  goal by other moves; below the threshold it plans as another navigator would).

The worst figure decides; agreement alone degrades a device, never fails it (the goals are
still reached). A scenario's verdict is its worst part's, named (``10y``).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

from cml_edge.report.numbers import human

LEVELS = ("survives", "degrades", "fails")
"""The verdicts, best first (a verdict's index is its severity)."""
SUCCESS_LOSS_DEGRADES = 0.02
"""Success more than 2 points below float64's: beyond the spread of 3 seeds x 100 pairs
(a binomial standard error of 1.3 points at 95 % success)."""
SUCCESS_LOSS_FAILS = 0.10
"""More than 10 points below: one goal in ten that float64 reaches is lost."""
OVERHEAD_DEGRADES = 1.10
"""Paths 10 % longer than float64's: a tenth more steps, time and energy per goal."""
OVERHEAD_FAILS = 1.50
"""Paths half again as long as float64's: the navigator wanders."""
AGREEMENT_DEGRADES = 0.75
"""Fewer than three decisions in four as the twin's: below every device of the reference
report on the paper's protocol (the lowest, int8, agrees on 82 %)."""
BASELINE = "float64"
"""The device every other one is judged against, on the same workload."""


@dataclass(frozen=True)
class Verdict:
    """A verdict (one of :data:`LEVELS`), the figures that decided it (``reasons``, each
    a short phrase) and the part of the scenario it was decided on (None: the only one)."""

    level: str
    reasons: tuple[str, ...] = ()
    part: str | None = None

    @property
    def severity(self) -> int:
        return LEVELS.index(self.level)

    def because(self) -> str:
        """``agreement 67.4 % (10y)``: why, or "" for a device that survives."""
        if not self.reasons:
            return ""
        return "; ".join(self.reasons) + (f" ({self.part})" if self.part else "")

    def text(self) -> str:
        """``degrades: agreement 67.4 % (10y)``, or ``survives``."""
        why = self.because()
        return f"{self.level}: {why}" if why else self.level


def judge(success: float | None, overhead: float | None = None,
          agreement: float | None = None, base_success: float = 1.0,
          base_overhead: float | None = 1.0) -> Verdict | None:
    """The verdict of one measurement against float64's on the same workload
    (``base_success``, ``base_overhead``); None where success is unknown."""
    if success is None:
        return None
    found: list[tuple[int, str]] = []
    loss = base_success - success
    if loss > SUCCESS_LOSS_DEGRADES:
        found.append((2 if loss > SUCCESS_LOSS_FAILS else 1,
                      f"success {human(success, '%')} (float64 {human(base_success, '%')})"))
    if overhead is not None and base_overhead:
        ratio = overhead / base_overhead
        if ratio > OVERHEAD_DEGRADES:
            found.append((2 if ratio > OVERHEAD_FAILS else 1,
                          f"overhead {human(overhead)} (float64 {human(base_overhead)})"))
    if agreement is not None and agreement < AGREEMENT_DEGRADES:
        found.append((1, f"agreement {human(agreement, '%')}"))
    if not found:
        return Verdict(LEVELS[0])
    worst = max(level for level, _ in found)
    return Verdict(LEVELS[worst], tuple(why for level, why in found if level == worst))


def judge_row(row: dict[str, Any], base: dict[str, Any] | None) -> Verdict | None:
    """The verdict of a scorecard row against float64's row of the same part (None: judged
    against a navigator that reaches every goal on the shortest path)."""
    base = base or {"success_rate": 1.0, "overhead_mean": 1.0}
    return judge(row["success_rate"], row.get("overhead_mean"), row.get("decision_agreement"),
                 base["success_rate"] if base["success_rate"] is not None else 1.0,
                 base.get("overhead_mean"))


def worst(verdicts: Iterable[Verdict | None]) -> Verdict | None:
    """The most severe of ``verdicts`` (the first of equals); None if there is none."""
    found = [v for v in verdicts if v is not None]
    return max(found, key=lambda v: v.severity) if found else None


def part_verdicts(scorecard: list[dict[str, Any]]) -> dict[tuple[str, str, str], Verdict]:
    """The verdict of every (device, scenario, part) of a scorecard, each part named."""
    base = {(r["scenario"], r["part"]): r for r in scorecard if r["device"] == BASELINE}
    out = {}
    for r in scorecard:
        v = judge_row(r, base.get((r["scenario"], r["part"])))
        if v is not None:
            part = None if r["part"] == r["scenario"] else r["part"]
            out[r["device"], r["scenario"], r["part"]] = Verdict(v.level, v.reasons, part)
    return out


def scenario_verdicts(scorecard: list[dict[str, Any]]) -> dict[tuple[str, str], Verdict]:
    """The verdict of every (device, scenario): its worst part's."""
    grouped: dict[tuple[str, str], list[Verdict]] = {}
    for (device, scenario, _), v in part_verdicts(scorecard).items():
        grouped.setdefault((device, scenario), []).append(v)
    return {key: worst(vs) for key, vs in grouped.items()}


def device_verdicts(scorecard: list[dict[str, Any]]) -> dict[str, Verdict]:
    """Each device's worst verdict over every scenario."""
    grouped: dict[str, list[Verdict]] = {}
    for (device, _), v in scenario_verdicts(scorecard).items():
        grouped.setdefault(device, []).append(v)
    return {device: worst(vs) for device, vs in grouped.items()}


THRESHOLDS = (
    ("success", f"survives within {human(100 * SUCCESS_LOSS_DEGRADES)} points of float64's, "
     f"degrades within {human(100 * SUCCESS_LOSS_FAILS)}, fails beyond"),
    ("overhead", f"survives up to {human(OVERHEAD_DEGRADES)} x float64's, degrades up to "
     f"{human(OVERHEAD_FAILS)} x, fails beyond"),
    ("agreement", f"degrades below {human(AGREEMENT_DEGRADES, '%')} (never fails alone: the "
     "goals are still reached)"),
)
"""The thresholds in words, for the pages that show verdicts."""
