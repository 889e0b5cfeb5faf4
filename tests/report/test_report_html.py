"""report.html in a real browser: it loads offline with no console error, every figure
decodes, every table's numbers are report.json's (formatted for people), its verdicts are
the documented thresholds', and a comparison highlights exactly what changed.

Chromium: ``apt-get install chromium``; without it these tests skip, saying so."""

from __future__ import annotations

import copy
import json
import shutil
from pathlib import Path

import pytest
from chromium_page import open_page

from cml_edge.report import load_report, write_report
from cml_edge.report.numbers import human
from cml_edge.report.tables import lookup
from cml_edge.report.verdict import LEVELS, device_verdicts, part_verdicts, scenario_verdicts

TINY_PNG = ("iVBORw0KGgoAAAANSUhEUgAAAAEAAAABCAYAAAAfFcSJAAAADUlEQVR42mP8z8BQDwAEhQGAhKmMIQAAAABJ"
            "RU5ErkJggg==")


def _value(reports: dict[str, dict], path: str):
    source, _, path = path.rpartition(":")
    return lookup(reports[source or "new"], path)


def check_cells(seen: dict, reports: dict[str, dict]) -> int:
    """Every table cell against the JSON: a cell read from a path holds that value and
    shows it as :func:`human` does; a computed one (``A / B``, ``A - B``) its result; a
    verdict the one the thresholds give. Returns how many numbers were checked."""
    verdicts = {**scenario_verdicts(reports["new"]["scorecard"]),
                **part_verdicts(reports["new"]["scorecard"]),
                **{(*k, "3-D"): v for k, v in scenario_verdicts(  # the 3-D section's
                    (reports["new"].get("space") or {}).get("scorecard", [])).items()}}
    checked = 0
    for c in seen["cells"]:
        where = f"{c['table']}, {c['row']}: {c['text']!r}"
        if "path" in c:
            v = _value(reports, c["path"])
            assert c.get("value", "") == ("" if v is None else repr(v)), where
            assert c["text"] == human(v, c.get("unit", "")), where
            checked += 1
        elif "of" in c:
            a, op, b = c["of"].split()
            x, y = _value(reports, a), _value(reports, b)
            v = x / y if op == "/" else x - y
            assert float(c["value"]) == pytest.approx(v, rel=1e-12), where
            assert c["text"].lstrip("+") == human(v, c.get("unit", "")), where
            checked += 1
        elif "key" in c:
            v = verdicts[tuple(c["key"].split("|"))]
            assert (c["verdict"], c["text"].startswith(v.level)) == (v.level, True), where
            if v.reasons:
                assert v.because() in c["text"], where
        else:  # words only: a label, a part, a note, n/a; a verdict of an older report
            assert "value" not in c or c["table"] == "changes-verdicts", where
    return checked


def check_page(folder: Path, figures: int, old: dict | None = None) -> dict:
    """Open ``folder``'s report.html; no error, no request out, every image decoded, every
    table cell as its JSON says, the summary's lists as the verdicts give them."""
    seen = open_page(folder / "report.html")
    assert seen["errors"] == [] and seen["requests"] == []
    assert len(seen["images"]) == figures and all(i["ok"] and i["width"] > 0
                                                  for i in seen["images"]), seen["images"]
    report = load_report(folder)
    assert check_cells(seen, {"new": report, "old": old or {}}) > 0
    worst = device_verdicts(report["scorecard"])
    for level, lead in zip(LEVELS, ("Survive all", "Degrade on at least one",
                                    "Fail at least one")):
        names = [d for d, v in worst.items() if v.level == level]
        assert f"{lead} {len(report['scorecard_plan']['scenarios'])} workloads: " \
               if level == LEVELS[0] else f"{lead}: " in seen["summary"]
        start = seen["summary"].index(f"{lead}" + (" " if level == LEVELS[0] else ":"))
        listed = seen["summary"][start:].split(":", 1)[1].split(".")[0].strip()
        assert listed == (", ".join(names) or "none"), (level, listed)
    return seen


def test_the_reference_page_in_a_browser(reference_page):
    seen = check_page(reference_page, figures=10)  # the 3-D section's two among them
    report = load_report(reference_page)
    cells = [c for c in seen["cells"] if "path" in c]
    # every system's every figure in the budget, every scorecard row's four figures
    assert sum(c["table"] == "budget" for c in cells) == 8 * len(report["systems"])
    assert sum(c["table"].startswith("scenario-") for c in cells) == 4 * len(report["scorecard"])
    assert {"verdicts", "cost", "budget", "scorecard-verdicts", "breakpoints",
            "recovery", "space-verdicts", "space-breakpoint-pairs",
            "space-breakpoints"} <= set(seen["tables"])
    pcm = next(c for c in cells if c["table"] == "budget" and c["row"] == "crossbar-pcm"
               and c["path"].endswith("parameter_bytes"))
    assert pcm["text"] == "36.9 kB"  # 36,864 bytes, for people


@pytest.mark.slow
def test_a_report_run_in_a_browser(report):
    """The page of a report just run (the tiny one): no error, the figures, its numbers."""
    _, out = report
    check_page(out, figures=9)  # 3-D paths; no 3-D break points without 3-D scenarios


def test_the_comparison_highlights_what_changed(reference_page, tmp_path):
    old = load_report(reference_page)
    new = copy.deepcopy(old)
    pcm = next(i for i, r in enumerate(new["scorecard"])
               if (r["device"], r["part"]) == ("crossbar-pcm", "paper"))
    new["scorecard"][pcm]["decision_agreement"] = 0.5  # degrades on agreement now
    new["systems"][0]["energy_per_action_nj"] = 2.0
    shutil.copytree(reference_page, tmp_path / "old")
    write_report(new, tmp_path / "new", (old, str(tmp_path / "old")))
    seen = check_page(tmp_path / "new", figures=10, old=old)
    changed = [c for c in seen["cells"] if c["table"].startswith("changes-")]
    figures = [c for c in changed if c["table"] == "changes-figures" and "path" in c]
    assert {c["path"] for c in figures} == {
        f"scorecard.{pcm}.decision_agreement", f"old:scorecard.{pcm}.decision_agreement",
        "systems.0.energy_per_action_nj", "old:systems.0.energy_per_action_nj"}
    verdicts = [c for c in changed if c["table"] == "changes-verdicts" and "verdict" in c]
    assert [(c["row"], c["verdict"]) for c in verdicts] == [
        ("crossbar-pcm", "survives"), ("crossbar-pcm", "degrades")]


def test_the_browser_check_fails_on_a_broken_page(tmp_path):
    """The check can fail: a console error, an uncaught exception, an image that does not
    decode, a request out of the page, each seen."""
    page = tmp_path / "bad.html"
    page.write_text(
        "<!DOCTYPE html><html><body><div id='summary'></div>"
        f"<img alt='good' src='data:image/png;base64,{TINY_PNG}'>"
        "<img alt='broken' src='data:image/png;base64,AAAA'>"
        "<img alt='away' src='http://127.0.0.1:9/x.png'>"
        "<script>console.error('boom'); undefinedFunction();</script></body></html>")
    seen = open_page(page)
    assert any("boom" in e for e in seen["errors"])
    assert any("undefinedFunction" in e for e in seen["errors"])
    assert [i["ok"] for i in seen["images"]] == [True, False, False]
    assert seen["requests"] == ["http://127.0.0.1:9/x.png"]
    with pytest.raises(AssertionError):
        assert seen["errors"] == [] and seen["requests"] == []


def test_a_page_whose_numbers_differ_from_its_json_fails(reference_page, tmp_path):
    """A cell whose number is not report.json's is caught (the page edited by hand)."""
    folder = tmp_path / "r"
    shutil.copytree(reference_page, folder)
    text = (folder / "report.html").read_text()
    assert ">36.9 kB<" in text
    (folder / "report.html").write_text(text.replace(">36.9 kB<", ">36.8 kB<", 1))
    with pytest.raises(AssertionError, match="36.8 kB"):
        check_page(folder, figures=10)


def test_the_page_sorts_on_the_raw_values(reference_page):
    """A click on a header sorts the rows by the cells' values, not by their text."""
    sort = """(async () => {
      const table = document.querySelector("table[data-table=budget]");
      table.querySelectorAll("thead th")[6].click();  // energy per run
      const order = [...table.tBodies[0].rows].map(r => r.cells[0].textContent);
      return JSON.stringify({order});
    })()"""
    seen = open_page(reference_page / "report.html", sort)
    report = load_report(reference_page)
    energy = sorted((s["energy_per_run_uj"], s["label"]) for s in report["systems"]
                    if s["energy_per_run_uj"] is not None)
    assert seen["order"][:len(energy)] == [label for _, label in energy]
    assert json.dumps(seen["order"]).count("float64") == 1  # n/a sorts after the numbers
