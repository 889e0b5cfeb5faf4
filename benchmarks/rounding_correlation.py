"""Shared against independent stochastic-rounding draws on the ``loihi2`` array.

    python benchmarks/rounding_correlation.py [--epochs 100 900] [--trials 50] [--json]

Lava's learning engine model rounds every synapse's accumulator with ONE uniform draw per
epoch (``ConnVarRandom``), so the rounding errors of all synapses in an epoch are
correlated; ``--draws independent`` gives each synapse its own. This measures it on the
array itself, with W_k's shape (8 x 256 = 2,048 synapses): an update per synapse
(lr post pre^T, post and pre uniform in [-1, 1] from the trial's seed, drawn afresh each
epoch so that no weight drifts into saturation, at most half a weight LSB) is applied once
per epoch (``outer_update(defer=True)`` then ``commit``) for
``epochs`` epochs. Each epoch's rounding error of a synapse is its written-back weight
minus the accumulator before the write-back (in weight LSB), which isolates the rounding
from the engine's term formation. Reported, per draw mode and epoch count, over trials:

- ``array_mean_error_lsb``: the RMS over trials of the array-mean cumulative rounding
  error (the mean over synapses of each synapse's summed error);
- ``synapse_error_lsb``: the RMS cumulative error of one synapse;
- ``correlation``: the mean pairwise correlation of the synapses' cumulative errors,
  from var(mean) = sigma^2 / n (1 + (n - 1) rho);
- the theory for uniform fractions: shared sqrt(epochs / 12); independent
  sqrt(epochs / (6 n)) (the fraction f rounds with variance f (1 - f), mean 1/6).

Run from the repository root (so that ``cml_edge`` is this checkout's).
"""

from __future__ import annotations

import argparse
import json
import math

import numpy as np

from cml_edge.backends.loihi2.array import Loihi2Array

SHAPE = (8, 256)


def run(draws: str, epochs: int, trials: int) -> dict[str, float]:
    n = SHAPE[0] * SHAPE[1]
    means, synapse_sq = [], []
    for t in range(trials):
        rng = np.random.default_rng(t)
        W = np.zeros(SHAPE)
        W[0, 0] = 127 / 256  # fixes the scale: LSB 2^-9 (the cell is left out below)
        arr = Loihi2Array.from_float(W, seed=t, index=1, draws=draws)
        lr = 2.0**-10  # |dw| <= 2^-10 = half an LSB
        total = np.zeros(SHAPE)
        for _ in range(epochs):
            post, pre = rng.uniform(-1, 1, SHAPE[0]), rng.uniform(-1, 1, SHAPE[1])
            arr.outer_update(post, pre, lr, defer=True)
            before = arr.state.acc.astype(np.float64) / 128
            arr.commit()
            total += arr.state.w - before
        err = total.ravel()[1:]
        means.append(err.mean())
        synapse_sq.append(np.mean(err**2))
    var_mean = float(np.mean(np.square(means)))
    sigma2 = float(np.mean(synapse_sq))
    m = n - 1
    return {"draws": draws, "epochs": epochs, "trials": trials, "synapses": m,
            "array_mean_error_lsb": math.sqrt(var_mean),
            "synapse_error_lsb": math.sqrt(sigma2),
            "correlation": (m * var_mean / sigma2 - 1) / (m - 1),
            "theory_lsb": math.sqrt(epochs / 12) if draws == "shared"
            else math.sqrt(epochs / (6 * m))}


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--epochs", type=int, nargs="+", default=[100, 900])
    p.add_argument("--trials", type=int, default=50)
    p.add_argument("--json", action="store_true")
    args = p.parse_args()
    rows = [run(d, e, args.trials) for e in args.epochs for d in ("shared", "independent")]
    if args.json:
        print(json.dumps(rows, indent=1))
        return
    print("| draws | epochs | array-mean error (LSB) | theory | one synapse (LSB) | "
          "correlation |")
    print("|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['draws']} | {r['epochs']} | {r['array_mean_error_lsb']:.3f} | "
              f"{r['theory_lsb']:.3f} | {r['synapse_error_lsb']:.3f} | "
              f"{r['correlation']:.3f} |")


if __name__ == "__main__":
    main()
