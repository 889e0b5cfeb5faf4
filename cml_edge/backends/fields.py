"""Device configurations as data: field metadata, presets, coercion and ``--set`` parsing.

A device's configuration is a frozen dataclass (``FloatConfig``, ``FixedConfig``, the
crossbar's ``DeviceConfig``). Each field is documented by the docstring under it and
declared with :func:`option`, whose metadata says what the rest of the package needs to
know about the field, so that no device writes code for it:

- ``flag``: a named command-line flag besides the generic ``--set field=value``
  (``--bits``); ``help`` and ``metavar`` for it;
- ``choices``: the allowed strings of a choice field (the kernels get the index);
- ``per_matrix``: ``"each"`` for a field that holds one value for every matrix or one
  per matrix, [W_q, W_k, W_v] (the fixed-point ``weight_exp``); ``(option, i)`` for a
  field that is matrix i's value of ``option`` (the crossbar's ``w_max_q`` / ``_k`` / ``_v``
  are ``("w_max", 0..2)``);
- ``kernel``: False keeps a field out of the kernels' parameter record
  (:mod:`cml_edge.backends.params`; per-matrix fields never enter it: the array's own
  value does, as a derived quantity);
- ``lo``, ``hi``, ``why``: the field's documented range (inclusive) and the one-line
  reason for it, from the physics or the arithmetic (levels and bits a device can hold,
  noise as a fraction, conductances in micro-siemens); ``off``: one value outside the
  range that is also allowed, meaning "no such stage" (a converter's 0 bits).
  :func:`check_ranges` refuses any other value outside it, the command line's help shows
  it (:func:`range_text`), the device pages document it and the property test of the
  devices draws from it.

A preset is a dict of field values; :func:`resolve` applies one (named by the
``preset`` option) and then the given fields. :func:`parse_setting` is the one parser of
``--set field=value`` (the command line's and ``cml-edge bench``'s, through
:meth:`cml_edge.backends.device.DeviceSpec.given`).
"""

from __future__ import annotations

import functools
import math
import types
import typing
from dataclasses import MISSING, Field, field, fields
from typing import Any

import numpy as np

from cml_edge.errors import InputError
from cml_edge.sizes import ascii_number

MATRICES = ("W_q", "W_k", "W_v")
_TRUE = ("1", "true", "yes", "on")
_FALSE = ("0", "false", "no", "off")


def option(default: Any = MISSING, *, flag: str | None = None, help: str | None = None,
           metavar: str | None = None, choices: tuple[str, ...] | None = None,
           per_matrix: str | tuple[str, int] | None = None, kernel: bool = True,
           noun: str | None = None, lo: float | None = None, hi: float | None = None,
           why: str | None = None, off: float | None = None) -> Any:
    """A dataclass field with the metadata of the module docstring (``noun`` names the
    values of an ``"each"`` per-matrix flag in its error: "1 or 3 exponents")."""
    if (lo is None) != (hi is None) or (lo is not None and (not lo <= hi or not why)):
        raise ValueError(f"a range needs lo <= hi and a reason (lo {lo!r}, hi {hi!r})")
    if off is not None and (lo is None or lo <= off <= hi):
        raise ValueError(f"an off value {off!r} needs a range that excludes it")
    meta = {"flag": flag, "help": help, "metavar": metavar, "choices": choices,
            "per_matrix": per_matrix, "noun": noun, "lo": lo, "hi": hi, "why": why,
            "off": off}
    meta = {k: v for k, v in meta.items() if v is not None}
    if not kernel:
        meta["kernel"] = False
    return field(default=default, metadata=meta)


@functools.cache
def _hints(cls: type) -> dict[str, Any]:
    return typing.get_type_hints(cls)


def field_names(cls: type) -> tuple[str, ...]:
    return tuple(f.name for f in fields(cls))


def scalar_kind(cls: type, name: str) -> type | None:
    """The scalar type of field ``name``: float, int, bool or str (the element type of a
    per-matrix field), None if it has none."""
    hint = _hints(cls)[name]
    if hint in (float, int, bool, str):
        return hint
    if isinstance(hint, types.UnionType) or typing.get_origin(hint) is typing.Union:
        for arg in typing.get_args(hint):
            if arg in (float, int, bool, str):
                return arg
    return None


def per_matrix_options(cls: type) -> dict[str, tuple[str, ...]]:
    """Each per-matrix option and the field(s) holding it: ``{"weight_exp": ("weight_exp",)}``
    (one field, one value or one per matrix) or ``{"w_max": ("w_max_q", "w_max_k",
    "w_max_v")}`` (one field per matrix)."""
    out: dict[str, list[tuple[int, str]]] = {}
    for f in fields(cls):
        pm = f.metadata.get("per_matrix")
        if pm == "each":
            out[f.name] = [(0, f.name)]
        elif pm is not None:
            out.setdefault(pm[0], []).append((pm[1], f.name))
    return {k: tuple(n for _, n in sorted(v)) for k, v in out.items()}


def matrix_value(config: Any, option_name: str, index: int, default: Any = None) -> Any:
    """The value of per-matrix option ``option_name`` for matrix ``index`` (0, 1, 2 = W_q,
    W_k, W_v); ``default`` for an index beyond the declared matrices of a split option."""
    names = per_matrix_options(type(config))[option_name]
    if len(names) == 1:
        value = getattr(config, names[0])
        if isinstance(value, (list, tuple)):
            return value[min(index, len(value) - 1)]
        return value
    return getattr(config, names[index]) if 0 <= index < len(names) else default


# values -------------------------------------------------------------------------------
def coerce(cls: type, name: str, value: Any) -> Any:
    """A value from JSON or the command line in the field's type: ints for float fields
    become floats, integral floats for int fields ints, lists of a per-matrix field a
    tuple; anything else is left for the config's validation to judge."""
    kind = scalar_kind(cls, name)
    if isinstance(value, (list, tuple)):
        return tuple(coerce_scalar(kind, v) for v in value)
    return coerce_scalar(kind, value)


def coerce_scalar(kind: type | None, value: Any) -> Any:
    if kind is float and isinstance(value, (int, np.integer)) and not isinstance(value, bool):
        return float(value)
    if kind is int and isinstance(value, float) and value.is_integer():
        return int(value)
    return value


def check_types(config: Any, label: str) -> None:
    """Every field of ``config`` of its declared type (finite floats, integers, booleans,
    one of the choices); InputError naming the field, the value and what is allowed."""
    for f in fields(config):
        v = getattr(config, f.name)
        kind = scalar_kind(type(config), f.name)
        values = v if isinstance(v, tuple) and f.metadata.get("per_matrix") == "each" else (v,)
        for x in values:
            if x is None and f.default is None:
                continue
            _check_scalar(kind, f, x, label)


def _check_scalar(kind: type | None, f: Field, v: Any, label: str) -> None:
    number = isinstance(v, (int, float, np.integer)) and not isinstance(v, bool)
    if kind is float and not (number and math.isfinite(v)):
        raise InputError(f"{label}{f.name} {v!r} is not a finite number")
    if kind is int and not (number and isinstance(v, (int, np.integer))):
        raise InputError(f"{label}{f.name} {v!r} is not an integer")
    if kind is bool and not isinstance(v, (bool, np.bool_)):
        raise InputError(f"{label}{f.name} {v!r} is not a boolean")
    choices = f.metadata.get("choices")
    if choices is not None and v not in choices:
        raise InputError(f"{label}{f.name} {v!r} is not allowed "
                         f"(allowed: {', '.join(choices)})")


def field_range(cls: type, name: str) -> tuple[float, float, str] | None:
    """(lo, hi, why) of field ``name`` (None: no declared range)."""
    meta = next(f.metadata for f in fields(cls) if f.name == name)
    return (meta["lo"], meta["hi"], meta["why"]) if "lo" in meta else None


def field_off(cls: type, name: str) -> float | None:
    """The value outside its range that field ``name`` also allows (None: no such value)."""
    return next(f.metadata for f in fields(cls) if f.name == name).get("off")


def range_text(cls: type, name: str) -> str:
    """``lo..hi`` of field ``name`` ('' without a range), ``off or lo..hi`` when it has an
    off value, numbers as %g."""
    r, off = field_range(cls, name), field_off(cls, name)
    if r is None:
        return ""
    return ("" if off is None else f"{off:g} or ") + f"{r[0]:g}..{r[1]:g}"


def range_table(cls: type) -> str:
    """The markdown table of the fields of ``cls`` that declare a range: field, range,
    reason (the device pages carry it; a test holds them to the code)."""
    rows = [f"| `{f.name}` | {range_text(cls, f.name)} | {f.metadata['why']} |"
            for f in fields(cls) if "lo" in f.metadata]
    return "\n".join(["| field | range | why |", "|---|---|---|", *rows])


def check_ranges(config: Any, label: str) -> None:
    """Every field of ``config`` with a declared range inside it (each value of a
    per-matrix field); InputError naming the field, the value, the range and its
    reason. Run after the types are checked."""
    for f in fields(config):
        if "lo" not in f.metadata:
            continue
        v = getattr(config, f.name)
        for x in v if isinstance(v, tuple) else (v,):
            if x is not None and not f.metadata["lo"] <= x <= f.metadata["hi"] and \
                    x != f.metadata.get("off"):
                raise InputError(f"{label}{f.name} {x!r} is outside its range "
                                 f"{range_text(type(config), f.name)} ({f.metadata['why']})")


def resolve(cls: type, presets: dict[str, dict[str, Any]], options: dict[str, Any],
            label: str, default_preset: str | None = None) -> Any:
    """The config ``cls`` of ``options``: the preset ``options["preset"]`` (or
    ``default_preset``), then the other options as field values, coerced to the fields'
    types; InputError naming an unknown preset or field and the allowed ones."""
    options = dict(options)
    preset = options.pop("preset", None) or default_preset
    values: dict[str, Any] = {}
    if preset is not None:
        if preset not in presets:
            raise InputError(f"unknown {label} preset {preset!r}; allowed: "
                             f"{', '.join(presets)}")
        values.update(presets[preset])
    names = field_names(cls)
    unknown = sorted(set(options) - set(names))
    if unknown:
        raise InputError(f"unknown {label} field {unknown[0]!r}; allowed: {', '.join(names)}")
    values.update(options)
    return cls(**{k: coerce(cls, k, v) for k, v in values.items()})


def parse_setting(cls: type, text: str, label: str) -> tuple[str, Any]:
    """``field=value`` from ``--set``: the field's name and the value in its type. A
    per-matrix field takes one value or three, comma-separated (W_q, W_k, W_v);
    ``none`` clears an optional field."""
    name, sep, raw = text.partition("=")
    name, raw = name.strip(), raw.strip()
    if not sep or not name:
        raise InputError(f"--set {text!r} is not of the form field=value")
    names = field_names(cls)
    if name not in names:
        raise InputError(f"unknown {label} field {name!r}; allowed: {', '.join(names)}")
    f = next(f for f in fields(cls) if f.name == name)
    kind = scalar_kind(cls, name)
    if f.default is None and raw.lower() == "none":
        return name, None
    if f.metadata.get("per_matrix") == "each" and "," in raw:
        parts = [p.strip() for p in raw.split(",")]
        return name, [_parse_scalar(kind, p, name, raw) for p in parts]
    return name, _parse_scalar(kind, raw, name, raw)


def _parse_scalar(kind: type | None, raw: str, name: str, whole: str) -> Any:
    try:
        if kind is float:
            return ascii_number(raw, float)
        if kind is int:
            return ascii_number(raw, int)
        if kind is bool:
            low = raw.lower()
            if low not in _TRUE + _FALSE:
                raise ValueError
            return low in _TRUE
        return raw
    except ValueError:
        what = kind.__name__ if kind is not None else "value"
        raise InputError(f"--set {name}={whole!r}: not a valid {what}") from None


__all__ = ["MATRICES", "check_ranges", "check_types", "coerce", "field_names", "field_off",
           "field_range", "matrix_value", "option", "parse_setting", "per_matrix_options",
           "resolve", "range_table", "range_text", "scalar_kind"]
