"""Many chips on a Dask cluster of local workers: throughput, and the same results as the pool.

    python benchmarks/dask_scaling.py [--chips 100] [--workers 1 2 4] [--json] [-- OPTION ...]

The sweep is ``cml-edge emulate --backend crossbar --chips N --seeds 1`` (the ``pcm``
preset, the full protocol per chip: 100 walks x 900 steps, 100 pairs, one model seed),
run through the command itself (:func:`cml_edge.cli.main` with ``--json``). It runs once
on the local process pool (``--workers 2``, no scheduler): the reference. Then, for each n
of ``--workers``, a :class:`distributed.LocalCluster` of n worker processes, one thread each,
is started, the same sweep runs on it (``--scheduler ADDRESS``), and the cluster is closed.
Options after ``--`` go to every run of ``emulate`` (a smaller training per chip for a
sweep of many chips, e.g. ``-- --walks 30 --trials 25``). Every run writes to a fresh
``--chips-out`` folder (in a temporary folder removed at the
end), so nothing is resumed.

Each run is checked against the reference: its JSON and every chip's task file, minus
what depends on the run (:data:`RUN_DEPENDENT`: wall times, timings, the output folder, the
command line and the task files' checksums), must be equal. The table gives, per run, the
wall time of the command (the cluster already started, but its workers' first task loads
the compiled kernels, a few seconds) and the chips per minute it makes (chips / wall time).
A chip costs about 0.33 s of one free core (training 90,000 steps), so the default 100
chips take about 2 minutes in all on 2 free cores (9 under the load of the figures in
benchmarks/README.md).

Run from the repository root, with this checkout's ``cml_edge`` importable (it is when
installed from here; else ``PYTHONPATH=$PWD``); the Dask workers inherit it.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import logging
import tempfile
import time
from pathlib import Path
from typing import Any

from cml_edge.cli import main as cml_edge

RUN_DEPENDENT = ("wall_time_s", "timings", "out", "command", "checksum")
"""Keys that differ between two runs of the same sweep (a nested ``timings.X`` too); a task
file's checksum covers its result, wall time included."""
REFERENCE_WORKERS = 2  # the local process pool's


def comparable(doc: Any) -> Any:
    """``doc`` without the keys of :data:`RUN_DEPENDENT`, at any depth."""
    if isinstance(doc, dict):
        return {k: comparable(v) for k, v in doc.items()
                if k not in RUN_DEPENDENT and not k.startswith("timings.")}
    if isinstance(doc, list):
        return [comparable(v) for v in doc]
    return doc


def emulate_chips(chips: int, out: Path, options: list[str]) -> tuple[dict[str, Any], float]:
    """``cml-edge emulate --backend crossbar --chips CHIPS --seeds 1 --chips-out OUT
    OPTIONS --json``: its JSON and its wall time (s)."""
    argv = ["emulate", "--backend", "crossbar", "--chips", str(chips), "--seeds", "1",
            "--chips-out", str(out), *options, "--json"]
    stdout = io.StringIO()
    t0 = time.perf_counter()
    with contextlib.redirect_stdout(stdout):
        code = cml_edge(argv)
    wall = time.perf_counter() - t0
    if code != 0:
        raise RuntimeError(f"cml-edge {' '.join(argv)} exited with {code}")
    return json.loads(stdout.getvalue()), wall


def chip_files(out: Path) -> dict[str, Any]:
    """Every chip's task file under ``out``, comparable."""
    return {p.name: comparable(json.loads(p.read_text()))
            for p in sorted((out / "tasks").glob("*.json"))}


def measure(chips: int, workers: list[int], folder: Path,
            options: list[str] | None = None) -> list[dict[str, Any]]:
    """The reference on the pool, then the sweep on a LocalCluster of each n of ``workers``;
    one row per run. ``options``: more ``emulate`` options (e.g. a smaller training)."""
    options = list(options or [])
    out = folder / "pool"
    result, wall = emulate_chips(chips, out, [*options, "--workers", str(REFERENCE_WORKERS)])
    reference = (comparable(result), chip_files(out))
    assert len(reference[1]) == chips
    rows = [{"run": "pool", "workers": REFERENCE_WORKERS, "chips": chips, "wall_s": wall,
             "identical": True}]
    from distributed import LocalCluster

    for n in workers:
        with LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                          dashboard_address=None, silence_logs=logging.CRITICAL) as cluster:
            out = folder / f"dask-{n}"
            result, wall = emulate_chips(chips, out,
                                         [*options, "--scheduler", cluster.scheduler_address])
        same = (comparable(result), chip_files(out)) == reference
        rows.append({"run": "dask", "workers": n, "chips": chips, "wall_s": wall,
                     "identical": same})
    for row in rows:
        row["chips_per_min"] = 60.0 * row["chips"] / row["wall_s"]
    return rows


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--chips", type=int, default=100)
    p.add_argument("--workers", type=int, nargs="+", default=[1, 2, 4])
    p.add_argument("--json", action="store_true")
    p.add_argument("options", nargs=argparse.REMAINDER,
                   help="after --: more options of every emulate run")
    args = p.parse_args()
    options = args.options[1:] if args.options[:1] == ["--"] else args.options
    with tempfile.TemporaryDirectory(prefix="dask-scaling-") as folder:
        rows = measure(args.chips, args.workers, Path(folder), options)
    if args.json:
        print(json.dumps(rows, indent=1))
        return
    print("| run | workers | chips | wall s | chips per minute | identical |")
    print("|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['run']} | {r['workers']} | {r['chips']} | {r['wall_s']:.1f} | "
              f"{r['chips_per_min']:.0f} | {'yes' if r['identical'] else 'no'} |")


if __name__ == "__main__":
    main()
