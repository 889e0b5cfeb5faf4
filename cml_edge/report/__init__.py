"""The hardware-budget report (``cml-edge report``): JSON, markdown, an HTML page, figures.

The names below load :mod:`cml_edge.report.build` when first used, so the command line's
summaries can import the report's number formatting and verdicts without it.
"""

from typing import Any

__all__ = ["build_report", "check_report_folder", "load_report", "render_report",
           "write_report"]


def __getattr__(name: str) -> Any:
    if name in __all__:
        from cml_edge.report import build

        return getattr(build, name)
    raise AttributeError(name)
