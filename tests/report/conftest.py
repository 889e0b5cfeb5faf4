"""The report's fixtures: the reference report rendered again from its JSON, and a tiny
report run (its numbers mean nothing of a device)."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from cml_edge.report import build_report, write_report
from cml_edge.report.scorecard import Breakpoint, ScorecardPlan


@pytest.fixture(scope="session")
def reference_page(tmp_path_factory) -> Path:
    """The committed reference report rendered again from its report.json alone."""
    from cml_edge.report import render_report

    folder = tmp_path_factory.mktemp("reference") / "reference"
    shutil.copytree(Path(__file__).resolve().parents[2] / "hw_reports" / "reference", folder)
    return render_report(folder)


# the scorecard's machinery on a smoke-test budget (its numbers mean nothing of a device)
TINY_CARD = ScorecardPlan(2, "tiny", 2, devices=[("float32", "float32", {}),
                                                 ("crossbar-pcm", "crossbar", {"preset": "pcm"})],
                          scenarios=("paper", "recovery"),
                          breakpoints=(Breakpoint("float32", "float32", {}, "drift_time"),),
                          workers=1)


@pytest.fixture(scope="session")
def report(tmp_path_factory):
    """A tiny report run (quick systems, the tiny scorecard) and the folder it was
    written to."""
    rep = build_report(quick=True, systems=[("float32", "float32", {})],
                       sweeps=[("read noise", "pcm read_noise 0.2", "crossbar",
                                {"preset": "pcm", "read_noise": 0.2})], scorecard=TINY_CARD)
    out = tmp_path_factory.mktemp("rep") / "r"
    write_report(rep, out)
    return rep, out

