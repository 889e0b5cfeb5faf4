"""The documentation: a README a user reads, links that resolve, no tracker or branch
wording, and figure markers that parse, name valid commands and can fail."""

from __future__ import annotations

import json
import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

from cml_edge.cli import build_parser

ROOT = Path(__file__).resolve().parent.parent
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md")),
         ROOT / "benchmarks" / "README.md"]
CHECKER = ROOT / "docs" / "check_figures.py"
WORDING = re.compile(r"\bissues? #?\d+|\bworktrees?\b|\bthis branch\b|\bsessions?\b", re.I)
LINK = re.compile(r"(?<!!)\[[^\]]*\]\(([^)\s]+)\)")



def _slug(heading: str) -> str:
    """GitHub's anchor of a heading."""
    text = re.sub(r"[^\w\- ]", "", heading.strip().lower().replace("`", ""))
    return text.replace(" ", "-")


def _anchors(page: Path) -> set[str]:
    text = re.sub(r"```.*?```", "", page.read_text(), flags=re.S)
    return {_slug(m.group(1)) for m in re.finditer(r"^#+\s+(.*)$", text, re.M)}


def test_readme_is_at_most_300_lines():
    assert len((ROOT / "README.md").read_text().splitlines()) <= 300


def test_no_tracker_branch_or_session_wording():
    files = [*PAGES, *sorted((ROOT / "cml_edge").rglob("*.py")),
             *sorted((ROOT / "cml_edge").rglob("*.md"))]
    found = [f"{f.relative_to(ROOT)}:{n}: {line.strip()}"
             for f in files for n, line in enumerate(f.read_text().splitlines(), 1)
             if WORDING.search(line)]
    assert not found, "\n".join(found)


def test_every_relative_link_resolves():
    pages = [*PAGES, *sorted((ROOT / "cml_edge").rglob("*.md"))]
    broken = []
    for page in pages:
        text = re.sub(r"```.*?```", "", page.read_text(), flags=re.S)
        for target in LINK.findall(text):
            if re.match(r"[a-z]+:", target):
                continue  # http(s), mailto
            path, _, anchor = target.partition("#")
            dest = (page.parent / path).resolve() if path else page
            if not dest.exists():
                broken.append(f"{page.relative_to(ROOT)}: {target}")
            elif anchor and dest.is_file() and dest.suffix == ".md" \
                    and anchor not in _anchors(dest):
                broken.append(f"{page.relative_to(ROOT)}: {target} (no such heading)")
    assert not broken, "\n".join(broken)


def test_every_figure_marker_parses_and_names_a_valid_command(script):
    checker = script("docs/check_figures.py")
    figures = [f for page in PAGES for f in checker.parse_page(page)]
    seeded = [f for f in figures if f.kind == "figure"]
    assert len(seeded) >= 50  # the docs' seeded figures carry markers
    parser = build_parser()
    for fig in figures:
        for argv in fig.argvs():
            if argv[0] == "python":  # a benchmark script (a timing)
                assert fig.kind == "timing" and (ROOT / argv[1]).is_file(), fig.where
                continue
            assert argv[0] == "cml-edge", fig.where
            parser.parse_args(argv[1:])
        if fig.file:
            assert (ROOT / fig.file).is_file(), f"{fig.where}: no {fig.file}"
        for group, (_, text) in zip(fig.groups, fig.targets):
            assert group and text.strip(), fig.where


def test_figures_read_from_committed_results_match(script):
    """The figures whose command wrote a committed results file agree with that file."""
    checker = script("docs/check_figures.py")
    figures = [f for page in PAGES for f in checker.parse_page(page)
               if f.kind == "figure" and f.file]
    assert figures
    lines: list[str] = []
    failed = checker.check(figures, echo=lines.append)
    assert failed == 0, "\n".join(lines)


FABRICATED = """# A page

<!-- figure rows 1-2 cols 2-3: cml-edge robot evaluate m.npz --json ->
  success_rate path_ratio:.2f
  mean_actions:.1f e_pos_mean:.1f @ hw_reports/robot/xy_kinematic.json -->

| what | a | b |
|---|---|---|
| row one | 0.011 | 1.73 |
| row two | 63.9 | 19.5 |
"""


def test_checker_reports_a_mismatch_against_a_results_file(tmp_path):
    page = tmp_path / "page.md"
    page.write_text(FABRICATED)
    proc = subprocess.run([sys.executable, str(CHECKER), str(page)], capture_output=True,
                          text=True)
    assert proc.returncode == 1, proc.stdout + proc.stderr
    assert "MISMATCH" in proc.stdout and "e_pos_mean gives 19.4" in proc.stdout
    page.write_text(FABRICATED.replace("19.5", "19.4"))
    proc = subprocess.run([sys.executable, str(CHECKER), str(page)], capture_output=True,
                          text=True)
    assert proc.returncode == 0 and "1 match" in proc.stdout, proc.stdout + proc.stderr


def test_checker_refuses_a_marker_without_its_table(tmp_path):
    page = tmp_path / "page.md"
    page.write_text("<!-- figure row 1: cml-edge train --out m.npz --json -> walks -->\n\n"
                    "No table here.\n")
    proc = subprocess.run([sys.executable, str(CHECKER), str(page)], capture_output=True,
                          text=True)
    assert proc.returncode == 2 and "expected a table" in proc.stderr


@pytest.mark.slow
def test_checker_reruns_a_command_and_reports_a_wrong_number(tmp_path):
    """A 2-walk training and evaluation: the figure that echoes the command's settings
    matches, the one with a success rate no run can give does not."""
    command = ("cml-edge train --walks 2 --steps 100 --out m.npz && "
               "cml-edge evaluate m.npz --trials 5 --json")
    page = tmp_path / "page.md"
    page.write_text(f"<!-- figure: {command} -> trials:d seeds:d -->\n"
                    "Five trials, 5 pairs, on 1 model.\n\n"
                    f"<!-- figure: {command} -> success_rate -->\n"
                    "It reached 9.999 of its goals.\n")
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.run([sys.executable, str(CHECKER), str(page)], capture_output=True,
                          text=True, env=env)
    assert proc.returncode == 1, proc.stdout + proc.stderr
    out = proc.stdout.splitlines()
    assert out[0].startswith("match") and out[1].startswith("MISMATCH"), proc.stdout
    assert "success_rate gives" in proc.stdout and "9.999" in proc.stdout
    assert shlex.split(command.split(" && ")[0])[0] == "cml-edge"


def test_checker_reports_a_figure_within_the_cross_machine_tolerance(tmp_path):
    """A value that rounds the other way in its last printed digit within the tolerance a
    seed promises across machines matches "(other CPU)"; one beyond it does not."""
    results = tmp_path / "r.json"
    results.write_text(json.dumps({"x": 0.123449999999999}))
    page = tmp_path / "page.md"
    marker = f"<!-- figure: cml-edge evaluate m.npz --json -> x:.4f @ {results} -->\n"
    page.write_text(marker + "It is 0.1235.\n")
    proc = subprocess.run([sys.executable, str(CHECKER), str(page)], capture_output=True,
                          text=True)
    assert proc.returncode == 0 and proc.stdout.startswith("matches (other CPU)"), proc.stdout
    page.write_text(marker + "It is 0.1236.\n")
    proc = subprocess.run([sys.executable, str(CHECKER), str(page)], capture_output=True,
                          text=True)
    assert proc.returncode == 1 and "x gives 0.1234" in proc.stdout


def test_estimate_prices_the_commands_and_quick_picks_the_fastest(script):
    """``--estimate`` runs nothing and prices each command once from the size estimate
    (a committed results file's figure costs nothing, a report is not priced); ``--quick``
    keeps the figures read from results files and the QUICK_COMMANDS fastest commands."""
    checker = script("docs/check_figures.py")
    figures = [f for page in PAGES for f in checker.parse_page(page)]
    lines: list[str] = []
    total = checker.estimate(figures, echo=lines.append)
    assert total > 0 and " commands, ~" in lines[-1] and "first compile" in lines[-1]
    assert all(checker.seconds(f) == 0 for f in figures if f.kind == "figure" and f.file)
    assert sum(1 for line in lines if line.startswith("not priced")) >= 1  # the report's
    assert checker.estimate(figures, rerun=True, echo=lambda _: None) > total
    picked = checker.quick(figures)
    from_files = [f for f in figures if f.kind == "figure" and f.file]
    run = {checker._key(f) for f in picked if not f.file}
    assert set(map(id, from_files)) <= set(map(id, picked))
    assert len(run) == checker.QUICK_COMMANDS
    slowest_run = max(checker.seconds(f) for f in picked if not f.file)
    left_out = [checker.seconds(f) for f in figures if f.kind == "figure" and not f.file
                and checker._key(f) not in run and checker.seconds(f) is not None]
    assert left_out and min(left_out) >= slowest_run
