"""aihwkit's presets as the project runs them: a committed snapshot, read without aihwkit.

``cml_edge/data/aihwkit_presets.json`` holds every preset device and unit cell aihwkit
1.1.0 defines (``aihwkit.simulator.presets.devices`` and ``.compounds``), each with its
parameters (the dataclass fields, nested ones as objects), its class lineage and its
weight granularity (the worker's ``params``), and the device classes those modules import
but do not define (``OneSidedUnitCell``, ``ConstantStepDevice``...: classes, not presets),
with the aihwkit and torch versions and the command that wrote it::

    python -m cml_edge.backends.crossbar.aihwkit.snapshot

run in the project's environment (it runs the worker's ``presets`` task in aihwkit's,
built by ``bash scripts/aihwkit_env.sh``). So ``--preset aihwkit:NAME`` needs no aihwkit;
only ``--against aihwkit`` runs it. ``tests/backends/crossbar/test_aihwkit.py`` holds the
file equal to aihwkit's live parameters where that environment is built.
"""

from __future__ import annotations

import json
import sys
from functools import cache
from pathlib import Path
from typing import Any

PATH = Path(__file__).resolve().parents[3] / "data" / "aihwkit_presets.json"
COMMAND = "python -m cml_edge.backends.crossbar.aihwkit.snapshot"


@cache
def load() -> dict[str, Any]:
    """The snapshot (once per process)."""
    return json.loads(PATH.read_text())


def take() -> dict[str, Any]:
    """A new snapshot from aihwkit's environment (the worker's ``presets`` task)."""
    from cml_edge.backends.crossbar.aihwkit import runner

    got = runner.run("presets")
    return {"aihwkit": got["versions"]["aihwkit"], "torch": got["versions"]["torch"],
            "command": COMMAND, "presets": got["presets"], "classes": got["classes"]}


def main() -> int:
    from cml_edge.io.files import atomic_write_text

    snap = take()
    atomic_write_text(PATH, json.dumps(snap, indent=1, sort_keys=True) + "\n")
    print(f"{PATH}: aihwkit {snap['aihwkit']}, {len(snap['presets'])} presets, "
          f"{len(snap['classes'])} classes")
    return 0


if __name__ == "__main__":
    sys.exit(main())
