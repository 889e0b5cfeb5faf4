"""What a command compiles on a cold cache, and how long each function takes.

    python benchmarks/compile_time.py [--cache DIR] [--top 25] [--json] -- COMMAND ...

Runs ``cml-edge COMMAND ...`` in this process (``cml_edge.cli.main``) with Numba's cache in
``DIR`` (default: a new empty folder, so everything the command uses compiles; give the
same folder again to time a warm run, which should compile nothing) and listens to Numba's
``numba:compile`` events. A compile nests the compiles of the functions it calls, so each
function's own seconds are its compiles' time minus the time of the compiles nested in
them. Prints the wall and process CPU seconds of the whole run, the number of compiles,
and the functions by their own seconds (with the number of signatures compiled and, for
the outermost compiles, the seconds including what they called). Routed plug-ins
(:mod:`cml_edge.jit.routing`) show as ``<routed>.NAME``. Timings are not seeded: name the
commit and the machine's load with a figure.

Run from the repository root (so that ``cml_edge`` is this checkout's).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from typing import Any


def _listener() -> Any:
    """A ``numba:compile`` listener, one record per compile with the time of the compiles
    nested in it (Numba is imported only once the cache folder is set)."""
    from numba.core import event

    class Compiles(event.Listener):
        def __init__(self) -> None:
            self.stack: list[list[Any]] = []
            self.rows: list[dict[str, Any]] = []

        def on_start(self, ev: Any) -> None:
            func = getattr(ev.data["dispatcher"], "py_func", None)
            module = getattr(func, "__module__", None) or "<routed>"
            self.stack.append([f"{module}.{getattr(func, '__qualname__', '?')}",
                               time.perf_counter(), 0.0])

        def on_end(self, ev: Any) -> None:
            name, t0, nested = self.stack.pop()
            total = time.perf_counter() - t0
            if self.stack:
                self.stack[-1][2] += total
            self.rows.append({"name": name, "total": total, "own": total - nested,
                              "outermost": not self.stack})

    return Compiles()


def main() -> int:
    argv = sys.argv[1:]
    split = argv.index("--") if "--" in argv else len(argv)
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cache", help="Numba's cache folder (default: a new empty one)")
    parser.add_argument("--top", type=int, default=25, help="functions listed (25)")
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    args = parser.parse_args(argv[:split])
    os.environ["NUMBA_CACHE_DIR"] = args.cache or tempfile.mkdtemp(prefix="cml_edge_cold_")
    wall, cpu = time.perf_counter(), time.process_time()
    from numba.core import event

    listener = _listener()
    with event.install_listener("numba:compile", listener), open(os.devnull, "w") as null:
        from cml_edge.cli import main as cml_edge

        stdout, sys.stdout = sys.stdout, null  # the command's own output is not the figure
        try:
            status = cml_edge(argv[split + 1:])
        finally:
            sys.stdout = stdout
    functions: dict[str, dict[str, Any]] = {}
    for row in listener.rows:
        f = functions.setdefault(row["name"], {"own_s": 0.0, "signatures": 0,
                                               "outermost_s": 0.0})
        f["own_s"] += row["own"]
        f["signatures"] += 1
        f["outermost_s"] += row["total"] if row["outermost"] else 0.0
    ranked = sorted(functions.items(), key=lambda kv: -kv[1]["own_s"])[:args.top]
    result = {"command": argv[split + 1:], "status": status, "cache": os.environ["NUMBA_CACHE_DIR"],
              "wall_s": time.perf_counter() - wall, "cpu_s": time.process_time() - cpu,
              "compiles": len(listener.rows),
              "functions": [{"function": name, **f} for name, f in ranked]}
    if args.json:
        print(json.dumps(result, indent=1))
        return 0
    print(f"{' '.join(result['command'])}: exit {status}, {result['wall_s']:.1f} s wall, "
          f"{result['cpu_s']:.1f} s CPU, {result['compiles']} compiles")
    print(f"{'own s':>8} {'with callees s':>15} {'signatures':>10}  function")
    for name, f in ranked:
        outer = f"{f['outermost_s']:.2f}" if f["outermost_s"] else ""
        print(f"{f['own_s']:8.2f} {outer:>15} {f['signatures']:10d}  {name}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
