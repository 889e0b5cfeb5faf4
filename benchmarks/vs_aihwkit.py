"""One CML training step and one planning step on IBM aihwkit's tiles and on the project.

    python benchmarks/vs_aihwkit.py [--steps 2000] [--repeats 5] [--json]

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

Pairs: ``float`` against aihwkit's floating-point tile, ``crossbar:pcm`` with ``refresh=false``
against the lone ``PCMPresetDevice`` (which has no refresh), ``crossbar:pcm`` (its open-loop
refresh) against the ``PCMPresetUnitCell`` (the SET-only pair with refresh the preset
models), ``crossbar:reram`` against ``ReRamSBPresetDevice``.

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
PAIRS = (("float", (), "float"), ("crossbar:pcm", ("refresh=false",), "PCMPresetDevice"),
         ("crossbar:pcm", (), "PCMPresetUnitCell"),
         ("crossbar:reram", (), "ReRamSBPresetDevice"))
"""(the project's backend, its ``--set`` settings, aihwkit's device)"""


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
           repeats: int) -> dict[str, float]:
    """Microseconds per step on aihwkit's tiles (public API and bare tile), each tile's
    learning rate scaled so that its expected pulses per device and its pulse-train length
    are the project array's: lr x aihwkit's weight granularity / the array's dw_min."""
    xs, ds = vectors()
    lrs = [LR] * 3
    if dw_min is not None:
        g = runner.run("params", name=device)["granularity"]
        lrs = [LR * g / d for d in dw_min]
    r = runner.run("bench", device=device, shapes=[[256, 2], [8, 256], [256, 8]],
                   xs=[x.tolist() for x in xs], ds=[(-d).tolist() for d in ds], lrs=lrs,
                   seed=0, steps=steps, repeats=repeats)
    return {k.replace("_s", "_us"): v * 1e6 for k, v in r.items() if k.endswith("_s")}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=2000)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    runner.require()
    ours = {(name, settings): (pulse_weights(name, settings),
                                project(name, args.steps, args.repeats, settings))
            for name, settings, _ in PAIRS}
    rows = []
    for name, settings, device in PAIRS:
        dw_min, p = ours[name, settings]
        a = theirs(device, dw_min, max(args.steps // 10, 10), args.repeats)
        rows.append({"project": label(name, settings), "aihwkit": device,
                     **{f"project_{k}": v for k, v in p.items()},
                     **{f"aihwkit_{k}": v for k, v in a.items()},
                     **{f"{s}_x_{api}": a[f"{s}_{api}_us"] / p[f"{s}_us"]
                        for s in ("train", "plan") for api in ("public", "bare")}})
    if args.json:
        print(json.dumps(rows, indent=1))
        return
    print("us per step (process CPU, 1 thread); x: aihwkit's time / the project's")
    print(f"{'project':30} {'aihwkit':22} {'train':>8} {'public':>9} {'x':>6} {'bare':>9} "
          f"{'x':>6} {'plan':>8} {'public':>9} {'x':>6} {'bare':>9} {'x':>6}")
    for r in rows:
        print(f"{r['project']:30} {r['aihwkit']:22} {r['project_train_us']:8.2f} "
              f"{r['aihwkit_train_public_us']:9.1f} {r['train_x_public']:6.1f} "
              f"{r['aihwkit_train_bare_us']:9.1f} {r['train_x_bare']:6.1f} "
              f"{r['project_plan_us']:8.2f} {r['aihwkit_plan_public_us']:9.1f} "
              f"{r['plan_x_public']:6.1f} {r['aihwkit_plan_bare_us']:9.1f} "
              f"{r['plan_x_bare']:6.1f}")


if __name__ == "__main__":
    main()
