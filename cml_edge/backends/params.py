"""The kernels' parameter record, derived from a device's config dataclass.

Numba kernels cannot read a dataclass, so each device's kernels get its numbers as one
``NamedTuple`` of scalars, the ``params`` field of its state. :func:`kernel_record`
builds that NamedTuple class from the config class: every numeric field of the config
(int and float as they are, a bool as an int 0/1, a choice field as the index of its
value in ``choices``), except fields declared ``kernel=False`` or per matrix
(:mod:`cml_edge.backends.fields`), followed by the quantities the device derives
(``derived``: the crossbar's level spacing and weight scale, the fixed-point exponent and
accumulator limits...). The kernels read ``state.params.g_min``; a new config field
reaches them with no other edit. Values the kernels change at run time are state
arrays, never record fields.

Types are fixed by the record class, not by the values given (:func:`build_record`
converts), so that one compiled kernel serves every configuration of a device.

In a ``state_dict`` a record is stored as one vector (:func:`record_to_array`: int64 if
every field is an int, float64 otherwise, each int checked to be exact in float64) and
its field names (``__params__``, JSON), and rebuilt field by field on load
(:func:`record_from_array`), which refuses another set or order of fields.
"""

from __future__ import annotations

import json
from dataclasses import fields
from typing import Any, NamedTuple

import numpy as np

from cml_edge.backends.fields import scalar_kind
from cml_edge.errors import InputError

_EXACT = 2 ** 53


def kernel_fields(config_cls: type) -> list[tuple[str, type]]:
    """(name, int or float) of each config field that enters the kernels' record."""
    out = []
    for f in fields(config_cls):
        meta = f.metadata
        if meta.get("kernel") is False or "per_matrix" in meta:
            continue
        kind = scalar_kind(config_cls, f.name)
        if kind is float:
            out.append((f.name, float))
        elif kind in (int, bool) or (kind is str and "choices" in meta):
            out.append((f.name, int))
    return out


def kernel_record(config_cls: type, name: str, module: str,
                  derived: dict[str, type]) -> type:
    """The NamedTuple class ``name`` of the kernel fields of ``config_cls`` followed by
    ``derived`` (name -> int or float). Assign it to ``name`` in ``module`` (Numba's
    on-disk cache finds the class by its module and name)."""
    spec = kernel_fields(config_cls)
    clash = sorted({n for n, _ in spec} & set(derived))
    if clash:
        raise ValueError(f"derived quantities {clash} shadow config fields")
    cls = NamedTuple(name, [*spec, *derived.items()])
    cls.__module__ = module
    cls.__qualname__ = name
    cls.config_class = config_cls  # type: ignore[attr-defined]
    return cls


def build_record(record_cls: type, config: Any, **derived: Any) -> Any:
    """The record of ``config`` and the ``derived`` values, each in its field's type."""
    meta = {f.name: f.metadata for f in fields(config)}
    values = []
    for name, kind in record_cls.__annotations__.items():
        if name in derived:
            v = derived[name]
        else:
            v = getattr(config, name)
            choices = meta[name].get("choices")
            if choices is not None:
                v = choices.index(v)
        values.append(float(v) if kind is float else int(v))
    missing = set(derived) - set(record_cls.__annotations__)
    if missing:
        raise ValueError(f"{record_cls.__name__} has no field {sorted(missing)[0]!r}")
    return record_cls(*values)


def is_record(value: Any) -> bool:
    return isinstance(value, tuple) and hasattr(type(value), "_fields")


def record_dtype(record_cls: type) -> np.dtype:
    kinds = set(record_cls.__annotations__.values())
    return np.dtype(np.int64 if kinds == {int} else np.float64)


def record_to_array(record: Any) -> np.ndarray:
    """The record as one vector (module docstring)."""
    dtype = record_dtype(type(record))
    if dtype == np.float64:
        for name, v in zip(record._fields, record):
            if isinstance(v, int) and abs(v) >= _EXACT:
                raise InputError(f"{name} {v} is not allowed (allowed: |{name}| < 2^53)")
    return np.array(tuple(record), dtype=dtype)


def record_names(record: Any) -> np.ndarray:
    """The JSON list of the record's field names (``__params__`` of a state dict)."""
    return np.array(json.dumps(list(record._fields)))


def record_from_array(record_cls: type, vector: Any, names: Any, what: str) -> Any:
    """The record stored by :func:`record_to_array`; InputError if the names, dtype or
    length differ from ``record_cls``'s or an int field holds a fraction."""
    if names is None:
        raise InputError(f"field {what!r} comes without its field names")
    try:
        stored = json.loads(str(names))
    except json.JSONDecodeError:
        stored = None
    expected = list(record_cls._fields)
    if stored != expected:
        raise InputError(f"field {what!r} holds {stored}, expected the fields {expected}")
    a = np.asarray(vector)
    dtype = record_dtype(record_cls)
    if a.dtype != dtype or a.shape != (len(expected),):
        raise InputError(f"field {what!r}: {a.dtype}{list(a.shape)} where "
                         f"{dtype}[{len(expected)}] is expected")
    values = []
    for name, kind, v in zip(expected, record_cls.__annotations__.values(), a.tolist()):
        if kind is int:
            if float(v) != int(v):
                raise InputError(f"field {what!r}: {name} = {v!r} is not an integer")
            v = int(v)
        values.append(v)
    return record_cls(*values)


__all__ = ["build_record", "is_record", "kernel_fields", "kernel_record", "record_dtype",
           "record_from_array", "record_names", "record_to_array"]
