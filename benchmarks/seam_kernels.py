"""CPU time of one call of each seam kernel of a device, as the training step makes them.

    python benchmarks/seam_kernels.py [BACKEND[:PRESET] ...] [--calls 100000] [--json]

For each named array device (default ``float int8 loihi2 crossbar:ideal crossbar:pcm``),
on the CML of the 30 x 30 protocol (model seed 0): the reads of a training step
(``W_q o``, a 2-input read with 256 outputs; ``W_k s``, 256 inputs and 8 outputs;
``W_v a``, a one-hot action) and its three updates into the per-walk accumulator
(``W_k``: 8 x 256 cells; ``W_v``: one column; ``W_q``: two columns), with fixed nonzero
vectors drawn once from seed 0, each called ``calls`` times in a compiled loop through
the seam (:mod:`cml_edge.backends.dispatch`); and the ``commit`` of the three arrays
after a walk of 900 learning steps between one pair of observations (the median over 5
walks, each on a fresh model). Microseconds of process CPU time per call, after a
warm-up call. The figures are the kernels' own cost; ``cml-edge bench`` gives the whole
step.

Run from the repository root (so that ``cml_edge`` is this checkout's).
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np
from numba import njit

from cml_edge.backends.dispatch import sa_commit, sa_matvec, sa_outer_update
from cml_edge.bench.timing import parse_name
from cml_edge.core.cml import CML, CMLConfig
from cml_edge.core.step import SeamLearner, learn

DEFAULT = ("float", "int8", "loihi2", "crossbar:ideal", "crossbar:pcm")
LR = 1e-3
COMMITS = 5  # walks, each on a fresh model; the median commit is reported


@njit
def _reads(state, x, out, n):
    for _ in range(n):
        sa_matvec(state, x, out)


@njit
def _updates(state, post, pre, n):
    for _ in range(n):
        sa_outer_update(state, post, pre, LR, True)


@njit
def _walk(learner, o_t, o_1):
    for t in range(900):
        learn(learner, o_t, o_1, t % 8)


def _per_call(run, *args, calls: int) -> float:
    run(*args, 1)  # compile and warm up
    t0 = time.process_time()
    run(*args, calls)
    return (time.process_time() - t0) / calls * 1e6


def kernel_figures(name: str, calls: int) -> dict[str, float]:
    """The figures of one device (module docstring), microseconds per call."""
    backend, options = parse_name(name)

    def model() -> CML:
        return CML.create(CMLConfig.for_arena(30), backend, 0, **options)

    rng = np.random.default_rng(0)
    s = rng.normal(0.0, 0.05, 256)
    g = rng.normal(0.0, 0.3, 8)
    e = rng.normal(0.0, 0.01, 256)
    a = np.zeros(8)
    a[2] = 1.0
    o = np.array([0.3, -0.4])
    out: dict[str, float] = {}
    q, k, v = (arr.state for arr in model().arrays)
    for key, state, x, n_out in (("read_q", q, o, 256), ("read_k", k, s, 8),
                                 ("read_v", v, a, 256)):
        out[f"{key}_us"] = _per_call(_reads, state, x, np.zeros(n_out), calls=calls)
    q, k, v = (arr.state for arr in model().arrays)
    for key, state, post, pre in (("update_k", k, g, s), ("update_v", v, e, a),
                                  ("update_q", q, -e, o)):
        out[f"{key}_us"] = _per_call(_updates, state, post, pre, calls=calls)
    times = []
    for _ in range(COMMITS + 1):  # the first walk and commit compile and warm up
        cml = model()
        _walk(SeamLearner.of(cml, True), o, o + np.array([0.02, 0.0]))
        t0 = time.process_time()
        for arr in cml.arrays:
            sa_commit(arr.state)
        times.append((time.process_time() - t0) * 1e6)
    out["commit_after_walk_us"] = float(np.median(times[1:]))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("devices", nargs="*", default=list(DEFAULT))
    ap.add_argument("--calls", type=int, default=100_000)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    result = {name: kernel_figures(name, args.calls) for name in args.devices}
    if args.json:
        print(json.dumps(result, indent=1))
        return
    for name, figs in result.items():
        print(name, "  ".join(f"{k[:-3]} {v:.3g}" for k, v in figs.items()), "(us per call)")


if __name__ == "__main__":
    main()
