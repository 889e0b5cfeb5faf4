"""Non-finite values: looked for at the end of each phase of a run, never written.

A device setting within its documented range can still make a run's numbers overflow
(a drift time far beyond the drift model's validity turns conductances into NaN). So a
run checks what each phase produced: the three matrices W_q, W_k, W_v after training
(:func:`check_weights`, called by the grid's and the robot's training) and after the idle
time between training and use (drift), and the metrics after evaluation, when they are
serialised. A NaN or an infinity found ends the run as failed with
:class:`NonFiniteError`: one line naming the device, the phase and the matrix or the
metric. ``cml-edge`` prints it as ``cml-edge: error: run failed: ...`` and exits with
status 1 (status 2 is bad input, refused before any work).

Every JSON that cml-edge writes (``--json`` on stdout, result and task files) goes through
:func:`dumps`: strict JSON, never a bare ``NaN`` or ``Infinity``. A figure that does not
apply is null because the code that computes it says so (and documents it: a read SNR of
float64 rounding, a path overhead with no trial reaching its goal); :func:`dumps` never
turns a non-finite number into null, it refuses it.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from typing import Any

import numpy as np

MATRICES = ("W_q", "W_k", "W_v")
"""The CML's three matrices, in the order of ``CML.arrays``."""


class NonFiniteError(RuntimeError):
    """A run whose weights, reads or metrics hold NaN or infinity: the run failed. The
    message names the device, the phase and the matrix or metric; exit status 1."""


def device_name(cml: Any) -> str:
    """The CML's backend, with its preset where the device has one (``crossbar (preset
    pcm)``)."""
    preset = getattr(cml.arrays[0], "preset", None)
    return f"{cml.backend} (preset {preset})" if preset else str(cml.backend)


def _kind(a: np.ndarray) -> str:
    return "NaN" if np.isnan(a).any() else "infinity"


def check_weights(cml: Any, phase: str, seed: int | None = None) -> None:
    """Raise :class:`NonFiniteError` if any of the CML's effective weights (``to_float``)
    is NaN or infinite after ``phase`` (``training``, ``drift``); ``seed`` names the model."""
    for name, arr in zip(MATRICES, cml.arrays):
        with np.errstate(all="ignore"):  # the line below says it, not a NumPy warning
            W = arr.to_float()
        if not np.isfinite(W).all():
            which = "" if seed is None else f" of seed {int(seed)}"
            bad = int(np.size(W) - np.isfinite(W).sum())
            raise NonFiniteError(
                f"run failed: {device_name(cml)} produced {_kind(W)} in {name}{which} "
                f"after {phase} ({bad:,} of {W.size:,} weights); nothing written")


def first_non_finite(obj: Any, where: str = "") -> tuple[str, float] | None:
    """The first number in ``obj`` (nested mappings, lists, tuples, arrays) that is NaN or
    infinite, as (its key path, e.g. ``per_seed[0].read_snr.W_q``, the value); None if
    there is none."""
    if isinstance(obj, (float, np.floating)):
        return None if math.isfinite(obj) else (where or "the value", float(obj))
    if isinstance(obj, np.ndarray):
        if obj.dtype.kind in "fc" and not np.isfinite(obj).all():
            i = int(np.flatnonzero(~np.isfinite(obj))[0])
            return f"{where}[{i}]", float(obj.reshape(-1)[i])
        return None
    if isinstance(obj, Mapping):
        items = ((f"{where}.{k}" if where else str(k), v) for k, v in obj.items())
    elif isinstance(obj, (list, tuple)):
        items = ((f"{where}[{i}]", v) for i, v in enumerate(obj))
    else:
        return None
    for key, v in items:
        found = first_non_finite(v, key)
        if found is not None:
            return found
    return None


def check_finite(obj: Any, phase: str | None = None) -> None:
    """Raise :class:`NonFiniteError` naming the first non-finite number of a result
    (:func:`first_non_finite`), the device (its ``backend`` key, if any) and the
    ``phase`` that produced it, if known."""
    found = first_non_finite(obj)
    if found is None:
        return
    key, value = found
    backend = obj.get("backend") if isinstance(obj, Mapping) else None
    device = f"{backend} " if isinstance(backend, str) else ""
    after = f" after {phase}" if phase else ""
    raise NonFiniteError(f"run failed: {device}metric {key} is {value}{after}; "
                         f"nothing written")


def dumps(obj: Any, indent: int | None = None, sort_keys: bool = False) -> str:
    """``obj`` as strict JSON (``allow_nan=False``): the one serialiser of cml-edge's JSON
    output. A NaN or infinity raises :class:`NonFiniteError` naming it
    (:func:`check_finite`)."""
    try:
        return json.dumps(obj, indent=indent, sort_keys=sort_keys, allow_nan=False)
    except ValueError:
        check_finite(obj)
        raise
