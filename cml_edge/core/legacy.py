"""The one older layout a model file may hold: the release before the parameter records.

Model files written by release 30f00e8 (tests/data/legacy/ holds one per device kind)
store a fixed-point or crossbar array's parameters as one hand-numbered vector, and a
crossbar array lacks the options, state and counters the calibrated physics added since.
:func:`upgrade` converts such a file's arrays to the current layout before they are
loaded; the arrays' loader then checks what it returns as it checks a current file. The
model reader (:func:`cml_edge.core.model_file.load_model`) is the only caller: no other
file kind was written by that release, and no other older layout is read.
"""

from __future__ import annotations

import json
import math
from typing import Any

import numpy as np

from cml_edge.backends.crossbar.array import new_fields
from cml_edge.backends.crossbar.codes import N_COUNTERS
from cml_edge.backends.crossbar.config import (
    DEFAULT_PRESET,
    NEW_FIELDS,
    CrossbarParams,
    DeviceConfig,
    crossbar_params,
    make_config,
)
from cml_edge.backends.fixed.config import FixedParams
from cml_edge.backends.params import record_names, record_to_array
from cml_edge.errors import InputError

FIXED_SLOTS = ("exp", "bits", "qmax", "rounding", "act_qmax", "frac", "acc_max", "mac_max",
               "mv_check", "rmv_check", "mv_shift", "rmv_shift", "strict", "lr_bits")
"""The 14 slots of a fixed-point array's int64 ``params`` vector (the old ``P_*`` indices
0..13, in order)."""

CROSSBAR_SLOTS = (
    "g_min", "g_max", "dG", "w_max", "g_per_w", "dw_min", "update", "commit", "bl_max",
    "dw_min_std", "bounds", "prog_noise", "prog_c0", "prog_c1", "prog_c2", "prog_gref",
    "read_noise", "out_noise", "dac_step", "adc_step", "adc_bound", "drift_t0",
    "drift_compensation", "alpha", "elapsed", "dw_min_dtod", "up_down", "up_down_dtod",
    "drift_nu", "drift_nu_std", "stuck_low", "stuck_high",
)
"""The 32 slots of a crossbar array's float64 ``params`` vector (the old ``P_*`` indices
0..31, in order); slot ``adc_bound`` held inf when there was no ADC."""


def upgrade(data: dict[str, np.ndarray], matrices: tuple[str, ...]) -> dict[str, np.ndarray]:
    """``data`` (a model file's arrays, each matrix's state under ``<matrix>/``) with every
    array of the old layout converted; arrays of the current layout are left as they are."""
    out = dict(data)
    for name in matrices:
        head = f"{name}/"
        d = {k[len(head):]: v for k, v in data.items() if k.startswith(head)}
        if "__params__" in d or "params" not in d:
            continue  # the current layout (or one the arrays' loader refuses)
        convert = {"fixed": _fixed, "crossbar": _crossbar}.get(str(d.get("__backend__")))
        if convert is not None:
            out.update({head + k: v for k, v in convert(d).items()})
    return out


def _slots(d: dict[str, np.ndarray], names: tuple[str, ...], dtype: type) -> dict[str, Any]:
    old = np.asarray(d["params"])
    if old.dtype != dtype or old.shape != (len(names),):
        raise InputError(f"field 'params' has shape {old.shape}, expected ({len(names)},)")
    return dict(zip(names, old.tolist()))


def _fixed(d: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """The record's other fields are the widths the slots imply (act_bits from act_qmax,
    acc_bits from acc_max, mac_bits from mac_max); the loader then checks the whole record
    against the saved options."""
    slots = _slots(d, FIXED_SLOTS, np.int64)
    values = {**slots, "act_bits": slots["act_qmax"].bit_length() + 1,
              "acc_bits": slots["acc_max"].bit_length() + 1,
              "mac_bits": slots["mac_max"].bit_length() + 1}
    record = np.array([values[name] for name in FixedParams._fields], dtype=np.int64)
    return {**d, "params": record, "__params__": np.array(json.dumps(FixedParams._fields))}


def _crossbar(d: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """The options gain the calibrated-physics fields (:data:`NEW_FIELDS`) at their
    defaults, all off: the array keeps the physics it was saved with, not what its preset
    names now (``pcm`` then is ``pcm-symmetric`` now; the options still say ``pcm``). The
    record is rebuilt from those options and the saved w_max, and the old vector must equal
    that record's slots, or the file is refused. The run-time alpha and elapsed move to
    their state arrays, the new state arrays start neutral and the new counters at 0."""
    slots = _slots(d, CROSSBAR_SLOTS, np.float64)
    options = json.loads(str(d["__options__"]))
    if not isinstance(options, dict):
        raise InputError("its options are not an object")
    defaults = DeviceConfig()
    options.update({f: getattr(defaults, f) for f in NEW_FIELDS if f not in options})
    fields = dict(options)
    record = crossbar_params(make_config(fields.pop("preset", DEFAULT_PRESET), **fields),
                             slots["w_max"])
    if [_slot(record, slots, name) for name in CROSSBAR_SLOTS] != list(slots.values()):
        raise InputError("crossbar parameters do not match the saved options")
    gp = np.asarray(d["Gp"])
    if gp.ndim != 2:
        return d  # refused by the loader
    counters = np.asarray(d["counters"])
    fresh = new_fields(record, *gp.shape)
    new = {f: a for f, a in fresh.items() if f not in d}
    if counters.ndim == 1 and counters.shape[0] < N_COUNTERS:
        new["counters"] = np.concatenate(
            [counters, np.zeros(N_COUNTERS - counters.shape[0], counters.dtype)])
    return {**d, **new, "__options__": np.array(json.dumps(options, sort_keys=True)),
            "params": record_to_array(record), "__params__": record_names(record),
            "alpha": np.array([slots["alpha"]]), "elapsed": np.array([slots["elapsed"]])}


def _slot(record: CrossbarParams, slots: dict[str, Any], name: str) -> float:
    """What the old release stored in slot ``name`` for ``record``."""
    if name in ("alpha", "elapsed"):
        return slots[name]
    if name == "adc_bound" and record.adc_bits <= 0:
        return math.inf
    return float(getattr(record, name))


__all__ = ["CROSSBAR_SLOTS", "FIXED_SLOTS", "upgrade"]
