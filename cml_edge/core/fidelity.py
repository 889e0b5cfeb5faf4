"""How far a device's CML is from its float64 twin: the metrics that move when success does not.

Success and path overhead saturate: on the empty 30 x 30 arena they stay at 1.000 for
most device settings while the weights the device holds are far from what float64 would
have learned. Three finer measures, each against the **float64 twin**: a CML of the same
seed (so the same initial weights, drawn before any device programs them) trained in
float64 on the same exploration walks (exploration never reads the weights, so the walks
are the same) with the same schedule. The world modules make the twin and replay the
decisions (:mod:`cml_edge.grid.fidelity`, :mod:`cml_edge.robot.fidelity`); the
arithmetic they share is here:

- :func:`weight_error`: per matrix, ||W_dev - W_twin||_F / ||W_twin||_F, W_dev the
  device's effective weights (``to_float``: on a crossbar (G+ - G-) / g_per_w times the
  drift compensation, including any accumulated read-noise draw), taken when the device
  plans (after training and any idle time);
- decision agreement: the fraction of the device's planning decisions at which the twin,
  put in the same state with the same available moves, picks the same move;
- :func:`read_snr`: per matrix, over a seeded sample of the states the device planned
  from, the planning reads (W_q (o* - o) and W_q o, W_v^T d, W_k s) taken by the device
  and computed exactly from its effective weights on the same input:
  SNR = rms(exact) / std(device - exact). It is read from a copy of the device, so the
  run's counters and random stream are untouched. None (JSON null) means not applicable:
  the device's reads differ from the exact ones by no more than float64 rounding
  (``READ_ROUNDING``): it computes as its float64 twin does (the float64 array, the
  ideal crossbar), and the ratio of the reads to their rounding (~1e15) would say nothing
  about the device.

Per-seed values are pooled over seeds by :func:`seed_stats` (mean and spread).
"""

from __future__ import annotations

import copy
from collections.abc import Iterable, Sequence
from typing import Any

import numpy as np

from cml_edge.core.cml import CML
from cml_edge.core.finite import MATRICES

SNR_SAMPLES = 64
"""States sampled per seed for :func:`read_snr` (each gives four reads)."""
READ_ROUNDING = 1e-12
"""The largest read error, relative to the reads' rms, that :func:`read_snr` counts as
float64 rounding rather than the device's (its SNR is then None). float64 arithmetic in
another order errs by ~1e-16, float32 arithmetic by ~1e-7."""
TWIN = ("float64 CML of the same seed (same initial weights) trained on the same walks with "
        "the same schedule: factored path for the per-walk schedule, direct float64 for the "
        "per-step one")


def weight_error(cml: CML, twin: CML) -> dict[str, float | None]:
    """||W_dev - W_twin||_F / ||W_twin||_F per matrix, and their mean (``matrix_mean``).
    None (JSON null) means not applicable: the twin's matrix is zero and the device's is
    not, so no relative error is defined (0.0 when both are zero); the mean is then None."""
    out: dict[str, float | None] = {}
    for name, dev, ref in zip(MATRICES, cml.arrays, twin.arrays):
        W = ref.to_float()
        norm = float(np.linalg.norm(W))
        diff = float(np.linalg.norm(dev.to_float() - W))
        out[name] = diff / norm if norm > 0 else (0.0 if diff == 0 else None)
    values = [out[m] for m in MATRICES]
    out["matrix_mean"] = None if None in values else float(np.mean(values))
    return out


def read_snr(cml: CML, states: Iterable[tuple[np.ndarray, np.ndarray]]) -> dict[str, Any]:
    """Per matrix, rms(exact) / std(device - exact) of the planning reads at ``states``
    (pairs (o, o* - o)); read from a copy of ``cml`` (module docstring). None: not
    applicable, the read error is float64 rounding at most (``READ_ROUNDING``); ``reads``
    counts the reads per matrix."""
    dev = copy.deepcopy(cml)
    Wq, Wk, Wv = (a.to_float() for a in cml.arrays)
    got: dict[str, list[np.ndarray]] = {m: [] for m in MATRICES}
    exact: dict[str, list[np.ndarray]] = {m: [] for m in MATRICES}
    for o, dgo in states:
        d = dev.W_q.matvec(dgo)
        s = dev.W_q.matvec(o)
        got["W_q"] += [d, s]
        exact["W_q"] += [Wq @ dgo, Wq @ o]
        got["W_v"].append(dev.W_v.rmatvec(d))
        exact["W_v"].append(Wv.T @ d)
        got["W_k"].append(dev.W_k.matvec(s))
        exact["W_k"].append(Wk @ s)
    out: dict[str, Any] = {}
    for m in MATRICES:
        if not got[m]:
            out[m] = None
            continue
        y, x = np.concatenate(got[m]), np.concatenate(exact[m])
        noise = float(np.std(y - x))
        rms = float(np.sqrt(np.mean(x * x)))
        out[m] = rms / noise if noise > READ_ROUNDING * rms else None
    out["reads"] = len(got["W_k"])
    return out


def sample_indices(n: int, seed: int, stream: int, k: int = SNR_SAMPLES) -> np.ndarray:
    """``k`` of ``range(n)`` (all of them if fewer), sorted, from a generator keyed
    [seed, stream]."""
    if n <= k:
        return np.arange(n)
    return np.sort(np.random.default_rng([int(seed), int(stream)]).choice(n, k, replace=False))


def seed_stats(values: Sequence[float | None]) -> dict[str, Any]:
    """Mean and spread over seeds: mean, std (sample, ddof 1; 0 for one seed), min, max, n.
    A None among the values (a figure not applicable: a read SNR of float64 rounding)
    makes mean, std and max None. A NaN or an infinity is not hidden: it makes the
    statistics non-finite, which :mod:`cml_edge.core.finite` refuses to write."""
    vals = list(values)
    if not vals:
        return {"mean": None, "std": None, "min": None, "max": None, "n": 0}
    if any(v is None for v in vals):
        known = [v for v in vals if v is not None]
        return {"mean": None, "std": None, "min": float(np.min(known)) if known else None,
                "max": None, "n": len(vals)}
    a = np.asarray(vals, dtype=float)
    return {"mean": float(a.mean()), "std": float(a.std(ddof=1)) if len(a) > 1 else 0.0,
            "min": float(a.min()), "max": float(a.max()), "n": len(a)}


def pool_seeds(per_seed: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """The seed means and spreads of a list of per-seed fidelity records (each with
    ``weight_error``, ``decision_agreement`` and ``read_snr``)."""
    if not per_seed:
        return {}
    keys = (*MATRICES, "matrix_mean")
    return {
        "weight_error": {k: seed_stats([r["weight_error"][k] for r in per_seed]) for k in keys},
        "decision_agreement": seed_stats([r["decision_agreement"] for r in per_seed]),
        "read_snr": {m: seed_stats([r["read_snr"][m] for r in per_seed]) for m in MATRICES},
    }
