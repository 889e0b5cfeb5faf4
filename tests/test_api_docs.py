"""docs/api.md runs as written: its Python blocks, in order, in one process; and a library
user hears of the first compile (stderr, or the ``cml_edge`` logger when logging is set)."""

from __future__ import annotations

import os
import re
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PAGE = ROOT / "docs" / "api.md"


def python_blocks() -> list[str]:
    return re.findall(r"^```python\n(.*?)^```", PAGE.read_text(), re.S | re.M)


def _run(code: str, cwd: Path, **env: str) -> subprocess.CompletedProcess:
    full = dict(os.environ, PYTHONPATH=str(ROOT), **env)
    full.pop("CML_EDGE_PLUGINS", None)
    return subprocess.run([sys.executable, "-c", code], cwd=cwd, env=full,
                          capture_output=True, text=True)


def test_the_page_has_its_sections():
    text = PAGE.read_text()
    for heading in ("Train and evaluate", "Emulate a device", "float64 twin", "Save and load",
                    "scorecard"):
        assert heading in text
    assert len(python_blocks()) == 5


@pytest.mark.slow
def test_the_pages_blocks_run_in_one_process(tmp_path):
    done = _run("\n\n".join(python_blocks()), tmp_path)
    assert done.returncode == 0, done.stderr[-3000:]
    assert "success_rate" in done.stdout and (tmp_path / "int8-model.npz").is_file()
    assert "paper all" in done.stdout or "paper" in done.stdout


FIRST_COMPILE = textwrap.dedent("""
    import numpy as np
    {setup}
    from cml_edge.kit import uniform
    uniform(np.array([1, 0], dtype=np.uint64))
    uniform(np.array([1, 0], dtype=np.uint64))
""")


def test_a_library_user_hears_of_the_first_compile_once(tmp_path):
    done = _run(FIRST_COMPILE.format(setup=""), tmp_path,
                NUMBA_CACHE_DIR=str(tmp_path / "cold"))
    assert done.returncode == 0, done.stderr
    lines = [line for line in done.stderr.splitlines() if "compiling kernels" in line]
    assert len(lines) == 1 and lines[0].startswith("cml-edge: compiling kernels (cml_edge.")
    logged = _run(FIRST_COMPILE.format(
        setup="import logging; logging.basicConfig(level=logging.INFO, format='LOG %(name)s "
              "%(message)s')"), tmp_path, NUMBA_CACHE_DIR=str(tmp_path / "cold2"))
    assert logged.returncode == 0, logged.stderr
    assert "LOG cml_edge compiling kernels" in logged.stderr
    assert "cml-edge: compiling" not in logged.stderr
    warm = _run(FIRST_COMPILE.format(setup=""), tmp_path, NUMBA_CACHE_DIR=str(tmp_path / "cold"))
    assert "compiling" not in warm.stderr  # cached: nothing compiles, nothing is said
