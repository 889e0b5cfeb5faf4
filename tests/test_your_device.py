"""docs/your-device.md as a user follows it: its files written and its shell commands run
verbatim, in order, from an empty folder outside the repository; its example files the
package's; the ternary and read-noise devices at most 40 lines of code each."""

from __future__ import annotations

import ast
import importlib
import os
import re
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PAGE = ROOT / "docs" / "your-device.md"
FILE = re.compile(r"^# (\w+\.py)$")


def blocks() -> list[tuple[str, str]]:
    """(language, text) of each fenced block of the page, in order."""
    return [(m.group(1), m.group(2)) for m in
            re.finditer(r"^```(\w*)\n(.*?)^```", PAGE.read_text(), re.S | re.M)]


def steps() -> list[tuple[str, str]]:
    """("file", text) for a block that is a file, ("run", line) for each shell line."""
    out = []
    for lang, text in blocks():
        first = text.splitlines()[0]
        if lang == "python" and FILE.match(first):
            out.append(("file", text))
        elif lang == "bash":
            out += [("run", line) for line in text.splitlines() if line.strip()]
    return out


def code_lines(text: str) -> int:
    """Lines of code: not blank, not a comment, not inside a docstring."""
    docs: set[int] = set()
    for node in ast.walk(ast.parse(text)):
        if isinstance(node, ast.Expr) and isinstance(node.value, ast.Constant) and \
                isinstance(node.value.value, str):
            docs |= set(range(node.lineno, node.end_lineno + 1))
    return sum(1 for n, line in enumerate(text.splitlines(), 1)
               if line.strip() and not line.strip().startswith("#") and n not in docs)


def files() -> dict[str, str]:
    return {FILE.match(text.splitlines()[0]).group(1): text for kind, text in steps()
            if kind == "file"}


def test_the_pages_example_files_are_the_shipped_ones():
    shipped = {"ternary.py", "noisy.py", "ecram.py"}
    assert shipped <= set(files())
    for name in shipped:
        module = importlib.import_module(f"cml_edge.kit.examples.{name[:-3]}")
        assert Path(module.__file__).read_text() == files()[name], name


@pytest.mark.parametrize("name", ["ternary.py", "noisy.py"])
def test_a_device_is_at_most_40_lines_of_code(name):
    assert code_lines(files()[name]) <= 40


def test_code_lines_counts_code_only():
    assert code_lines('"""doc\nmore"""\n# c\n\nx = 1\ndef f():\n    """d"""\n    return x\n') == 3


@pytest.mark.slow
def test_the_page_runs_verbatim_in_order(tmp_path):
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        p for p in (str(ROOT), os.environ.get("PYTHONPATH")) if p))
    env.pop("CML_EDGE_PLUGINS", None)
    folder = tmp_path / "mine"
    folder.mkdir()
    ran = []
    for kind, text in steps():
        if kind == "file":
            name = FILE.match(text.splitlines()[0]).group(1)
            (folder / name).write_text(text)
            continue
        done = subprocess.run(["bash", "-c", text], cwd=folder, env=env, capture_output=True,
                              text=True)
        assert done.returncode == 0, f"{text}\n{done.stderr[-3000:]}"
        ran.append((text, done))
    by_line = {text: done for text, done in ran}
    assert "ternary keeps the contract" in next(
        d.stdout for t, d in ran if t.startswith("python -c"))
    refused = next(d for t, d in ran if "|| echo" in t)
    assert "comes from the plugin" in refused.stderr and "(refused" in refused.stdout
    assert (folder / "lab-fit.png").stat().st_size > 10_000
    assert len(by_line) == len(ran)  # no line twice
