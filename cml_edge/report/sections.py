"""What the report says, section by section, as prose and :class:`~cml_edge.report.tables.Table`
data that :mod:`~cml_edge.report.render` (report.md) and :mod:`~cml_edge.report.page`
(report.html) render.

Every section names the command and the seeds that made it; every number in a table is
a cell read from the report's JSON (its path kept), so report.md and report.html show the
same numbers, formatted once (:func:`~cml_edge.report.numbers.human`). The scorecard's
sections are in :mod:`~cml_edge.report.card`.
"""

from __future__ import annotations

import shlex
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from cml_edge.report.numbers import human
from cml_edge.report.tables import Cell, Table, at
from cml_edge.report.verdict import LEVELS, THRESHOLDS, device_verdicts, scenario_verdicts

DQN_REFERENCE = "DQN-goal-conditioned"
"""The DQN the CML's costs stand against: like the CML, it plans to any goal."""


@dataclass
class Section:
    """A titled part of the report: ``made_by`` names its command and seeds; ``blocks``
    are paragraphs (strings, with ``code`` in backticks) and tables, in order."""

    key: str
    title: str
    made_by: str
    blocks: list[str | Table] = field(default_factory=list)


def seeds_text(n: int) -> str:
    """``seeds 0-9``, ``seed 0``."""
    return "seed 0" if n == 1 else f"seeds 0-{n - 1}"


def device_flags(backend: str, options: dict[str, Any]) -> list[str]:
    """The command-line options that select a device: ``--backend``, ``--preset``, then
    ``--set FIELD=VALUE`` for each other option."""
    flags = ["--backend", backend]
    for k, v in options.items():
        flags += ["--preset", str(v)] if k == "preset" else ["--set", f"{k}={v}"]
    return flags


def command(*argv: str) -> str:
    return shlex.join(["cml-edge", *argv])


def report_command(report: dict[str, Any]) -> str:
    return report["command"]


def systems_by_label(report: dict[str, Any]) -> dict[str, int]:
    """Each system's label -> its index in ``systems`` (its cells' paths)."""
    return {s["label"]: i for i, s in enumerate(report["systems"])}


# the summary ----------------------------------------------------------------------------
def verdict_table(report: dict[str, Any], key: str, rows: list[dict[str, Any]] | None = None,
                  command_of: Callable[[str, str], str | None] | None = None,
                  tag: str = "") -> Table:
    """Every device x scenario of the scorecard (or of ``rows``, each scenario's column
    and cell key marked ``tag``, each cell's command ``command_of(device, scenario)``):
    its verdict, coloured, the reason named."""
    rows = report["scorecard"] if rows is None else rows
    verdicts = scenario_verdicts(rows)
    scenarios = list(dict.fromkeys(r["scenario"] for r in rows))
    table = Table(key, ["device", *(f"{sc}{tag and f' ({tag})'}" for sc in scenarios)])
    if command_of is None:
        def command_of(device: str, sc: str) -> str | None:
            return scenario_command(report, device, sc, report["scorecard_plan"])
    for device in dict.fromkeys(r["device"] for r in rows):
        cells: list[Cell | str] = []
        for sc in scenarios:
            v = verdicts.get((device, sc))
            cells.append("n/a" if v is None else Cell(
                text=v.text(), verdict=v.level, key=f"{device}|{sc}{tag and f'|{tag}'}",
                title=command_of(device, sc)))
        table.add(device, cells)
    return table


def scenario_command(report: dict[str, Any], device: str, scenario: str,
                     plan: dict[str, Any]) -> str | None:
    """The ``cml-edge scenario`` command that measures one device on one scenario."""
    spec = next(((s["backend"], s.get("options") or {}) for s in report["systems"]
                 if s["label"] == device and s["kind"] == "cml"), None)
    if spec is None:
        return None
    budget = [] if plan["budget"] == "full" else ["--budget", plan["budget"]]
    return command("scenario", scenario, *device_flags(*spec), "--seeds", str(plan["seeds"]),
                   *budget)


def cost_table(report: dict[str, Any]) -> Table:
    """Each system's costs, and the DQN's training energy over the CML's."""
    index = systems_by_label(report)
    dqn = index.get(DQN_REFERENCE)
    table = Table("cost", ["system", "energy per training run", f"{DQN_REFERENCE} / this",
                           "energy per action", "parameter memory", "training memory"])
    for s in report["systems"]:
        i = index[s["label"]]
        run = f"systems.{i}.energy_per_run_uj"
        ratio: Cell | str = "n/a"
        if dqn is not None and s["kind"] == "cml" and s.get("energy_per_run_uj"):
            num = f"systems.{dqn}.energy_per_run_uj"
            ratio = Cell(report["systems"][dqn]["energy_per_run_uj"] / s["energy_per_run_uj"],
                         "x", of=f"{num} / {run}")
        table.add(s["label"], [at(report, run, "uJ"), ratio,
                               at(report, f"systems.{i}.energy_per_action_nj", "nJ"),
                               at(report, f"systems.{i}.parameter_bytes", "B"),
                               at(report, f"systems.{i}.train_bytes_direct", "B")])
    return table


def _listing(devices: dict[str, Any], level: str) -> str:
    names = [d for d, v in devices.items() if v.level == level]
    return ", ".join(names) if names else "none"


def summary(report: dict[str, Any]) -> Section:
    """The verdicts and the costs, at a glance."""
    plan, prot = report["scorecard_plan"], report["protocol"]
    worst = device_verdicts(report["scorecard"])
    n = len(plan["scenarios"])
    text = [f"**Survive all {n} workloads**: {_listing(worst, LEVELS[0])}. "
            f"**Degrade on at least one**: {_listing(worst, LEVELS[1])}. "
            f"**Fail at least one**: {_listing(worst, LEVELS[2])}.",
            "A device is judged against float64 on the same workload (scenario part), so a "
            "workload that defeats the navigator itself does not count against the device; "
            "a scenario's verdict is its worst part's. Thresholds: "
            + "; ".join(f"{what}: {rule}" for what, rule in THRESHOLDS) + "."]
    energies = [(s["energy_per_run_uj"], s["label"]) for s in report["systems"]
                if s["kind"] == "cml" and s.get("energy_per_run_uj")]
    dqn = next((s for s in report["systems"] if s["label"] == DQN_REFERENCE), None)
    if energies and dqn is not None:
        lo, hi = min(energies), max(energies)
        text.append(f"A training run costs {human(lo[0], 'uJ')} ({lo[1]}) to "
                    f"{human(hi[0], 'uJ')} ({hi[1]}) on the CML's devices, against "
                    f"{human(dqn['energy_per_run_uj'], 'uJ')} for the {DQN_REFERENCE} (which, "
                    "like the CML, plans to any goal).")
    return Section("summary", "At a glance", (
        f"Verdicts: the scorecard, {n} scenarios on {seeds_text(plan['seeds'])} at the "
        f"`{plan['budget']}` budget; costs: the budget, {seeds_text(prot['seeds'])}; "
        f"`{report_command(report)}`."),
        [*text, verdict_table(report, "verdicts"), cost_table(report)])


# the budget ------------------------------------------------------------------------------
def _traffic(report: dict[str, Any], i: int) -> Cell:
    s = report["systems"][i]
    if s.get("device_pulses_per_run") is not None:  # the crossbar moves pulses, not bytes
        return at(report, f"systems.{i}.device_pulses_per_run", "pulses")
    return at(report, f"systems.{i}.update_bytes_per_run_direct", "B")


def budget(report: dict[str, Any]) -> Section:
    """Accuracy, memory, traffic, energy and convergence of every system."""
    p = report["protocol"]
    main = Table("budget", ["system", "success", "path overhead", "parameter memory",
                            "training memory", "update traffic per run", "energy per run",
                            "energy per action", "steps to converge"])
    per = Table("per-action", ["system", "FLOPs per action (paper formula)",
                               "FLOPs per action (counted)", "update traffic per step",
                               "traffic per run, factored", "cells changed per run",
                               "training wall time"])
    for i, s in enumerate(report["systems"]):
        def cell(key: str, unit: str = "", i: int = i) -> Cell:
            return at(report, f"systems.{i}.{key}", unit)

        title = None if s["kind"] != "cml" else shlex.join(device_flags(s["backend"],
                                                                        s["options"]))
        main.add(s["label"], [cell("success_rate", "%"), cell("overhead_mean"),
                              cell("parameter_bytes", "B"), cell("train_bytes_direct", "B"),
                              _traffic(report, i), cell("energy_per_run_uj", "uJ"),
                              cell("energy_per_action_nj", "nJ"), cell("steps_to_converge")],
                 title)
        per.add(s["label"], [cell("inference_flops_formula"), cell("inference_flops_counted"),
                             cell("update_bytes_per_step_direct", "B"),
                             cell("update_bytes_per_run_factored", "B"),
                             cell("cells_changed_per_run"), cell("train_wall_s", "s")], title)
    dqn = report["dqn_results_file"]
    return Section("budget", "The budget", (
        f"Each CML row: {p['arena']} x {p['arena']} arena, {p['walks']} walks x {p['steps']} "
        f"steps, {seeds_text(p['seeds'])} x {p['trials']} (start, goal) pairs from evaluation "
        f"seed {p['eval_seed']}, at most {p['max_steps']} actions, on its synaptic array "
        "through the direct compiled path; memory, traffic and energy from the array's "
        f"counters of one more model (seed 0); `{report_command(report)}`. DQN rows: the "
        "ledger from the network's layer sizes and training settings, accuracy from "
        + (f"`{dqn}` (`cml-edge dqn train`)." if dqn else "no results file (n/a: run "
           "`cml-edge dqn train`).")), [
        main,
        "Success: the share of the pairs whose goal was reached. Path overhead: steps over "
        "the Chebyshev distance, mean over the successes. Training memory: CML, the "
        "weights plus the per-walk update accumulator at the array's accumulator width; "
        "DQN, online and target networks, gradients, two Adam moments, the replay buffer "
        "and the minibatch activations. Update traffic per run: CML, the bytes the array "
        "read and wrote while learning (the crossbar moves device pulses instead); DQN, "
        "replay and weight, gradient and optimizer traffic. Energy: the array's counters "
        "times sourced per-operation constants (below); n/a where no sourced figure exists "
        "(float64) or the baseline was not run. Steps to converge: e_pos stays within half "
        "a cell of its final value, the same criterion for the CML and the DQN.",
        per,
        "FLOPs counted: two per multiply-accumulate the array performed while planning, per "
        "planning step (zero inputs are skipped, so this can be below the formula). "
        "Factored: 60 accumulators per walk and one read and one write of each matrix per "
        "walk, the schedule a chip could run instead of touching every synapse every step."])


def sweeps(report: dict[str, Any]) -> Section | None:
    """The precision and noise sweeps."""
    if not report["sweeps"]:
        return None
    table = Table("sweeps", ["configuration", "sweep", "seeds", "success", "e_pos mean",
                             "path overhead"])
    for i, s in enumerate(report["sweeps"]):
        table.add(s["label"], [s["figure"], at(report, f"sweeps.{i}.seeds"),
                               at(report, f"sweeps.{i}.success_rate", "%"),
                               at(report, f"sweeps.{i}.e_pos_mean"),
                               at(report, f"sweeps.{i}.overhead_mean")],
                  shlex.join(device_flags(s["backend"], s["options"])))
    n = report["sweeps"][0]["seeds"]
    return Section("sweeps", "Precision and noise sweeps", (
        f"The budget's protocol on {seeds_text(n)} per configuration; "
        f"`{report_command(report)}`."), [table])


def constants(report: dict[str, Any]) -> Section:
    """The sourced energy constants."""
    table = Table("constants", ["constant", "energy", "per", "source"])
    for i, c in enumerate(report["costs"]):
        table.add(c["name"], [at(report, f"costs.{i}.pj", "pJ"), c["per"], c["source"]])
    return Section("constants", "Energy constants", (
        "Each constant with its source (`cml_edge/costs/ledger.py`); the energy of a row is "
        "its counters times these."), [table])
