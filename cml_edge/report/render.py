"""Render a report dict (see :mod:`cml_edge.report.build`) as report.md, report.html and
PNG figures, from the dict alone: every number shown is a number of report.json,
formatted by :func:`~cml_edge.report.numbers.human`.

:func:`outline` lists the sections both pages show, in order: the summary (verdicts and
costs), what changed since an older report (``old``, when given), the budget, the
scorecard, break points, recovery, the third dimension (a report that has it), the sweeps
and the energy constants.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from cml_edge.report import card, sections, space
from cml_edge.report.figures import render_figures
from cml_edge.report.numbers import human
from cml_edge.report.page import page
from cml_edge.report.sections import Section
from cml_edge.report.tables import Table, markdown


def outline(report: dict[str, Any], old: tuple[dict[str, Any], str] | None = None
            ) -> list[Section]:
    """The sections of the report; ``old``: (an older report, its folder) to compare."""
    from cml_edge.report.compare import comparison

    parts = [sections.summary(report)]
    if old is not None:
        parts.append(comparison(report, *old))
    parts.append(sections.budget(report))
    if report.get("scorecard"):
        parts += [card.scorecard(report), card.breakpoints(report), card.recovery(report)]
    parts += [space.space(report), sections.sweeps(report), sections.constants(report)]
    return [p for p in parts if p is not None]


def intro(report: dict[str, Any]) -> list[str]:
    """Where the report comes from: its command, date, versions, machine, time."""
    v, m = report["versions"], report["machine"]
    lines = [f"Made by `{report['command']}` at {report['generated']}; cml-edge "
             f"{v['cml_edge']}, Python {v['python']}, NumPy {v['numpy']}, Numba {v['numba']}, "
             f"SciPy {v['scipy']}; {m['cpus']} CPUs ({m['platform']}); it took "
             f"{human(report['wall_time_s'], 's')}. Every number is in report.json."]
    if report["quick"]:
        lines.append("Quick profile: every section on 2 seeds at the quick budget; run "
                     "without --quick for the reference figures.")
    return lines


def _md_section(s: Section) -> list[str]:
    out = [f"## {s.title}", "", f"*{s.made_by}*"]
    for block in s.blocks:
        out += ["", markdown(block) if isinstance(block, Table) else block]
    return [*out, ""]


def render_markdown(report: dict[str, Any], figures: dict[str, str],
                    old: tuple[dict[str, Any], str] | None = None) -> str:
    """report.md: the sections of :func:`outline` and links to the figures."""
    parts = [f"# {report['title']}", "", *intro(report), "", "report.html: the same as one "
             "page, with the figures inline and tables that sort.", ""]
    for s in outline(report, old):
        parts += _md_section(s)
    parts += ["## Figures", ""] + [f"![{name}]({file})" for name, file in figures.items()]
    return "\n".join(parts) + "\n"


def render_html(report: dict[str, Any], folder: Path, figures: dict[str, str],
                old: tuple[dict[str, Any], str] | None = None) -> str:
    """report.html: :func:`outline`'s sections as one self-contained page, the figures of
    ``folder`` embedded (:mod:`cml_edge.report.page`)."""
    return page(report["title"], intro(report), outline(report, old), folder, figures)


__all__ = ["outline", "render_figures", "render_html", "render_markdown"]
