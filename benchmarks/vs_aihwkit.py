"""One CML training step and one planning step on IBM aihwkit's tiles and on the project.

    python benchmarks/vs_aihwkit.py [--steps 2000] [--repeats 5] [--rows TEXT ...] [--json]

The shapes of the 30 x 30 protocol's CML (model seed 0): W_q 256 x 2, W_k 8 x 256, W_v 256 x
8. A training step is, on each of the three arrays, one forward read and one pulsed rank-one
update applied at once (the per-step pulsed schedule: the project's ``outer_update`` with
``defer`` False; aihwkit's ``update``), with the vectors of a training step (W_q: o and the
error, W_k: s and the affordance error, W_v: a one-hot action and the error, drawn once from
seed 0) and the learning rate 0.01. The same schedule on aihwkit: the same vectors, each
tile's learning rate scaled by aihwkit's weight granularity over the project array's dw_min
(the weight either controller counts a pulse as), so the pulse trains have the same length
and the same expected coincidences per device. A planning step is one forward and one
transposed read of each. The project's step is a compiled loop through the seam
(:mod:`cml_edge.backends.dispatch`); aihwkit's runs in its own environment (``bash
scripts/aihwkit_env.sh``), through its public tile API and through the bare compiled tile
the API wraps. One process and one thread each (torch and aihwkit's OpenMP set to 1 thread);
microseconds of process CPU time per step, the median of ``repeats`` runs of ``steps`` steps
after a warm-up (the project's also as ``*_min_us``, their minimum).

Pairs, chosen so that both sides pulse as many devices per coincidence (a pulse of a row's
train meeting one of a column's): ``float`` against aihwkit's floating-point tile (no
pulses); ``crossbar:pcm`` with ``refresh=false`` (a SET-only G+/G- pair: one device pulsed
per coincidence, up) against ``PCMPresetDevice`` in a ``OneSidedUnitCell`` without refresh
(the same); ``crossbar:pcm`` (the same pair with its open-loop refresh) against the
``PCMPresetUnitCell`` (the SET-only pair with refresh the preset models: the same cell,
checked for refresh after every update, refreshed with noisy reads and pulsed rewrites);
``crossbar:reram`` (a pair pulsed push-pull: both devices per coincidence, one up, one
down) against two ``ReRamSBPresetDevice``s in a ``VectorUnitCell`` with update policy ALL
(both devices pulsed per coincidence, the same way: its weight is their mean); and one
device per weight on both sides: ``crossbar:reram`` and ``crossbar:pcm`` with
``mapping=single`` (for ``pcm`` also ``set_only=false`` and ``refresh=false``, as the lone
device is pulsed both ways) against the lone device on ``SingleRPUConfig``.
``--rows`` runs the rows whose label holds one of its texts (case-insensitive: ``--rows
float VectorUnitCell``). aihwkit's weight granularity of a two-device cell of one preset is
the mean of its devices', the device's own, so a device and its cell get the same learning
rate.

Run from the repository root (so that ``cml_edge`` is this checkout's).
"""

from __future__ import annotations

import argparse
import json
import statistics
import time

import numpy as np
from numba import njit

from cml_edge.backends.crossbar.aihwkit import runner
from cml_edge.backends.dispatch import sa_matvec, sa_outer_update, sa_rmatvec
from cml_edge.bench.timing import label, parse_name
from cml_edge.core.cml import CML, CMLConfig

LR = 0.01
PAIRS = (("float", (), "float", None),
         ("crossbar:pcm", ("refresh=false",), "PCMPresetDevice", "one-sided"),
         ("crossbar:pcm", (), "PCMPresetUnitCell", None),
         ("crossbar:reram", (), "ReRamSBPresetDevice", "vector"),
         ("crossbar:reram", ("mapping=single",), "ReRamSBPresetDevice", "single"),
         ("crossbar:pcm", ("mapping=single", "set_only=false", "refresh=false"),
          "PCMPresetDevice", "single"))
"""(the project's backend, its ``--set`` settings, aihwkit's device, aihwkit's cell: the
worker's ``bench`` ``cell``, None for a unit-cell preset as it is or the float tile)"""
CELLS = {"single": "1 device, SingleRPUConfig", "one-sided": "OneSidedUnitCell pair, no refresh",
         "vector": "2-device VectorUnitCell"}


def their_label(device: str, cell: str | None) -> str:
    """aihwkit's side of a row: the device and the cell it is pulsed in."""
    return f"{device} ({CELLS[cell]})" if cell else device


@njit
def _train(q, k, v, xq, xk, xv, dq, dk, dv, oq, ok, ov, lr, n):
    for _ in range(n):
        sa_matvec(q, xq, oq)
        sa_outer_update(q, dq, xq, lr, False)
        sa_matvec(k, xk, ok)
        sa_outer_update(k, dk, xk, lr, False)
        sa_matvec(v, xv, ov)
        sa_outer_update(v, dv, xv, lr, False)


@njit
def _plan(q, k, v, xq, xk, xv, dq, dk, dv, oq, ok, ov, tq, tk, tv, n):
    for _ in range(n):
        sa_matvec(q, xq, oq)
        sa_rmatvec(q, dq, tq)
        sa_matvec(k, xk, ok)
        sa_rmatvec(k, dk, tk)
        sa_matvec(v, xv, ov)
        sa_rmatvec(v, dv, tv)


def vectors() -> tuple[list[np.ndarray], list[np.ndarray]]:
    """The inputs (xs) and the updates' post-synaptic factors (ds) of W_q, W_k, W_v."""
    rng = np.random.default_rng(0)
    a = np.zeros(8)
    a[2] = 1.0
    xs = [np.array([0.3, -0.4]), rng.normal(0.0, 0.05, 256), a]
    ds = [rng.normal(0.0, 0.01, 256), rng.normal(0.0, 0.3, 8), rng.normal(0.0, 0.01, 256)]
    return xs, ds


def project(name: str, steps: int, repeats: int,
            settings: tuple[str, ...] = ()) -> dict[str, float]:
    """Microseconds per training and planning step of the project's backend ``name`` with
    ``settings`` (``field=value`` texts)."""
    backend, options = parse_name(name, settings)
    xs, ds = vectors()
    outs = [np.zeros(256), np.zeros(8), np.zeros(256)]
    tr = [np.zeros(2), np.zeros(256), np.zeros(8)]
    figures = {}
    for key, run, extra in (("train", _train, (LR,)), ("plan", _plan, tuple(tr))):
        cml = CML.create(CMLConfig.for_arena(30), backend, 0, **options)
        states = [arr.state for arr in cml.arrays]
        run(*states, *xs, *ds, *outs, *extra, 1)  # compile and warm up
        runs = []
        for _ in range(repeats):
            t0 = time.process_time()
            run(*states, *xs, *ds, *outs, *extra, steps)
            runs.append((time.process_time() - t0) / steps * 1e6)
        figures[f"{key}_us"] = statistics.median(runs)
        figures[f"{key}_min_us"] = min(runs)  # the figure other jobs move least
    return figures


@njit
def _update(state, post, pre, lr, n):
    for _ in range(n):
        sa_outer_update(state, post, pre, lr, False)


def per_array(name: str, steps: int, repeats: int,
              settings: tuple[str, ...] = ()) -> list[dict[str, float]]:
    """The training step's pulsed update of each array alone (W_q, W_k, W_v): the minimum
    microseconds per update over ``repeats`` runs of ``steps``, and per update the
    coincidences, device pulses and words drawn (the array's counters)."""
    backend, options = parse_name(name, settings)
    xs, ds = vectors()
    out = []
    for arr, x, d in zip(CML.create(CMLConfig.for_arena(30), backend, 0, **options).arrays,
                         xs, ds):
        _update(arr.state, d, x, LR, 1)  # compile and warm up
        before = dict(arr.counters)
        runs = []
        for _ in range(repeats):
            t0 = time.process_time()
            _update(arr.state, d, x, LR, steps)
            runs.append((time.process_time() - t0) / steps * 1e6)
        n = steps * repeats
        out.append({"shape": arr.shape, "update_min_us": min(runs),
                    **{k: (arr.counters[k] - before[k]) / n
                       for k in ("coincidences", "device_pulses", "rng_draws")}})
    return out


def pulse_weights(name: str, settings: tuple[str, ...] = ()) -> list[float] | None:
    """The weight the project's controller counts one pulse as, per array (W_q, W_k, W_v;
    None: a float array, no pulses)."""
    backend, options = parse_name(name, settings)
    states = [a.state for a in CML.create(CMLConfig.for_arena(30), backend, 0,
                                          **options).arrays]
    if not hasattr(getattr(states[0], "params", None), "dw_min"):
        return None
    return [float(s.params.dw_min) for s in states]


def theirs(device: str, dw_min: list[float] | None, steps: int,
           repeats: int, cell: str | None = None) -> dict[str, float]:
    """Microseconds per step on aihwkit's tiles of ``device`` in ``cell`` (public API and bare
    tile), each tile's learning rate scaled so that its expected pulses per device and its
    pulse-train length are the project array's: lr x aihwkit's weight granularity (the
    device's: a cell of two of it has the same) / the array's dw_min."""
    xs, ds = vectors()
    lrs = [LR] * 3
    if dw_min is not None:
        g = runner.run("params", name=device)["granularity"]
        lrs = [LR * g / d for d in dw_min]
    r = runner.run("bench", device=device, cell=cell, shapes=[[256, 2], [8, 256], [256, 8]],
                   xs=[x.tolist() for x in xs], ds=[(-d).tolist() for d in ds], lrs=lrs,
                   seed=0, steps=steps, repeats=repeats)
    return {k.replace("_s", "_us"): v * 1e6 for k, v in r.items() if k.endswith("_s")}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=2000)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--rows", nargs="+", action="extend", metavar="TEXT",
                    help="only the rows whose label holds one of these (case-insensitive)")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    pairs = [pair for pair in PAIRS if args.rows is None or any(
        t.lower() in f"{label(*pair[:2])} {their_label(*pair[2:])}".lower() for t in args.rows)]
    if not pairs:
        ap.error(f"no row matches {args.rows}")
    runner.require()
    for name, settings, _, _ in pairs:  # an unknown setting fails before any timing
        parse_name(name, settings)
    ours = {(name, settings): (pulse_weights(name, settings),
                                project(name, args.steps, args.repeats, settings))
            for name, settings, _, _ in pairs}
    rows = []
    for name, settings, device, cell in pairs:
        dw_min, p = ours[name, settings]
        a = theirs(device, dw_min, max(args.steps // 10, 10), args.repeats, cell)
        rows.append({"project": label(name, settings), "aihwkit": their_label(device, cell),
                     "device": device, "cell": cell,
                     **{f"project_{k}": v for k, v in p.items()},
                     **{f"aihwkit_{k}": v for k, v in a.items()},
                     **{f"{s}_x_{api}": a[f"{s}_{api}_us"] / p[f"{s}_us"]
                        for s in ("train", "plan") for api in ("public", "bare")}})
    if args.json:
        print(json.dumps(rows, indent=1))
        return
    print("us per step (process CPU, 1 thread); x: aihwkit's time / the project's")
    wp, wa = (max(len(r[k]) for r in rows) for k in ("project", "aihwkit"))
    print(f"{'project':{wp}} {'aihwkit':{wa}} {'train':>8} {'public':>9} {'x':>6} {'bare':>9} "
          f"{'x':>6} {'plan':>8} {'public':>9} {'x':>6} {'bare':>9} {'x':>6}")
    for r in rows:
        print(f"{r['project']:{wp}} {r['aihwkit']:{wa}} {r['project_train_us']:8.2f} "
              f"{r['aihwkit_train_public_us']:9.1f} {r['train_x_public']:6.1f} "
              f"{r['aihwkit_train_bare_us']:9.1f} {r['train_x_bare']:6.1f} "
              f"{r['project_plan_us']:8.2f} {r['aihwkit_plan_public_us']:9.1f} "
              f"{r['plan_x_public']:6.1f} {r['aihwkit_plan_bare_us']:9.1f} "
              f"{r['plan_x_bare']:6.1f}")


if __name__ == "__main__":
    main()
