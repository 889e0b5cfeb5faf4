"""The report's 3-D section: what the third dimension costs (the paper's section 5).

The paper: "The resource requirements of such an upscaling would increase proportionally
with the number of dimensions." Here that is a measured ratio: every system of the budget
again in the 30 x 30 x 30 volume with the 26 king moves (``report["space"]``, measured by
:func:`cml_edge.report.build.build_report`), a table of ratios over the devices, one table
per device (the plane's figures, the volume's and their ratio), the verdicts of the
scorecard's 3-D scenarios (:data:`cml_edge.scenarios.registry.SPACE_SCENARIOS`), and the
report's break points again in the volume beside the plane's. Every number is a cell of
report.json (``space.systems.I.plane.KEY``, ``space.systems.I.space.KEY``,
``space.systems.I.ratio.KEY``, ``space.scorecard.I.KEY``, ``space.breakpoints.I.KEY``).
"""

from __future__ import annotations

from typing import Any

from cml_edge.report.card import KNOB_UNITS, breakpoint_command, breakpoint_table
from cml_edge.report.numbers import human
from cml_edge.report.sections import (
    Section,
    command,
    device_flags,
    report_command,
    seeds_text,
    verdict_table,
)
from cml_edge.report.tables import Cell, Table, at, lookup

FIGURES = (("parameters", "parameters", ""), ("parameter memory", "parameter_bytes", "B"),
           ("training memory", "train_bytes_direct", "B"),
           ("update traffic per run", "update_bytes_per_run_direct", "B"),
           ("device pulses per run", "device_pulses_per_run", "pulses"),
           ("energy per action", "energy_per_action_nj", "nJ"),
           ("energy per training run", "energy_per_run_uj", "uJ"),
           ("steps to converge", "steps_to_converge", ""),
           ("success", "success_rate", "%"),
           ("decision agreement", "decision_agreement", "%"))
"""(row label, key of ``space.systems.I.plane`` / ``.space`` / ``.ratio``, unit)."""
RATIOS = ("parameters", "train_bytes_direct", "update_bytes_per_run_direct",
          "energy_per_action_nj", "energy_per_run_uj", "steps_to_converge")
"""The ratios of the overview table, one column each."""


def _ratio(report: dict[str, Any], i: int, key: str) -> Cell:
    return at(report, f"space.systems.{i}.ratio.{key}", "x")


def space_command(report: dict[str, Any], device: str, scenario: str) -> str | None:
    """The ``cml-edge scenario NAME --dims 3`` command of one device on a 3-D scenario."""
    space = report["space"]
    spec = next(((s["backend"], s.get("options") or {}) for s in space["systems"]
                 if s["label"] == device), None)
    if spec is None:
        return None
    plan = space["scorecard_plan"]
    budget = [] if plan["budget"] == "full" else ["--budget", plan["budget"]]
    return command("scenario", scenario, "--dims", str(space["dims"]), *device_flags(*spec),
                   "--seeds", str(plan["seeds"]), *budget)


def verdicts_3d(report: dict[str, Any]) -> Table:
    """Every device x 3-D scenario: its verdict against float64 in the same volume."""
    return verdict_table(report, "space-verdicts", report["space"]["scorecard"],
                         lambda device, sc: space_command(report, device, sc), "3-D")


def scenario_table(report: dict[str, Any]) -> Table:
    """Each device's success and decision agreement on each part of the 3-D scenarios."""
    table = Table("space-scenarios", ["device", "scenario", "part", "success",
                                      "decision agreement", "weight error", "path overhead"])
    for i, r in enumerate(report["space"]["scorecard"]):
        table.add(r["device"], [r["scenario"], r["part"],
                                at(report, f"space.scorecard.{i}.success_rate", "%"),
                                at(report, f"space.scorecard.{i}.decision_agreement", "%"),
                                at(report, f"space.scorecard.{i}.weight_error"),
                                at(report, f"space.scorecard.{i}.overhead_mean")],
                  space_command(report, r["device"], r["scenario"]))
    return table


def overview(report: dict[str, Any]) -> Table:
    """A row per device: the 3-D / 2-D ratio of each of :data:`RATIOS`."""
    names = dict((key, label) for label, key, _ in FIGURES)
    table = Table("space-ratios", ["device", *(f"{names[k]}, 3-D / 2-D" for k in RATIOS)])
    for i, s in enumerate(report["space"]["systems"]):
        table.add(s["label"], [_ratio(report, i, k) for k in RATIOS],
                  " ".join(device_flags(s["backend"], s["options"])))
    return table


def breakpoint_comparison(report: dict[str, Any]) -> Table:
    """Each break point of the report on the plane and in the volume, side by side (the
    last good value; ``none in range`` where the knob's range does not bracket the
    target)."""
    table = Table("space-breakpoint-pairs", ["device", "knob", "2-D breaks at",
                                             "3-D breaks at", "3-D success at the good end"])
    plane = {(b["device"], b["knob"]): i for i, b in enumerate(report["breakpoints"])}
    for j, b in enumerate(report["space"]["breakpoints"]):
        i = plane.get((b["device"], b["knob"]))
        unit = KNOB_UNITS.get(b["knob"], "")
        cells = [Cell(text="n/a") if i is None else _breaks_at(report, f"breakpoints.{i}", unit),
                 _breaks_at(report, f"space.breakpoints.{j}", unit),
                 at(report, f"space.breakpoints.{j}.evaluations.0.success_rate", "%")]
        table.add(b["device"], [b["knob"], *cells], breakpoint_command(b))
    return table


def _breaks_at(report: dict[str, Any], row: str, unit: str) -> Cell:
    """The last good value of break point ``row``, or ``none in range``."""
    return (at(report, f"{row}.value", unit) if lookup(report, row).get("bracket")
            else Cell(text="none in range"))


def device_table(report: dict[str, Any], i: int) -> Table:
    """One device: each figure on the plane, in the volume, and their ratio."""
    s = report["space"]["systems"][i]
    table = Table(f"space-{s['label']}", ["figure", "2-D (30 x 30)", "3-D (30 x 30 x 30)",
                                          "3-D / 2-D"])
    for label, key, unit in FIGURES:
        if s["plane"].get(key) is None and s["space"].get(key) is None:
            continue  # a figure the device has in neither world (pulses of a digital array)
        table.add(label, [at(report, f"space.systems.{i}.plane.{key}", unit),
                          at(report, f"space.systems.{i}.space.{key}", unit),
                          _ratio(report, i, key)])
    return table


def space(report: dict[str, Any]) -> Section | None:
    """The 3-D section (module docstring); None for a report without one."""
    sp = report.get("space")
    if not sp or not sp.get("systems"):
        return None
    p, plan = report["protocol"], sp["scorecard_plan"]
    blocks: list[str | Table] = [
        "The paper (section 5): the method \"can directly scale up to three dimensions\", "
        "and \"the resource requirements of such an upscaling would increase proportionally "
        "with the number of dimensions\". Measured: the CML observes (x, y, z) (N_i 3 "
        "against 2) and chooses among 26 moves (N_a 26 against 8 on the plane), so its "
        "(N_i + 2 N_a) N_s parameters grow "
        f"{human(sp['systems'][0]['ratio']['parameters'])} times, against the 1.5 of the "
        "dimensions, and every cost that scales with the weights follows them.",
        overview(report)]
    if sp.get("scorecard"):
        blocks += [f"The scorecard's 3-D scenarios ({', '.join(plan['scenarios'])}), "
                   f"{seeds_text(plan['seeds'])} at the `{plan['budget']}` budget, each "
                   "device judged against float64 in the same volume (the thresholds of the "
                   "summary):", verdicts_3d(report), scenario_table(report)]
    if sp.get("breakpoints"):
        blocks += ["The report's break points again in the volume (the paper scenario "
                   "with `--dims 3`, the same knobs, ranges, target and seeds; each row's "
                   "command its tooltip in report.html), beside the plane's:",
                   breakpoint_comparison(report), "In full, as the plane's are shown:",
                   breakpoint_table(report, "space.breakpoints", "space-breakpoints")]
    for i, s in enumerate(sp["systems"]):
        blocks += [f"**{s['label']}** (`{' '.join(device_flags(s['backend'], s['options']))}`)",
                   device_table(report, i)]
    return Section("space", "3-D: what the third dimension costs", (
        f"Each device on the budget's protocol twice, on the {p['arena']} x {p['arena']} "
        f"plane and in the {sp['arena']} x {sp['arena']} x {sp['arena']} volume with "
        f"{sp['moves']} moves ({p['walks']} walks x {p['steps']} steps, "
        f"{seeds_text(p['seeds'])} x {p['trials']} pairs, as `cml-edge emulate --dims "
        f"{sp['dims']}` runs it); memory, traffic and energy from one more model's counters "
        f"(seed 0); `{report_command(report)}`."), blocks)
