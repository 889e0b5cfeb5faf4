"""Two reports side by side (``cml-edge report --compare OLD``): what changed.

Rows are matched by what they measure (a system by its label; a scorecard row by device,
scenario and part; a break point by device, knob and scenario), so two chips, two
versions or two budgets compare figure by figure. A figure has changed when the two
differ by more than a seed promises across machines (:mod:`cml_edge.core.machines`); each
change shows the old value, the new one (highlighted) and the difference. A row only one
report has is listed as added or removed.
"""

from __future__ import annotations

from typing import Any

from cml_edge.core.machines import ABS, REL
from cml_edge.report.numbers import human
from cml_edge.report.sections import Section
from cml_edge.report.tables import Cell, Table
from cml_edge.report.verdict import scenario_verdicts

SYSTEM_FIGURES = (("success_rate", "success", "%"), ("overhead_mean", "path overhead", ""),
                  ("parameter_bytes", "parameter memory", "B"),
                  ("train_bytes_direct", "training memory", "B"),
                  ("energy_per_run_uj", "energy per run", "uJ"),
                  ("energy_per_action_nj", "energy per action", "nJ"),
                  ("steps_to_converge", "steps to converge", ""))
CARD_FIGURES = (("success_rate", "success", "%"),
                ("decision_agreement", "decision agreement", "%"),
                ("weight_error", "weight error", ""), ("overhead_mean", "path overhead", ""))


def changed(a: Any, b: Any) -> bool:
    """Whether two figures differ beyond the cross-machine tolerance."""
    if isinstance(a, (int, float)) and isinstance(b, (int, float)):
        return abs(a - b) > REL * max(abs(a), abs(b)) + ABS
    return a != b


def _index(rows: list[dict[str, Any]], keys: tuple[str, ...]) -> dict[tuple, int]:
    return {tuple(r[k] for k in keys): i for i, r in enumerate(rows)}


def _diff(a: Any, b: Any, old_path: str, new_path: str, unit: str) -> list[Cell]:
    """Old, new (highlighted) and their difference."""
    cells = [Cell(a, unit, path=old_path), Cell(b, unit, path=new_path, changed=True)]
    if isinstance(a, (int, float)) and isinstance(b, (int, float)):
        d = b - a
        return [*cells, Cell(d, unit, of=f"{new_path} - {old_path}",
                             text=("+" if d > 0 else "") + human(d, unit))]
    return [*cells, Cell(text="")]


def _figure_rows(table: Table, new: dict[str, Any], old: dict[str, Any], section: str,
                 keys: tuple[str, ...], figures: tuple[tuple[str, str, str], ...]) -> None:
    """A row per changed figure of the rows both reports have, and a row per row only
    one of them has (added, removed)."""
    mine, theirs = _index(new[section], keys), _index(old[section], keys)
    for key in dict.fromkeys([*mine, *theirs]):
        i, j = mine.get(key), theirs.get(key)
        where = " ".join(map(str, key[1:]))
        if i is None or j is None:
            table.add(key[0], [where, "added" if j is None else "removed", "", "", ""])
            continue
        for field, name, unit in figures:
            a, b = old[section][j].get(field), new[section][i].get(field)
            if changed(a, b):
                table.add(key[0], [where, name, *_diff(a, b, f"old:{section}.{j}.{field}",
                                                       f"{section}.{i}.{field}", unit)])


def comparison(new: dict[str, Any], old: dict[str, Any], old_name: str) -> Section:
    """The section of what changed from report ``old`` (folder ``old_name``) to ``new``."""
    before, after = scenario_verdicts(old["scorecard"]), scenario_verdicts(new["scorecard"])
    verdicts = Table("changes-verdicts", ["device", "scenario", "before", "now"])
    for key in dict.fromkeys([*after, *before]):
        a, b = before.get(key), after.get(key)
        if a is None or b is None or a.level != b.level:
            verdicts.add(key[0], [key[1], _verdict(a), _verdict(b, changed=True)])
    figures = Table("changes-figures", ["row", "where", "figure", "before", "now",
                                       "change"])
    _figure_rows(figures, new, old, "systems", ("label",), SYSTEM_FIGURES)
    _figure_rows(figures, new, old, "scorecard", ("device", "scenario", "part"), CARD_FIGURES)
    _figure_rows(figures, new, old, "breakpoints", ("device", "knob", "scenario"),
                 (("value", "breaks at", ""),))
    blocks: list[str | Table] = [
        f"{len(verdicts.rows)} verdicts and {len(figures.rows)} figures or rows differ "
        "(beyond the tolerance a seed keeps across machines); every other figure is the "
        "same in both.", verdicts, figures]
    return Section("changes", f"What changed since {old_name}", (
        f"This report, `{new['command']}` ({new['generated']}, cml-edge "
        f"{new['versions']['cml_edge']}), against the report in `{old_name}`, "
        f"`{old['command']}` ({old['generated']}, cml-edge {old['versions']['cml_edge']})."),
        blocks)


def _verdict(v: Any, changed: bool = False) -> Cell:
    if v is None:
        return Cell(text="not measured")
    return Cell(text=v.text(), verdict=v.level, changed=changed)
