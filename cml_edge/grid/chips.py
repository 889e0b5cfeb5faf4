"""Monte Carlo over chips: N independent chips through the protocol, and yield.

A chip is the set of physical arrays a model runs on. What it fixes is the **chip seed**:
the seed of the three arrays' device streams (``stream_key(chip, STREAM_DEVICE + index)``,
:class:`cml_edge.backends.crossbar.array.CrossbarArray` and the other devices). Each
array draws from its stream, first, everything fixed at manufacture: on the crossbar its
stuck devices, the device-to-device spreads of the step sizes and up/down asymmetry, the
devices' own bounds, their drift exponents, the first programming's noise; and then, in
the same stream, in order, its cycle-to-cycle draws (pulse, write and read noise); on
the integer devices the stochastic rounding. So the chip seed fixes the chip and its
noise; the **model seed** fixes what the chip is asked to learn: the initial weights
(:meth:`cml_edge.core.cml.CML.create`) and the exploration walks. The evaluation seed
fixes the pairs. Chip c of a run has chip seed ``first + c``; every chip trains the
same model seeds, so chips differ only by the chip. A chip whose seed equals the model
seed is exactly the single-chip run of that seed (``cml-edge emulate`` without
``--chips``). A float array draws nothing, so its chips are all the same.

Each chip is one task of the sweep engine (:mod:`cml_edge.engine.sweep`: local pool or Dask,
one atomic file per chip, resumable in the folder the user names; without one, a temporary
folder removed at the end), running :func:`cml_edge.grid.protocol.run_protocol`
on the run's :class:`~cml_edge.grid.protocol.Protocol` with its chip seed.
:func:`pool_chips` pools the per-chip summaries generically: every numeric key of the
protocol's per-seed summaries (the success rate, e_pos, the decision agreement, ...; a
nested record's as ``key.sub``, so the weight error against the float64 twin is
``weight_error.matrix_mean``) gets its distribution over chips (each chip's mean over
its models); the **yield** is the fraction of chips whose success rate is at least the
yield target.
"""

from __future__ import annotations

import math
import tempfile
import time
from collections.abc import Callable, Sequence
from contextlib import nullcontext
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from cml_edge.engine.sweep import Task, run_sweep
from cml_edge.errors import InputError

if TYPE_CHECKING:
    from cml_edge.grid.protocol import Protocol

DEFAULT_YIELD_TARGET = 0.95
QUANTILES = {"p05": 0.05, "median": 0.5, "p95": 0.95}


def check_chips(n: int, yield_target: float, first: int = 0) -> None:
    """InputError unless ``n`` >= 1, ``yield_target`` is in [0, 1] and the first chip
    seed ``first`` >= 0."""
    if isinstance(n, bool) or not isinstance(n, int) or n < 1:
        raise InputError(f"chips {n!r} is not allowed (allowed: an integer >= 1)")
    if isinstance(first, bool) or not isinstance(first, int) or first < 0:
        raise InputError(f"first chip seed {first!r} is not allowed (allowed: >= 0)")
    if not (isinstance(yield_target, (int, float)) and math.isfinite(yield_target)
            and 0.0 <= yield_target <= 1.0):
        raise InputError(f"yield target {yield_target!r} is not allowed (allowed: 0..1)")


def chip_task(chip: int, protocol: dict[str, Any]) -> dict[str, Any]:
    """One chip through the protocol (a sweep task): the protocol (as
    :meth:`~cml_edge.grid.protocol.Protocol.to_dict`) on chip seed ``chip``, its pooled
    summary and per-seed summaries (no curves, no counters)."""
    from cml_edge.grid.protocol import Protocol, run_protocol

    result = run_protocol(replace(Protocol.from_dict(protocol), chip=chip))
    summary = {k: v for k, v in result.items()
               if isinstance(v, (int, float)) and not isinstance(v, bool)}
    return {"chip": chip, **summary, "per_seed": result["per_seed"]}


def chip_tasks(n: int, protocol: dict[str, Any], first: int = 0) -> list[Task]:
    """The tasks of chips ``first`` .. ``first + n - 1``."""
    return [Task(f"chip-{first + c:06d}", "cml_edge.grid.chips:chip_task",
                 {"chip": first + c, "protocol": protocol}) for c in range(n)]


def _stats(values: Sequence[float]) -> dict[str, float]:
    v = np.asarray(values, dtype=np.float64)
    out = {"mean": float(v.mean()), "std": float(v.std()), "min": float(v.min())}
    out.update({k: float(np.quantile(v, q)) for k, q in QUANTILES.items()})
    out["max"] = float(v.max())
    return out


def _numeric(record: dict[str, Any]) -> dict[str, float]:
    """The numeric values of a per-seed record, a nested record's as ``key.sub``
    (``weight_error.matrix_mean``)."""
    out = {}
    for k, v in record.items():
        if isinstance(v, dict):
            out.update({f"{k}.{sub}": x for sub, x in _numeric(v).items()})
        elif isinstance(v, (int, float)) and not isinstance(v, bool) and k != "seed":
            out[k] = v
    return out


def chip_means(per_seed: Sequence[dict[str, Any]]) -> dict[str, float]:
    """A chip's mean over its models of every numeric per-seed key, nested ones as
    ``key.sub`` (None values left out)."""
    flat = [_numeric(s) for s in per_seed]
    keys = dict.fromkeys(k for s in flat for k in s)
    out = {}
    for k in keys:
        vals = [s[k] for s in flat if k in s]
        if vals:
            out[k] = float(np.mean(vals))
    return out


def chip_yield(success: Sequence[float], target: float) -> float:
    """The fraction of chips whose success rate is at least ``target``."""
    if not len(success):
        raise InputError("no chips")
    return float(np.mean(np.asarray(success, dtype=np.float64) >= target))


def pool_chips(results: Sequence[dict[str, Any]], yield_target: float) -> dict[str, Any]:
    """``{"chips": {...}, "yield": ...}`` from the chips' task results (module docstring)."""
    means = [chip_means(r["per_seed"]) for r in results]
    keys = dict.fromkeys(k for m in means for k in m)
    distribution = {k: _stats([m[k] for m in means if k in m]) for k in keys}
    success = [r["success_rate"] for r in results]
    per_chip = [{"chip": r["chip"], "success_rate": r["success_rate"], **{
        k: v for k, v in m.items() if k != "success_rate"}} for r, m in zip(results, means)]
    return {"chips": {"n": len(results), "chip_seeds": [r["chip"] for r in results],
                      "success_rate": _stats(success), "distribution": distribution,
                      "per_chip": per_chip},
            "yield": chip_yield(success, yield_target), "yield_target": float(yield_target)}


def run_chips(n: int, protocol: Protocol, yield_target: float = DEFAULT_YIELD_TARGET,
              first: int = 0, out: str | Path | None = None, workers: int | None = None,
              scheduler: str | None = None,
              progress: Callable[[int, int], None] | None = None,
              restart: bool = False) -> dict[str, Any]:
    """Chips ``first`` .. ``first + n - 1`` through ``protocol`` (its ``chip`` left unset:
    each chip is one), on the sweep engine; task files under ``out``, so a rerun resumes
    (None: a temporary folder, removed at the end). ``out`` is a run folder of the
    protocol (:mod:`cml_edge.engine.runs`; every chip trains the protocol's seeds, so they
    are among its settings; more chips resume it; ``restart`` starts it over). Returns the
    pooled result (:func:`pool_chips`) with the protocol, the folder (None without
    ``out``) and the wall time."""
    check_chips(n, yield_target, first)
    if protocol.chip is not None:
        raise InputError(f"the protocol's chip {protocol.chip} is set (allowed: None; each "
                         f"chip of the run is given its chip seed)")
    settings = protocol.to_dict()
    t0 = time.perf_counter()
    keep = nullcontext(out) if out is not None else tempfile.TemporaryDirectory(
        prefix="cml-edge-chips-")
    with keep as folder:
        done = run_sweep(chip_tasks(n, settings, first), folder, workers=workers,
                         scheduler=scheduler, progress=progress, resumable=out is not None,
                         settings={"run": "chips", "protocol": settings}, restart=restart)
    return {**pool_chips(list(done.values()), yield_target), "protocol": settings,
            "out": None if out is None else str(out), "wall_time_s": time.perf_counter() - t0}
