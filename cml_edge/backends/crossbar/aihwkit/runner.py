"""Run a task of :mod:`~cml_edge.backends.crossbar.aihwkit.worker` in aihwkit's environment.

aihwkit 1.1.0 needs exactly torch 2.10.0, and the project's DQN extra another torch, so
aihwkit lives in a virtual environment of its own, built by ``bash scripts/aihwkit_env.sh``
(the extra ``aihwkit``). This module finds its interpreter, writes the request to a
temporary file, runs the worker there as a subprocess and reads the result file back: the
project's environment never imports torch for it.
"""

from __future__ import annotations

import json
import os
import subprocess
import tempfile
from pathlib import Path
from typing import Any

from cml_edge.errors import InputError

BUILD_COMMAND = "bash scripts/aihwkit_env.sh"
"""The one command that builds aihwkit's environment (from the repository's root)."""
VENV_VARIABLE = "CML_EDGE_AIHWKIT_VENV"
"""An environment variable naming the environment's folder (default
``~/.cache/cml-edge/aihwkit-venv``, where the build command puts it)."""
WORKER = Path(__file__).with_name("worker.py")


def venv_dir() -> Path:
    """The folder of aihwkit's environment: ``$CML_EDGE_AIHWKIT_VENV``, else
    ``$XDG_CACHE_HOME/cml-edge/aihwkit-venv`` (``~/.cache`` without it)."""
    given = os.environ.get(VENV_VARIABLE)
    if given:
        return Path(given)
    cache = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(cache) / "cml-edge" / "aihwkit-venv"


def python() -> Path | None:
    """The environment's interpreter, or None where it has not been built."""
    exe = venv_dir() / "bin" / "python"
    return exe if exe.is_file() and os.access(exe, os.X_OK) else None


def require() -> Path:
    """The interpreter; InputError naming the build command where it is missing."""
    exe = python()
    if exe is None:
        raise InputError(f"aihwkit's environment is missing ({venv_dir()}): build it with "
                         f"`{BUILD_COMMAND}` (or set {VENV_VARIABLE} to its folder)")
    return exe


def run(task: str, **request: Any) -> dict[str, Any]:
    """The worker's result of ``task`` with ``request`` (JSON-able); RuntimeError with the
    worker's last lines of stderr when it fails."""
    exe = require()
    with tempfile.TemporaryDirectory(prefix="cml-edge-aihwkit-") as tmp:
        req, out = Path(tmp) / "request.json", Path(tmp) / "result.json"
        req.write_text(json.dumps({"task": task, **request}))
        env = {**os.environ, "OMP_NUM_THREADS": "1", "PYTHONNOUSERSITE": "1"}
        env.pop("PYTHONPATH", None)
        proc = subprocess.run([str(exe), str(WORKER), str(req), str(out)], env=env,
                              capture_output=True, text=True, check=False)
        if proc.returncode != 0:
            tail = "\n".join(proc.stderr.strip().splitlines()[-5:])
            raise RuntimeError(f"aihwkit's worker failed on {task!r} ({exe}):\n{tail}")
        return json.loads(out.read_text())
