"""The Loihi-style fixed-point synaptic array (issue 3): ``int8``, ``int16``, ``fixed``.

Weights are signed integer mantissas of ``bits`` bits (2..16) in the narrowest
NumPy integer type, with one power-of-two exponent per matrix; reads are integer
multiply-accumulates of quantised activations; the local rule is formed in integers
and written back in place with floor, nearest or stochastic rounding, saturating
(counted, or raising in strict mode). Formats and rounding: :mod:`cml_edge.backends.quant`;
the arithmetic, step by step: :mod:`cml_edge.backends.fixed.kernels`.

Choices, measured on the paper's protocol (30 x 30, 10 seeds x 100 pairs; success):

- exponent: the finest that holds the initial max|W| (Lava's rule), ``headroom`` 0
  extra bits. Training grows max|W_k| and max|W_q| by at most ~12 % (float runs), a
  few cells may saturate (counted; none did at int8), while W_v shrinks ~30x to
  entries of ~0.7 LSB (std) at int8, which stochastic rounding still resolves on
  average: int8 1.000, overhead 1.000; headroom 1: 1.000, overhead 1.004;
- learning accumulator: ``acc_bits`` 32 with F = acc_bits - bits - 1 fractional bits
  below the weight's LSB (23 at int8, 15 at int16; the integer part holds twice the
  weight range). Loihi's 16 bits (F = 7 at int8) also reach 1.000 with stochastic
  rounding but cost 37x more random draws and drop nearest rounding to 0.748 (0.858
  with 32 bits): two roundings instead of one;
- learning rate: a 4-bit mantissa (Lava's), 0.001 -> 8 x 2^-13 = 0.000977; an 8-bit
  mantissa (131 x 2^-17) also gives 1.000 but its wider products are narrowed into the
  accumulator 20x more often (1.3e9 vs 6.8e7 draws per 10 seeds);
- activations: 8 bits with their own exponent per vector; read accumulator 32 bits
  (no overflow possible at these shapes, see the kernels); sigmoid: a 256-entry table.
"""

from __future__ import annotations

import argparse
from typing import Any, NamedTuple

import numpy as np

from cml_edge.backends.base import SynapticArray
from cml_edge.backends.dispatch import Kernels, register
from cml_edge.backends.fixed import kernels as kern
from cml_edge.backends.quant import (
    MAX_EXPONENT,
    ROUNDINGS,
    SaturationError,
    check_bits,
    check_int,
    choose_exponent,
    dequantize,
    qmax_of,
    quantize_matrix,
    rounding_code,
    storage_dtype,
)
from cml_edge.errors import InputError
from cml_edge.protocol import STREAM_DEVICE
from cml_edge.rng import stream_key


class FixedState(NamedTuple):
    mantissa: np.ndarray  # (rows, cols) int8 / int16 weight mantissas: W = mantissa 2^exp
    acc: np.ndarray  # (rows, cols) int16 / int32 learning accumulator, F fractional bits
    params: np.ndarray  # int64[N_PARAMS]: exponent, widths, rounding (kernels.P_*)
    rng: np.ndarray  # uint64[2]: stream key, next draw counter
    xq: np.ndarray  # int64[max(rows, cols)] scratch: quantised input / row factors
    yq: np.ndarray  # int64[max(rows, cols)] scratch: quantised second factor
    sums: np.ndarray  # int64[max(rows, cols)] scratch: read accumulators
    tally: np.ndarray  # int64[4] scratch: an update's writes, changes, saturations, draws
    counters: np.ndarray  # int64[N_COUNTERS]


register(FixedState, Kernels(kern.fixed_matvec, kern.fixed_rmatvec, kern.fixed_outer_update,
                             kern.fixed_commit, kern.fixed_sigmoid))

MATRIX_NAMES = ("W_q", "W_k", "W_v")
FIXED_BITS_BACKENDS = {"int8": 8, "int16": 16}  # backends whose width is part of the name


def _mac_plan(n: int, qmax_w: int, qmax_a: int, mac_bits: int) -> tuple[int, int]:
    """(check, shift) of a read summing n products: check if the worst case can exceed
    the accumulator; shift the fixed right shift of the sum into the neuron input."""
    bound = n * qmax_w * qmax_a
    mac_max = (1 << (mac_bits - 1)) - 1
    if bound >= 1 << 62:
        raise InputError(f"a read of {n} products of {qmax_w} x {qmax_a} is beyond 62 bits")
    check = int(bound > mac_max)
    shift = max(0, min(bound, mac_max).bit_length() + 1 - kern.NEURON_BITS)
    return check, shift


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
    def from_float(cls, W: np.ndarray, *, seed: int = 0, index: int = 0, bits: int = 8,
                   rounding: str = "stochastic", act_bits: int = 8, acc_bits: int = 32,
                   mac_bits: int = 32, lr_bits: int = 4,
                   weight_exp: int | list[int] | None = None,
                   headroom: int = 0, clip_init: bool = False,
                   strict: bool = False) -> FixedArray:
        """Program W: mantissas by round-to-nearest at the chosen exponent.

        ``weight_exp``: None (the exponent rule, plus ``headroom`` bits), an int, or one
        int per matrix [W_q, W_k, W_v] picked by ``index``. A fixed exponent that cannot
        represent W raises ValueError unless ``clip_init`` (then the clipped cells are
        counted as saturations, in strict mode too: programming is the user's choice).
        """
        bits = check_bits(bits)
        code = rounding_code(rounding)
        act_bits = check_bits(act_bits, "act_bits")
        acc_bits = check_int(acc_bits, "acc_bits", bits + 1, 32)
        mac_bits = check_int(mac_bits, "mac_bits", 16, 64)
        lr_bits = check_int(lr_bits, "lr_bits", 1, 16)
        headroom = check_int(headroom, "headroom", 0, 16)
        seed = check_int(seed, "seed", 0, 2**63 - 1)
        index = check_int(index, "index", 0, 2**16)
        W = np.asarray(W, dtype=np.float64)
        if W.ndim != 2 or W.size == 0:
            raise InputError(f"expected a non-empty matrix, got shape {W.shape}")
        if not np.isfinite(W).all():
            raise InputError("the weights to program are not all finite")
        what = MATRIX_NAMES[index] if index < len(MATRIX_NAMES) else f"matrix {index}"
        max_abs = float(np.abs(W).max())
        qmax = qmax_of(bits)
        if weight_exp is None:
            exp = choose_exponent(max_abs, bits, headroom)
        else:
            exp = _pick_exponent(weight_exp, index)
        mantissa, clipped = quantize_matrix(W, bits, exp)
        if clipped and not clip_init:
            need = choose_exponent(max_abs, bits)
            raise InputError(
                f"weight exponent {exp} cannot represent the initial weights of {what}: "
                f"max |W| = {max_abs:.4g} > {qmax} x 2^{exp} = {qmax * 2.0 ** exp:.4g} "
                f"({clipped} cells would saturate); allowed: an exponent >= {need} at "
                f"{bits} bits, or clip_init (--clip-init) to saturate them, counted")
        frac = acc_bits - bits - 1
        q_a = qmax_of(act_bits)
        rows, cols = W.shape
        mv_check, mv_shift = _mac_plan(cols, qmax, q_a, mac_bits)
        rmv_check, rmv_shift = _mac_plan(rows, qmax, q_a, mac_bits)
        params = np.zeros(kern.N_PARAMS, np.int64)
        params[kern.P_EXP] = exp
        params[kern.P_BITS] = bits
        params[kern.P_QMAX] = qmax
        params[kern.P_ROUNDING] = code
        params[kern.P_ACT_QMAX] = q_a
        params[kern.P_FRAC] = frac
        params[kern.P_ACC_MAX] = (1 << (acc_bits - 1)) - 1
        params[kern.P_MAC_MAX] = (1 << (mac_bits - 1)) - 1
        params[kern.P_MV_CHECK] = mv_check
        params[kern.P_RMV_CHECK] = rmv_check
        params[kern.P_MV_SHIFT] = mv_shift
        params[kern.P_RMV_SHIFT] = rmv_shift
        params[kern.P_STRICT] = int(bool(strict))
        params[kern.P_LR_BITS] = lr_bits
        n = max(rows, cols)
        counters = np.zeros(kern.N_COUNTERS, np.int64)
        counters[kern.SATURATIONS] = clipped
        rng = np.array([stream_key(seed, STREAM_DEVICE + index), 0], dtype=np.uint64)
        state = FixedState(np.ascontiguousarray(mantissa),
                           np.zeros((rows, cols), storage_dtype(acc_bits)), params, rng,
                           np.zeros(n, np.int64), np.zeros(n, np.int64), np.zeros(n, np.int64),
                           np.zeros(4, np.int64), counters)
        return cls(state)

    def options(self) -> dict[str, Any]:
        p = self.state.params
        return {"bits": int(p[kern.P_BITS]), "rounding": ROUNDINGS[int(p[kern.P_ROUNDING])],
                "act_bits": int(p[kern.P_ACT_QMAX]).bit_length() + 1,
                "acc_bits": int(p[kern.P_ACC_MAX]).bit_length() + 1,
                "mac_bits": int(p[kern.P_MAC_MAX]).bit_length() + 1,
                "lr_bits": int(p[kern.P_LR_BITS]),
                "weight_exp": int(p[kern.P_EXP]), "strict": bool(p[kern.P_STRICT])}

    # reading the state --------------------------------------------------------------
    @property
    def exponent(self) -> int:
        """The matrix's exponent: W = mantissa x 2^exponent."""
        return int(self.state.params[kern.P_EXP])

    @property
    def lsb(self) -> float:
        """The weight of one mantissa step, 2^exponent."""
        return 2.0 ** self.exponent

    @property
    def qmax(self) -> int:
        return int(self.state.params[kern.P_QMAX])

    @property
    def parameter_bytes(self) -> int:
        """Bytes of stored weights (mantissas at their storage width; one exponent aside)."""
        return int(self.state.mantissa.nbytes)

    def weight_bits(self) -> int:
        """Bits a chip holds per weight: the mantissa width (6 for ``--bits 6``, stored
        here in an int8)."""
        return int(self.state.params[kern.P_BITS])

    def accumulator_bits(self) -> int:
        """Bits per weight of the learning accumulator (``acc_bits``)."""
        return int(self.state.params[kern.P_ACC_MAX]).bit_length() + 1

    def to_float(self) -> np.ndarray:
        return dequantize(self.state.mantissa, self.exponent)

    def pending_float(self) -> np.ndarray:
        """The learning accumulator in weight units (what ``commit`` would add, unrounded)."""
        p = self.state.params
        return dequantize(self.state.acc, int(p[kern.P_EXP] - p[kern.P_FRAC]))

    # persistence ------------------------------------------------------------------
    @classmethod
    def _restore(cls, state: FixedState, options: dict[str, Any]) -> FixedArray:
        rows, cols = state.mantissa.shape
        ref = cls.from_float(np.zeros((rows, cols)), **options).state
        if not np.array_equal(state.params, ref.params):
            raise InputError("fixed-point parameters do not match the saved options")
        for f in ("rng", "xq", "yq", "sums", "tally"):
            if getattr(state, f).shape != getattr(ref, f).shape:
                raise InputError(f"field {f!r} has shape {getattr(state, f).shape}, expected "
                                 f"{getattr(ref, f).shape}")
        q, a = int(state.params[kern.P_QMAX]), int(state.params[kern.P_ACC_MAX])
        if np.abs(state.mantissa.astype(np.int64)).max() > q:
            raise InputError(f"weight mantissas beyond the {options.get('bits')}-bit format")
        if np.abs(state.acc.astype(np.int64)).max() > a:
            raise InputError("learning accumulator beyond its format")
        if (state.counters < 0).any():
            raise InputError("negative counters")
        return cls(state)

    # command line -------------------------------------------------------------------
    @classmethod
    def add_cli_arguments(cls, group: argparse._ArgumentGroup) -> None:
        group.add_argument("--bits", type=int, default=None, metavar="N",
                           help="weight mantissa bits 2..16 (backend fixed; default 8; "
                                "int8/int16 fix it)")
        group.add_argument("--rounding", default=None, metavar="MODE",
                           help=f"rounding of updates: {', '.join(ROUNDINGS)} "
                                "(default stochastic)")
        group.add_argument("--act-bits", type=int, default=None, metavar="N",
                           help="activation bits 2..16, one exponent per vector (default 8)")
        group.add_argument("--acc-bits", type=int, default=None, metavar="N",
                           help="learning accumulator bits, bits+1..32 (default 32)")
        group.add_argument("--mac-bits", type=int, default=None, metavar="N",
                           help="read accumulator bits 16..64 (default 32)")
        group.add_argument("--lr-bits", type=int, default=None, metavar="N",
                           help="learning-rate mantissa bits 1..16 (default 4, as Lava)")
        group.add_argument("--weight-exp", type=int, nargs="+", default=None, metavar="E",
                           help="fix the exponent: one for all matrices or three (W_q W_k W_v)"
                                " (default: the finest that holds the initial weights)")
        group.add_argument("--headroom", type=int, default=None, metavar="H",
                           help="extra exponent bits above the initial range (default 0)")
        group.add_argument("--clip-init", action="store_true", default=None,
                           help="with --weight-exp: saturate initial weights that do not fit "
                                "(counted) instead of refusing")
        group.add_argument("--strict-saturation", action="store_true", default=None,
                           help="raise on any saturation instead of clipping and counting")

    @classmethod
    def cli_options(cls, args: argparse.Namespace) -> dict[str, Any]:
        opts = {k: getattr(args, a) for k, a in (
            ("bits", "bits"), ("rounding", "rounding"), ("act_bits", "act_bits"),
            ("acc_bits", "acc_bits"), ("mac_bits", "mac_bits"), ("lr_bits", "lr_bits"),
            ("weight_exp", "weight_exp"),
            ("headroom", "headroom"), ("clip_init", "clip_init"), ("strict", "strict_saturation"))
            if getattr(args, a, None) is not None}
        fixed = FIXED_BITS_BACKENDS.get(args.backend)
        if fixed is not None and opts.get("bits", fixed) != fixed:
            raise InputError(f"--bits {opts['bits']} conflicts with --backend {args.backend} "
                             f"({fixed} bits); use --backend fixed --bits {opts['bits']}")
        we = opts.get("weight_exp")
        if we is not None:
            if len(we) not in (1, 3):
                raise InputError(f"--weight-exp takes 1 or 3 exponents (W_q W_k W_v), "
                                 f"got {len(we)}")
            opts["weight_exp"] = we[0] if len(we) == 1 else list(we)
        # validate now, before any training (same checks and messages as from_float)
        cls.from_float(np.zeros((1, 1)), **{**opts, "weight_exp": _first(opts.get("weight_exp")),
                                           "clip_init": True})
        return opts


def _first(weight_exp: Any) -> Any:
    return weight_exp[0] if isinstance(weight_exp, list) else weight_exp


def _pick_exponent(weight_exp: int | list[int], index: int) -> int:
    if isinstance(weight_exp, (list, tuple)):
        if len(weight_exp) != 3:
            raise InputError(f"weight_exp {list(weight_exp)!r}: give one exponent or three "
                             "(W_q, W_k, W_v)")
        for e in weight_exp:
            check_int(e, "weight_exp", -MAX_EXPONENT, MAX_EXPONENT)
        return int(weight_exp[min(index, 2)])
    return check_int(weight_exp, "weight_exp", -MAX_EXPONENT, MAX_EXPONENT)


__all__ = ["FIXED_BITS_BACKENDS", "FixedArray", "FixedState", "SaturationError"]
