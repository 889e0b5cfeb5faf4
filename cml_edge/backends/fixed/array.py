"""The Loihi-style fixed-point synaptic array: ``int8``, ``int16``, ``fixed``.

Weights are signed integer mantissas of ``bits`` bits (2..16) in the narrowest
NumPy integer type, with one power-of-two exponent per matrix; reads are integer
multiply-accumulates of quantised activations; the local rule is formed in integers
and written back in place with floor, nearest or stochastic rounding, saturating
(counted, or raising in strict mode). Formats and rounding: :mod:`cml_edge.backends.quant`;
the arithmetic, step by step: :mod:`cml_edge.backends.fixed.kernels`.

The choices (exponent rule and headroom, accumulator and learning-rate widths,
activations, the sigmoid table) are the fields of
:class:`~cml_edge.backends.fixed.config.FixedConfig`, each documented with its default;
how they do on the paper's protocol is measured in docs/devices/fixed.md.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np

from cml_edge.backends.base import SynapticArray, laid_out
from cml_edge.backends.fields import matrix_value
from cml_edge.backends.fixed import kernels as kern
from cml_edge.backends.fixed.config import (
    FixedConfig,
    FixedParams,
    fixed_params,
    make_config,
)
from cml_edge.backends.quant import (
    ROUNDINGS,
    SaturationError,
    check_int,
    choose_exponent,
    dequantize,
    qmax_of,
    quantize_matrix,
    storage_dtype,
)
from cml_edge.errors import InputError
from cml_edge.jit.rng import stream_key
from cml_edge.protocol import STREAM_DEVICE


class FixedState(NamedTuple):
    mantissa: np.ndarray  # (rows, cols) int8 / int16 weight mantissas: W = mantissa 2^exp
    acc: np.ndarray  # (rows, cols) int16 / int32 learning accumulator, F fractional bits
    params: FixedParams  # the formats and exponent as the kernels read them (config.py)
    rng: np.ndarray  # uint64[2]: stream key, next draw counter
    xq: np.ndarray  # int64[max(rows, cols)] scratch: quantised input / row factors
    yq: np.ndarray  # int64[max(rows, cols)] scratch: quantised second factor
    sums: np.ndarray  # int64[max(rows, cols)] scratch: read accumulators
    tally: np.ndarray  # int64[4] scratch: an update's writes, changes, saturations, draws
    counters: np.ndarray  # int64[N_COUNTERS]


MATRIX_NAMES = ("W_q", "W_k", "W_v")


class FixedArray(SynapticArray):
    """Integer mantissas with one exponent per matrix, integer reads and updates."""

    name = "fixed"
    State = FixedState
    counter_names = (
        "matvecs", "rmatvecs", "macs", "weight_reads", "outer_updates", "update_macs",
        "acc_writes", "weight_writes", "cells_changed", "commits", "saturations",
        "acc_saturations", "mac_saturations", "rng_draws", "bytes_read", "bytes_written",
    )
    assert len(counter_names) == kern.N_COUNTERS

    # construction -----------------------------------------------------------------
    @classmethod
    def from_float(cls, W: np.ndarray, *, seed: int = 0, index: int = 0,
                   **options: Any) -> FixedArray:
        """Program W: mantissas by round-to-nearest at the chosen exponent.

        ``options``: the fields of :class:`~cml_edge.backends.fixed.config.FixedConfig`
        (or a ``preset``). ``weight_exp``: None (the exponent rule, plus ``headroom``
        bits), an int, or one int per matrix [W_q, W_k, W_v] picked by ``index``. A
        fixed exponent that cannot represent W raises ValueError unless ``clip_init``
        (then the clipped cells are counted as saturations, in strict mode too:
        programming is the user's choice).
        """
        config = make_config(**options)
        seed = check_int(seed, "seed", 0, 2**63 - 1)
        index = check_int(index, "index", 0, 2**16)
        W = np.asarray(W, dtype=np.float64)
        if W.ndim != 2 or W.size == 0:
            raise InputError(f"expected a non-empty matrix, got shape {W.shape}")
        if not np.isfinite(W).all():
            raise InputError("the weights to program are not all finite")
        what = MATRIX_NAMES[index] if index < len(MATRIX_NAMES) else f"matrix {index}"
        max_abs = float(np.abs(W).max())
        bits = config.bits
        if config.weight_exp is None:
            exp = choose_exponent(max_abs, bits, config.headroom)
        else:
            exp = matrix_value(config, "weight_exp", index)
        mantissa, clipped = quantize_matrix(W, bits, exp)
        if clipped and not config.clip_init:
            need, qmax = choose_exponent(max_abs, bits), qmax_of(bits)
            raise InputError(
                f"weight exponent {exp} cannot represent the initial weights of {what}: "
                f"max |W| = {max_abs:.4g} > {qmax} x 2^{exp} = {qmax * 2.0 ** exp:.4g} "
                f"({clipped} cells would saturate); allowed: an exponent >= {need} at "
                f"{bits} bits, or clip_init (--clip-init) to saturate them, counted")
        params = fixed_params(config, exp, W.shape)
        rows, cols = W.shape
        n = max(rows, cols)
        counters = np.zeros(kern.N_COUNTERS, np.int64)
        counters[kern.SATURATIONS] = clipped
        rng = np.array([stream_key(seed, STREAM_DEVICE + index), 0], dtype=np.uint64)
        state = FixedState(laid_out(mantissa),
                           laid_out(np.zeros((rows, cols), storage_dtype(config.acc_bits))),
                           params, rng,
                           np.zeros(n, np.int64), np.zeros(n, np.int64), np.zeros(n, np.int64),
                           np.zeros(4, np.int64), counters)
        return cls(state)

    def options(self) -> dict[str, Any]:
        p = self.state.params
        return {"bits": p.bits, "rounding": ROUNDINGS[p.rounding], "act_bits": p.act_bits,
                "acc_bits": p.acc_bits, "mac_bits": p.mac_bits, "lr_bits": p.lr_bits,
                "weight_exp": p.exp, "strict": bool(p.strict)}

    @property
    def config(self) -> FixedConfig:
        """The config this array was built with (its exponent as ``weight_exp``)."""
        return make_config(**self.options())

    # reading the state --------------------------------------------------------------
    @property
    def exponent(self) -> int:
        """The matrix's exponent: W = mantissa x 2^exponent."""
        return int(self.state.params.exp)

    @property
    def lsb(self) -> float:
        """The weight of one mantissa step, 2^exponent."""
        return 2.0 ** self.exponent

    @property
    def qmax(self) -> int:
        return int(self.state.params.qmax)

    @property
    def parameter_bytes(self) -> int:
        """Bytes of stored weights (mantissas at their storage width; one exponent aside)."""
        return int(self.state.mantissa.nbytes)

    def weight_bits(self) -> int:
        """Bits a chip holds per weight: the mantissa width (6 for ``--bits 6``, stored
        here in an int8)."""
        return int(self.state.params.bits)

    def accumulator_bits(self) -> int:
        """Bits per weight of the learning accumulator (``acc_bits``)."""
        return int(self.state.params.acc_bits)

    def to_float(self) -> np.ndarray:
        return dequantize(self.state.mantissa, self.exponent)

    def pending_float(self) -> np.ndarray:
        """The learning accumulator in weight units (what ``commit`` would add, unrounded)."""
        p = self.state.params
        return dequantize(self.state.acc, int(p.exp - p.frac))

    # persistence ------------------------------------------------------------------
    @classmethod
    def _restore(cls, state: FixedState, options: dict[str, Any]) -> FixedArray:
        rows, cols = state.mantissa.shape
        ref = cls.from_float(np.zeros((rows, cols)), **options).state
        if state.params != ref.params:
            raise InputError("fixed-point parameters do not match the saved options")
        for f in ("rng", "xq", "yq", "sums", "tally"):
            if getattr(state, f).shape != getattr(ref, f).shape:
                raise InputError(f"field {f!r} has shape {getattr(state, f).shape}, expected "
                                 f"{getattr(ref, f).shape}")
        q, a = state.params.qmax, state.params.acc_max
        if np.abs(state.mantissa.astype(np.int64)).max() > q:
            raise InputError(f"weight mantissas beyond the {options.get('bits')}-bit format")
        if np.abs(state.acc.astype(np.int64)).max() > a:
            raise InputError("learning accumulator beyond its format")
        if (state.counters < 0).any():
            raise InputError("negative counters")
        return cls(state._replace(mantissa=laid_out(state.mantissa), acc=laid_out(state.acc)))


__all__ = ["FixedArray", "FixedState", "SaturationError"]
