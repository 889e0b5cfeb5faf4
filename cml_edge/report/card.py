"""The scorecard's sections of the report: the verdicts, every device on every scenario,
the break points, recovery (:mod:`cml_edge.report.scorecard` measures them)."""

from __future__ import annotations

from typing import Any

from cml_edge.report.numbers import human
from cml_edge.report.sections import (
    Section,
    command,
    device_flags,
    report_command,
    scenario_command,
    seeds_text,
    verdict_table,
)
from cml_edge.report.tables import Cell, Table, at, lookup
from cml_edge.report.verdict import part_verdicts
from cml_edge.scenarios.breakpoint import largest_rise


def scorecard(report: dict[str, Any]) -> Section:
    """The verdicts, then one table per scenario: a row per device and part."""
    from cml_edge.scenarios import SCENARIOS

    rows, plan = report["scorecard"], report["scorecard_plan"]
    verdicts = part_verdicts(rows)
    blocks: list[str | Table] = [verdict_table(report, "scorecard-verdicts")]
    for scenario in dict.fromkeys(r["scenario"] for r in rows):
        table = Table(f"scenario-{scenario}", ["device", "part", "success", "decision agreement",
                                               "weight error", "path overhead", "verdict"])
        for i, r in enumerate(rows):
            if r["scenario"] != scenario:
                continue
            v = verdicts.get((r["device"], scenario, r["part"]))
            table.add(r["device"], [
                r["part"], at(report, f"scorecard.{i}.success_rate", "%"),
                at(report, f"scorecard.{i}.decision_agreement", "%"),
                at(report, f"scorecard.{i}.weight_error"),
                at(report, f"scorecard.{i}.overhead_mean"),
                "n/a" if v is None else Cell(text=v.text(), verdict=v.level,
                                             key=f"{r['device']}|{scenario}|{r['part']}")],
                scenario_command(report, r["device"], scenario, plan))
        doc = SCENARIOS[scenario].doc if scenario in SCENARIOS else ""
        blocks += [f"**{scenario}**. {doc}", table]
    return Section("scorecard", "The scorecard: every device on every scenario", (
        f"Each device runs each scenario on {seeds_text(plan['seeds'])} at the "
        f"`{plan['budget']}` budget, as `cml-edge scenario NAME --backend ... --seeds "
        f"{plan['seeds']}` does (each row's command is its tooltip in report.html); "
        f"`{report_command(report)}`. Success saturates on the easy parts, so the decision "
        "agreement (the share of planning decisions at which the float64 twin, trained on "
        "the same walks from the same seed, picks the same move) and the weight error (the "
        "three matrices' mean relative Frobenius error against that twin) rank the devices "
        "there. Seed spreads are in report.json."), blocks)


KNOB_UNITS = {"drift_time": "s", "stuck": "%"}
"""The unit a knob's value reads in (:func:`~cml_edge.report.numbers.human`): the others
are plain numbers (read noise, levels, bits)."""


def breakpoint_command(b: dict[str, Any]) -> str:
    """The ``cml-edge breakpoint`` command of one break point of the report."""
    budget = [] if b["budget"] == "full" else ["--budget", b["budget"]]
    dims = [] if b.get("dims") is None else ["--dims", str(b["dims"])]
    return command("breakpoint", *device_flags(b["backend"], b.get("options") or {}),
                   "--knob", b["knob"], "--scenario", b["scenario"], *dims, "--target",
                   f"{b['target']:g}", "--seeds", str(b["seeds"]), *budget)


def breakpoint_table(report: dict[str, Any], key: str, name: str) -> Table:
    """Table ``name`` of the break points at ``key`` of the report (``breakpoints``, or the
    3-D section's ``space.breakpoints``): where each knob breaks, or that it does not within
    its range, the knob's two ends and the success there (the first two evaluations), and
    the largest rise in success toward the bad end among the evaluations
    (:func:`~cml_edge.scenarios.breakpoint.largest_rise`; the bisection assumes none)."""
    table = Table(name, ["device", "knob", "breaks at (last good)", "first bad", "good end",
                         "success there", "bad end", "success there", "evaluations",
                         "largest rise toward the bad end", "between"])
    for i, b in enumerate(lookup(report, key)):
        unit = KNOB_UNITS.get(b["knob"], "")
        row = f"{key}.{i}"
        if b.get("bracket"):
            found = [at(report, f"{row}.value", unit), at(report, f"{row}.bracket.1", unit)]
        else:
            found = [Cell(text="none in range"), Cell(text="none")]
        ends = [at(report, f"{row}.evaluations.{e}.{k}", u)
                for e in (0, 1) for k, u in (("value", unit), ("success_rate", "%"))]
        table.add(b["device"], [b["knob"], *found, *ends, at(report, f"{row}.n_evaluations"),
                                *_rise(b, row, unit)], breakpoint_command(b))
    return table


def _rise(b: dict[str, Any], row: str, unit: str) -> list[Cell]:
    """The largest rise of break point ``b`` (at ``row``) toward the bad end, computed from
    its two evaluations' success, and between which knob values."""
    rise = largest_rise(b["evaluations"])
    if rise is None:
        return [Cell(text="none"), Cell(text="")]
    values = [e["value"] for e in b["evaluations"]]
    lo, hi = (f"{row}.evaluations.{values.index(rise[k])}.success_rate" for k in ("from", "to"))
    return [Cell(rise["by"], "%", of=f"{hi} - {lo}", text="+" + human(rise["by"], "%")),
            Cell(text=f"{human(rise['from'], unit)} to {human(rise['to'], unit)}")]


def breakpoints(report: dict[str, Any]) -> Section:
    """Where each knob breaks the paper scenario (:func:`breakpoint_table`)."""
    plan = report["scorecard_plan"]
    return Section("breakpoints", "Break points", (
        f"The knob value at which the scenario's success (its worst part) last meets the "
        f"target {Cell(plan['target'], '%').shown()}, by bisection on a 17-point seeded grid "
        f"from the knob's good end, {seeds_text(plan['breakpoint_seeds'])} at the "
        f"`{plan['budget']}` budget (`cml-edge breakpoint --knob KNOB --scenario paper`: "
        f"each row's command is its tooltip in report.html); `{report_command(report)}`. "
        "none in range: the knob's physical range does not bracket the target (the success "
        "at its two ends says which way). Bisection assumes success falls from the good end "
        "to the bad one; the last two columns name the largest rise toward the bad end among "
        "the values evaluated, where it did not (none: it fell throughout)."),
        [breakpoint_table(report, "breakpoints", "breakpoints")])


def recovery(report: dict[str, Any]) -> Section | None:
    """Relearning in place after a year of drift, and the DQN's estimate to retrain."""
    rec = report["recovery"]
    if not rec:
        return None
    table = Table("recovery", ["device", "walks K", "success", "decision agreement",
                               "weight error", "pulses", "cells written", "energy"])
    for i, r in enumerate(rec):
        table.add(r["device"], [at(report, f"recovery.{i}.{k}", u) for k, u in (
            ("walks", ""), ("success_rate", "%"), ("decision_agreement", "%"),
            ("weight_error", ""), ("pulses", ""), ("writes", ""), ("energy_uJ", "uJ"))])
    blocks: list[str | Table] = [table]
    dqn = report.get("dqn_retrain") or {}
    if dqn.get("available"):
        est = Table("dqn-retrain", ["DQN configuration", "bound", "environment steps",
                                    "gradient steps", "MACs", "energy"])
        for i, c in enumerate(dqn["configs"]):
            for bound, key in (("lower: replay refill", "replay_refill"),
                               ("upper: from scratch", "to_converge")):
                if c.get(key):
                    base = f"dqn_retrain.configs.{i}.{key}"
                    est.add(c["config"], [bound, *(at(report, f"{base}.{k}", u) for k, u in (
                        ("env_steps", ""), ("gradient_steps", ""), ("macs", ""),
                        ("energy_uJ", "uJ")))])
        blocks += ["A DQN cannot relearn this way on a chip: it needs its replay buffer and "
                   f"gradient steps. Its cost to retrain, estimated ({dqn['method']}):", est]
    seeds = rec[0]["seeds"]
    return Section("recovery", "Recovery: relearning on the chip after a year of drift", (
        f"K self-supervised walks of in-situ relearning (the local rule, each update applied "
        f"on the device) after a year idle, the `recovery` scenario on {seeds_text(seeds)}; "
        f"what the relearning cost the arrays (seed means; energy n/a where the technology "
        f"has no sourced figure); `{report_command(report)}`."), blocks)
