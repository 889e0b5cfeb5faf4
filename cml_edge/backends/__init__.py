"""The synaptic arrays and their registry: a backend name -> an array class and options.

``make_array(name, W, seed=..., index=...)`` programs a float matrix into the named
backend. New devices register here and nothing else in the package changes.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from cml_edge.backends.base import SynapticArray
from cml_edge.backends.crossbar.array import CrossbarArray
from cml_edge.backends.fixed.array import FixedArray
from cml_edge.backends.floating.array import FloatArray
from cml_edge.errors import InputError


@dataclass(frozen=True)
class BackendSpec:
    """A named configuration of an array class (what ``--backend NAME`` selects)."""

    array_class: type[SynapticArray]
    options: dict[str, Any] = field(default_factory=dict)
    description: str = ""


BACKENDS: dict[str, BackendSpec] = {
    "float": BackendSpec(FloatArray, {"dtype": "float64"}, "float64 reference"),
    "float32": BackendSpec(FloatArray, {"dtype": "float32"}, "float32 weights and arithmetic"),
    "int8": BackendSpec(FixedArray, {"bits": 8}, "Loihi-style int8 weights, integer learning"),
    "int16": BackendSpec(FixedArray, {"bits": 16}, "int16 weights, integer learning"),
    "fixed": BackendSpec(FixedArray, {}, "fixed point of --bits N (2..16) bits"),
    "crossbar": BackendSpec(CrossbarArray, {"preset": CrossbarArray.DEFAULT_PRESET},
                            "memristive crossbar: --preset ideal|pcm|reram, --levels, --set"),
}

ARRAY_CLASSES: dict[str, type[SynapticArray]] = {
    "float": FloatArray,
    "fixed": FixedArray,
    "crossbar": CrossbarArray,
}


def backend_spec(name: str) -> BackendSpec:
    """The spec registered as ``name``; ValueError naming the allowed names otherwise."""
    try:
        return BACKENDS[name]
    except KeyError:
        raise InputError(
            f"unknown backend {name!r}; allowed: {', '.join(sorted(BACKENDS))}"
        ) from None


def make_array(name: str, W: np.ndarray, *, seed: int, index: int,
               **overrides: Any) -> SynapticArray:
    """Program ``W`` into a new array of backend ``name`` (options overridable)."""
    spec = backend_spec(name)
    return spec.array_class.from_float(W, seed=seed, index=index, **{**spec.options, **overrides})


def array_from_state_dict(d: dict[str, np.ndarray]) -> SynapticArray:
    """Rebuild any registered array from its ``state_dict``."""
    kind = str(d.get("__backend__", ""))
    if kind not in ARRAY_CLASSES:
        raise InputError(f"unknown array kind {kind!r}; known: {', '.join(sorted(ARRAY_CLASSES))}")
    return ARRAY_CLASSES[kind].from_state_dict(d)


__all__ = ["BACKENDS", "BackendSpec", "SynapticArray", "array_from_state_dict", "backend_spec",
           "make_array"]
