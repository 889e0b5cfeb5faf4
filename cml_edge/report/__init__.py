"""The hardware-budget report (``cml-edge report``): markdown, JSON and figures."""

from cml_edge.report.build import build_report, write_report

__all__ = ["build_report", "write_report"]
