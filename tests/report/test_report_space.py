"""The report's 3-D section: every system again in the volume, the ratios, the 3-D
scenarios' verdicts, rendered in report.md and report.html; the plane's sections the same
with or without it."""

import copy
import json

import pytest

from cml_edge.report import build_report, write_report
from cml_edge.report.build import SPACE_KEYS, space_row
from cml_edge.report.render import outline, render_markdown
from cml_edge.report.scorecard import Breakpoint, ScorecardPlan
from cml_edge.report.space import space
from cml_edge.report.tables import Cell, Table, lookup


def test_a_space_row_sets_the_volume_beside_the_plane():
    plane = {"label": "int8", "backend": "int8", "options": {}, "parameters": 4608,
             "energy_per_run_uj": 2.0, "device_pulses_per_run": None, "success_rate": 1.0}
    vol = {**plane, "parameters": 14080, "energy_per_run_uj": 5.0, "success_rate": 0.9}
    row = space_row(plane, {"decision_agreement": {"mean": 0.8}}, vol,
                    {"decision_agreement": {"mean": 0.5}})
    assert set(row["ratio"]) == set(SPACE_KEYS)
    assert row["ratio"]["parameters"] == 14080 / 4608
    assert row["ratio"]["energy_per_run_uj"] == 2.5
    assert row["ratio"]["decision_agreement"] == 0.5 / 0.8
    assert row["ratio"]["device_pulses_per_run"] is None  # n/a in both
    assert (row["plane"]["success_rate"], row["space"]["success_rate"]) == (1.0, 0.9)


def test_the_reference_has_it_and_a_report_without_it_has_none(reference_page):
    report = json.loads((reference_page / "report.json").read_text())
    (row,) = [s for s in report["space"]["systems"] if s["label"] == "int8"]
    assert (row["plane"]["parameters"], row["space"]["parameters"]) == (4608, 14080)
    assert row["plane"]["success_rate"] != row["space"]["success_rate"]
    assert "space" in [s.key for s in outline(report)]
    del report["space"]
    assert space(report) is None and "space" not in [s.key for s in outline(report)]


@pytest.mark.slow
def test_the_3d_section(tmp_path):
    card = ScorecardPlan(2, "tiny", 2, devices=[("float32", "float32", {})],
                         scenarios=("paper",), workers=1, space=("paper", "drone"),
                         breakpoints=(Breakpoint("float32", "float32", {}, "drift_time"),))
    rep = build_report(quick=True, systems=[("float32", "float32", {})], sweeps=[],
                       scorecard=card)
    sp = rep["space"]
    (row,) = sp["systems"]
    assert (sp["dims"], sp["moves"], sp["arena"]) == (3, "king", 30)
    assert row["plane"]["parameters"] == 4608 and row["space"]["parameters"] == 14080
    assert row["ratio"]["train_bytes_direct"] == pytest.approx(14080 / 4608)
    assert row["plane"]["energy_per_run_uj"] != row["space"]["energy_per_run_uj"]
    assert row["plane"]["success_rate"] == rep["systems"][0]["success_rate"]
    assert [(r["scenario"], r["part"], r["dims"]) for r in sp["scorecard"]] == \
        [("paper", "paper", 3), ("drone", "drone", 3)]
    (bp2,), (bp3,) = rep["breakpoints"], sp["breakpoints"]  # the same search in the volume
    assert "dims" not in bp2 and bp3["dims"] == 3
    assert {k: bp3[k] for k in ("device", "knob", "scenario", "target", "seeds")} == \
        {k: bp2[k] for k in ("device", "knob", "scenario", "target", "seeds")}
    assert bp3["evaluations"] != bp2["evaluations"]
    assert sp["scorecard"][0]["weight_error"] != rep["scorecard"][0]["weight_error"]
    out = write_report(rep, tmp_path / "r")
    md = (out / "report.md").read_text()
    html = (out / "report.html").read_text()
    assert "## 3-D: what the third dimension costs" in md and 'id="space"' in html
    assert "cml-edge scenario paper --dims 3 --backend float32" in html
    assert "cml-edge scenario drone --dims 3 --backend float32" in html
    assert ("cml-edge breakpoint --backend float32 --knob drift_time --scenario paper "
            "--dims 3 --target 0.95") in html
    assert {"trajectories_3d.png", "breakpoints_3d.png"} <= {f.name for f in out.iterdir()}
    section = next(s for s in outline(rep) if s.key == "space")
    tables = [b for b in section.blocks if isinstance(b, Table)]
    assert [t.key for t in tables] == ["space-ratios", "space-verdicts", "space-scenarios",
                                       "space-breakpoint-pairs", "space-breakpoints",
                                       "space-float32"]
    for table in tables:  # every number is the JSON's
        for cell in (c for r in table.rows for c in r[1:] if isinstance(c, Cell)):
            if cell.path:
                assert lookup(rep, cell.path) == cell.value
    plane = copy.deepcopy(rep)
    del plane["space"]
    cut = md.index("## 3-D"), md.index("## Energy constants")
    assert render_markdown(plane, {}) == render_markdown(rep, {})[:cut[0]] + \
        render_markdown(rep, {})[cut[1]:]
