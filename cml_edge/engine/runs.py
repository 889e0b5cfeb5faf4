"""A run folder that knows what it holds: its settings file, and checksummed task files.

A sweep with an output folder (:func:`cml_edge.engine.sweep.run_sweep`) writes
``OUT/run.json`` before any task: the run's settings (what every task of the run shares:
the scenario or experiment, the device and its fields, the budget; not the seeds or the
chips, which only add tasks) and the version of cml-edge that started it. A rerun into
the folder:

- with the same settings resumes: adding seeds or chips adds tasks, and the finished
  ones are kept;
- with other settings is refused (InputError naming the first differing setting), unless
  it starts over (``restart``: the folder's task files are removed first);
- in a folder without a settings file (written before there were any) is refused when
  one of its task files is of another call under the same key.

Each task file carries ``checksum``, the SHA-256 of its function, parameters, result and
the run's settings; a task file whose checksum does not match (a half or edited file, a
file from another run) is recomputed, never trusted.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from cml_edge import __version__
from cml_edge.core.finite import dumps
from cml_edge.errors import InputError
from cml_edge.io.files import atomic_write_text
from cml_edge.io.reading import MiB, read_text, strict_json

RUN_FILE = "run.json"
RUN_FORMAT = "cml-edge-run"
RUN_BYTES = 16 * MiB
"""The largest run file read: a run's settings (a report's are ~20 kB)."""


def plain(value: Any) -> Any:
    """``value`` as it reads back from JSON (tuples as lists, ...)."""
    return json.loads(json.dumps(value))


def checksum(doc: dict[str, Any], settings: dict[str, Any] | None) -> str:
    """The SHA-256 (hex) of a task document's function, parameters and result and the
    run's settings."""
    body = {"fn": doc.get("fn"), "params": doc.get("params"), "result": doc.get("result"),
            "settings": settings}
    text = json.dumps(body, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()


def first_difference(old: Any, new: Any, where: str = "") -> str | None:
    """The first setting where ``old`` and ``new`` differ, as ``key.sub: OLD there, NEW
    now``; None when they are equal."""
    if isinstance(old, dict) and isinstance(new, dict):
        for key in dict.fromkeys([*new, *old]):
            name = f"{where}.{key}" if where else str(key)
            if key not in old:
                return f"{name}: not set there, {new[key]!r} now"
            if key not in new:
                return f"{name}: {old[key]!r} there, not set now"
            found = first_difference(old[key], new[key], name)
            if found:
                return found
        return None
    if old != new:
        return f"{where or 'settings'}: {old!r} there, {new!r} now"
    return None


def open_run(out: str | Path, settings: dict[str, Any], tasks: Sequence[Any],
             restart: bool = False) -> None:
    """Check that folder ``out`` holds this run, or none, and record its settings there
    (module docstring); ``tasks``: the run's tasks (their ``key``, ``fn`` and
    ``params``)."""
    out = Path(out)
    path = out / RUN_FILE
    settings = plain(settings)
    tasks_dir = out / "tasks"
    if restart:
        for old in tasks_dir.glob("*.json") if tasks_dir.is_dir() else ():
            old.unlink()
        path.unlink(missing_ok=True)
    if path.exists() or path.is_symlink():
        text = read_text(path, "run file", RUN_BYTES)
        try:
            doc = strict_json(text)
            if not isinstance(doc, dict) or doc.get("format") != RUN_FORMAT or \
                    not isinstance(doc.get("settings"), dict):
                raise ValueError
        except ValueError:
            raise InputError(f"{str(path)!r} is not a cml-edge run file (give --restart to "
                             f"start the run over)") from None
        diff = first_difference(doc["settings"], settings)
        if diff:
            raise InputError(f"the run folder {str(out)!r} holds a run with other settings "
                             f"({diff}); rerun with its settings to resume, or give "
                             f"--restart to start over") from None
        return
    for task in tasks:  # a folder written before run files: its tasks must be these
        try:
            doc = json.loads((tasks_dir / f"{task.key}.json").read_text())
            params = doc["params"]
        except (OSError, ValueError, KeyError, TypeError):
            continue
        diff = first_difference(params, plain(task.params))
        if diff or doc.get("fn") != task.fn:
            raise InputError(f"the run folder {str(out)!r} holds task {task.key} of another "
                             f"run ({diff or 'its function'}); give --restart to start over")
    atomic_write_text(path, dumps({"format": RUN_FORMAT, "cml_edge_version": __version__,
                                   "settings": settings}, indent=1))
