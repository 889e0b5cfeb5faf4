"""The float reference synaptic array: W stored as float64 (``float``) or float32 (``float32``)."""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np

from cml_edge.backends.base import SynapticArray, laid_out
from cml_edge.backends.floating import kernels as kern
from cml_edge.backends.floating.config import FloatConfig, make_config


class FloatState(NamedTuple):
    W: np.ndarray  # (rows, cols) weights, float64 or float32
    acc: np.ndarray  # (rows, cols) update accumulated since the last commit
    buf: np.ndarray  # (max(rows, cols),) accumulators of a read, in the storage dtype
    counters: np.ndarray  # int64[N_COUNTERS]




class FloatArray(SynapticArray):
    """Exact floating-point weights: the reference every device array is compared with."""

    name = "float"
    State = FloatState
    counter_names = (
        "matvecs", "rmatvecs", "macs", "weight_reads", "outer_updates", "acc_writes",
        "weight_writes", "cells_changed", "commits", "bytes_read", "bytes_written",
    )
    assert len(counter_names) == kern.N_COUNTERS

    @classmethod
    def from_float(cls, W: np.ndarray, *, seed: int = 0, index: int = 0,
                   **options: Any) -> FloatArray:
        """Store W in the config's dtype (``options``: the fields of
        :class:`~cml_edge.backends.floating.config.FloatConfig`, or a ``preset``)."""
        config = make_config(**options)
        W = laid_out(np.asarray(W, dtype=np.dtype(config.dtype)))
        return cls(FloatState(W, np.zeros_like(W), np.zeros(max(W.shape), W.dtype),
                              np.zeros(kern.N_COUNTERS, np.int64)))

    @classmethod
    def _restore(cls, state: FloatState, options: dict[str, Any]) -> FloatArray:
        return cls(state._replace(W=laid_out(state.W), acc=laid_out(state.acc)))

    def options(self) -> dict[str, Any]:
        return {"dtype": self.state.W.dtype.name}

    @property
    def config(self) -> FloatConfig:
        return FloatConfig(self.state.W.dtype.name)

    def to_float(self) -> np.ndarray:
        return self.state.W.astype(np.float64)

    @property
    def supports_factored(self) -> bool:
        """The exact factored fast path (cml_edge.grid.training) needs float64 weights."""
        return self.state.W.dtype == np.float64
