"""The report's tables as data, rendered as markdown or as sortable HTML.

A :class:`Table` is a header and rows of :class:`Cell`: a number with its unit, printed by
:func:`~cml_edge.report.numbers.human`, and the place in ``report.json`` it was read from
(``path``, e.g. ``systems.5.energy_per_run_uj``), or the two it was computed from
(``of``: ``A / B`` or ``A - B``), so a page can be checked against the JSON it was made
from (a path of an older report compared with, ``old:systems.5...``). In HTML each
cell carries its raw value (``data-value``: what the table sorts by) and its path.
"""

from __future__ import annotations

import html
from dataclasses import dataclass, field
from typing import Any

from cml_edge.report.numbers import human


@dataclass
class Cell:
    """One table cell: ``value`` (a number, a string or None) in ``unit``; ``path`` where
    report.json holds it; ``of`` (``A / B``, ``A - B``: two paths) for a computed one;
    ``text`` the words shown instead of the number; ``verdict`` a verdict level (its
    colour) and ``key`` what it judges (``device|scenario[|part]``); ``title`` a tooltip;
    ``changed`` highlights it (a figure that differs from an older report's)."""

    value: Any = None
    unit: str = ""
    path: str | None = None
    of: str | None = None
    text: str | None = None
    verdict: str | None = None
    key: str | None = None
    title: str | None = None
    changed: bool = False

    def shown(self) -> str:
        return self.text if self.text is not None else human(self.value, self.unit)

    def sort_key(self) -> str:
        """What the column sorts by: the number, a verdict's severity, else the text."""
        if self.verdict is not None:
            from cml_edge.report.verdict import LEVELS

            return str(LEVELS.index(self.verdict))
        if isinstance(self.value, (int, float)) and not isinstance(self.value, bool):
            return repr(self.value)
        return ""


def at(report: dict[str, Any], path: str, unit: str = "") -> Cell:
    """The cell of the number at ``path`` (dots; list indices as numbers) of ``report``;
    ``n/a`` where the report has no such figure (a DQN row has no cells changed)."""
    try:
        return Cell(lookup(report, path), unit, path=path)
    except (KeyError, IndexError):
        return Cell(None, unit)


def lookup(data: Any, path: str) -> Any:
    """The value at a dotted path of a JSON document (list indices as numbers)."""
    for part in path.split("."):
        data = data[int(part)] if isinstance(data, list) else data[part]
    return data


@dataclass
class Table:
    """A titled table: ``rows`` of cells under ``header``; the first cell of a row is its
    label (a string, a row header in HTML, ``title`` its tooltip: the row's command)."""

    key: str
    header: list[str]
    rows: list[list[Cell | str]] = field(default_factory=list)
    titles: list[str | None] = field(default_factory=list)

    def add(self, label: str, cells: list[Cell | str], title: str | None = None) -> None:
        self.rows.append([label, *cells])
        self.titles.append(title)


def _md_cell(c: Cell | str) -> str:
    return (c if isinstance(c, str) else c.shown()).replace("|", "\\|")


def markdown(table: Table) -> str:
    """The table as a GitHub markdown table."""
    lines = ["| " + " | ".join(table.header) + " |", "|" + "---|" * len(table.header)]
    lines += ["| " + " | ".join(_md_cell(c) for c in row) + " |" for row in table.rows]
    return "\n".join(lines)


def _attrs(c: Cell) -> str:
    attrs = {"data-value": c.sort_key(), "data-path": c.path, "data-unit": c.unit or None,
             "data-of": c.of,
             "data-verdict": c.verdict, "data-key": c.key, "title": c.title,
             "class": " ".join(k for k in (f"v-{c.verdict}" if c.verdict else "",
                                            "changed" if c.changed else "",
                                            "text" if c.text is not None else "") if k) or None}
    return "".join(f' {k}="{html.escape(str(v))}"' for k, v in attrs.items() if v)


def _content(c: Cell) -> str:
    """A cell's HTML: a verdict as its word over its reason, else the shown text."""
    level, _, why = c.shown().partition(": ")
    if c.verdict is not None and why:
        return f"<b>{html.escape(level)}</b><br><small>{html.escape(why)}</small>"
    return html.escape(c.shown())


def to_html(table: Table) -> str:
    """The table as sortable HTML (the page's script sorts on a click on a header); its
    id ``table-KEY`` (a section may bear its key), its key in ``data-table``."""
    head = "".join(f'<th scope="col">{html.escape(h)}</th>' for h in table.header)
    body = []
    for row, title in zip(table.rows, table.titles):
        label = html.escape(str(row[0]))
        tip = f' title="{html.escape(title)}"' if title else ""
        cells = "".join(f'<td class="text">{html.escape(c)}</td>' if isinstance(c, str)
                        else f"<td{_attrs(c)}>{_content(c)}</td>" for c in row[1:])
        body.append(f'<tr><th scope="row"{tip}>{label}</th>{cells}</tr>')
    return (f'<div class="scroll"><table class="sortable" id="table-{table.key}" '
            f'data-table="{table.key}"><thead><tr>{head}</tr></thead>'
            f'<tbody>{"".join(body)}</tbody></table></div>')
