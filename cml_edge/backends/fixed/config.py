"""Configuration of the Loihi-style fixed-point array, as data: :class:`FixedConfig`.

Every number the fixed-point emulation depends on is a field of :class:`FixedConfig`
(frozen, documented, validated); ``int8`` and ``int16`` are presets that fix ``bits``
(:data:`PRESETS`); every field can be set (``--set field=value`` on the command line,
or its named flag: ``--bits``, ``--rounding``...). The kernels read
:class:`FixedParams`, the record of the config's numeric fields plus what an array
derives from its matrix (its exponent, the formats' limits, the read accumulator's
checks and shifts; :func:`fixed_params`). How well each choice does on the paper's
protocol is measured in docs/devices/fixed.md.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from cml_edge.backends.device import CostModel, Knob
from cml_edge.backends.fields import option, resolve
from cml_edge.backends.fixed.kernels import NEURON_BITS
from cml_edge.backends.params import build_record, kernel_record
from cml_edge.backends.quant import (
    MAX_BITS,
    MAX_EXPONENT,
    MIN_BITS,
    ROUNDINGS,
    check_bits,
    check_int,
    qmax_of,
    rounding_code,
)
from cml_edge.errors import InputError


@dataclass(frozen=True)
class FixedConfig:
    """The number formats and rounding of one fixed-point array (Loihi-style)."""

    bits: int = option(8, flag="--bits", metavar="N",
                       help="weight mantissa bits 2..16 (backend fixed; default 8; int8/int16 "
                            "fix it)",
                            lo=MIN_BITS, hi=MAX_BITS,
                            why="a symmetric mantissa: 2 bits is the least with a nonzero weight")
    """Weight mantissa width, 2..16 bits, symmetric (qmax = 2^(bits-1) - 1, so that
    negating a weight is exact). Default 8: Loihi's synaptic weights are at most 8 bits;
    ``int8`` and ``int16`` fix it."""
    rounding: str = option("stochastic", flag="--rounding", metavar="MODE", choices=ROUNDINGS,
                           help=f"rounding of updates: {', '.join(ROUNDINGS)} "
                                "(default stochastic)")
    """How the learning path narrows a value to fewer bits: ``floor`` (an arithmetic
    right shift, as Lava), ``nearest`` (ties to even) or ``stochastic`` (unbiased, one
    independent draw per cell; Lava shares one draw per epoch). Default stochastic:
    round-to-nearest stalls once updates fall below half an LSB."""
    act_bits: int = option(8, flag="--act-bits", metavar="N",
                           help="activation bits 2..16, one exponent per vector (default 8)",
                           lo=MIN_BITS, hi=MAX_BITS, why="as the weights' mantissa")
    """Bits of the activations (inputs of a read, factors of an update), each vector
    quantised with its own power-of-two exponent (nearest, ties to even). Default 8, the
    width of Loihi's graded spikes."""
    acc_bits: int = option(32, flag="--acc-bits", metavar="N",
                           help="learning accumulator bits, bits+1..32 (default 32)",
                           lo=MIN_BITS + 1, hi=32,
                           why="bits + 1 (one fraction bit) .. 32 (a 32-bit register)")
    """Width of the per-walk learning accumulator, bits+1..32, which keeps
    F = acc_bits - bits - 1 fractional bits below the weight's LSB (23 at int8; its
    integer part holds twice the weight range). Default 32, one rounding per commit;
    Loihi's 16 bits round twice (measured against 32 in docs/devices/fixed.md)."""
    mac_bits: int = option(32, flag="--mac-bits", metavar="N",
                           help="read accumulator bits 16..64 (default 32)",
                           lo=16, hi=64, why="16..64 (an int64 sum)")
    """Width of the read (multiply-accumulate) accumulator, 16..64. Default 32: at the
    CML's shapes no int8 or int16 read can overflow it (the bound is checked when an
    array is built; where it could overflow, each sum is saturated and counted)."""
    lr_bits: int = option(4, flag="--lr-bits", metavar="N",
                          help="learning-rate mantissa bits 1..16 (default 4, as Lava)",
                          lo=1, hi=16, why="a mantissa of 1..16 bits")
    """Mantissa bits of the learning rate, 1..16 (lr ~ m 2^e). Default 4, Lava's:
    0.001 becomes 8 x 2^-13 = 0.000977."""
    weight_exp: int | tuple[int, ...] | None = option(
        None, flag="--weight-exp", metavar="E", per_matrix="each", noun="exponents",
        help="fix the exponent: one for all matrices or three (W_q W_k W_v) (default: the "
             "finest that holds the initial weights)",
             lo=-MAX_EXPONENT, hi=MAX_EXPONENT, why="2^+-60 stays within an int64 shift")
    """The weights' power-of-two exponent (W = mantissa x 2^e), one for every matrix or
    one per matrix [W_q, W_k, W_v], each within +-60. Default None: the finest exponent
    that holds the initial max|W| (Lava's ``optimize_weight_bits``), plus ``headroom``."""
    headroom: int = option(0, flag="--headroom", metavar="H", kernel=False,
                           help="extra exponent bits above the initial range (default 0)",
                           lo=0, hi=16,
                           why="each bit halves the resolution: 16 leaves none at 16 bits")
    """Extra exponent bits above the initial range, 0..16, room for weights to grow.
    Default 0: training grows max|W| by little and a saturated cell is counted, while
    each bit of headroom halves the resolution."""
    clip_init: bool = option(False, flag="--clip-init", kernel=False,
                             help="with --weight-exp: saturate initial weights that do not "
                                  "fit (counted) instead of refusing")
    """With a fixed ``weight_exp`` too small for the initial weights: saturate them
    (counted as saturations) instead of refusing. Default False."""
    strict: bool = option(False, flag="--strict-saturation",
                          help="raise on any saturation instead of clipping and counting")
    """Raise on any saturation (weights, accumulators, reads) instead of clipping and
    counting it. Default False: a chip saturates silently; the counters report it."""

    def __post_init__(self) -> None:
        bits = check_bits(self.bits)
        rounding_code(self.rounding)
        ints = {"bits": bits, "act_bits": check_bits(self.act_bits, "act_bits"),
                "acc_bits": check_int(self.acc_bits, "acc_bits", bits + 1, 32),
                "mac_bits": check_int(self.mac_bits, "mac_bits", 16, 64),
                "lr_bits": check_int(self.lr_bits, "lr_bits", 1, 16),
                "headroom": check_int(self.headroom, "headroom", 0, 16)}
        for name, value in ints.items():
            object.__setattr__(self, name, value)
        object.__setattr__(self, "weight_exp", _exponents(self.weight_exp))
        for name in ("clip_init", "strict"):
            value = getattr(self, name)
            if not isinstance(value, (bool, np.bool_)):
                raise InputError(f"{name} {value!r} is not a boolean")
            object.__setattr__(self, name, bool(value))
        if self.weight_exp is None and self.clip_init:
            raise InputError("clip_init (--clip-init) needs weight_exp (--weight-exp): the "
                             "exponent chosen from the initial weights holds them all")
        if self.weight_exp is not None and self.headroom:
            raise InputError(f"headroom (--headroom) {self.headroom} does nothing with "
                             "weight_exp (--weight-exp), which fixes the exponent: give one "
                             "of them")


def _exponents(weight_exp: Any) -> int | tuple[int, ...] | None:
    if weight_exp is None:
        return None
    if isinstance(weight_exp, (list, tuple)):
        if len(weight_exp) != 3:
            raise InputError(f"weight_exp {list(weight_exp)!r}: give one exponent or three "
                             "(W_q, W_k, W_v)")
        return tuple(check_int(e, "weight_exp", -MAX_EXPONENT, MAX_EXPONENT)
                     for e in weight_exp)
    return check_int(weight_exp, "weight_exp", -MAX_EXPONENT, MAX_EXPONENT)


PRESETS: dict[str, dict[str, Any]] = {
    "int8": {"bits": 8},
    "int16": {"bits": 16},
}
"""Named formats; the backends ``int8`` and ``int16`` are these (``fixed`` is the
defaults, any ``--bits``)."""


def make_config(**options: Any) -> FixedConfig:
    """The config of ``options`` (field values, or a ``preset`` name and fields)."""
    return resolve(FixedConfig, PRESETS, options, "fixed")


KNOBS = (
    Knob("bits", "bits", 2, 16, "high", integer=True,
         doc="fixed: weight mantissa bits (2..16)"),
)
"""What a break point can sweep on the fixed-point device (``cml-edge scenario
breakpoint --knob``)."""


# the cost model (cml_edge.costs.ledger.COSTS) -------------------------------------------
_COUNTERS = dict(mac_counters=("macs", "update_macs"), byte="sram_byte",
                 byte_counters=("bytes_read", "bytes_written"))
INT8 = CostModel("int8", "int8_mac", **_COUNTERS)
"""Up to 8-bit weights: the int8 MAC, for every read and update MAC, and the SRAM byte."""
INT16 = CostModel("int16", "int32_mac", **_COUNTERS)
"""9..16-bit weights: the int32 MAC, an upper bound, and the SRAM byte."""


def cost_model(config: FixedConfig) -> CostModel:
    """The cost model of an array of ``config``: by its weight width."""
    return INT8 if config.bits <= 8 else INT16


# the kernels' parameter record ---------------------------------------------------------
FixedParams = kernel_record(FixedConfig, "FixedParams", __name__, derived={
    "exp": int,  # the matrix's exponent: W = mantissa x 2^exp
    "qmax": int,  # largest weight mantissa, 2^(bits-1) - 1
    "act_qmax": int,  # largest activation mantissa, 2^(act_bits-1) - 1
    "frac": int,  # fractional bits of the learning accumulator, acc_bits - bits - 1
    "acc_max": int,  # largest learning-accumulator value, 2^(acc_bits-1) - 1
    "mac_max": int,  # largest read-accumulator value, 2^(mac_bits-1) - 1
    "mv_check": int,  # 1 if a read W x could exceed mac_max (then each sum is checked)
    "rmv_check": int,  # the same for W^T y
    "mv_shift": int,  # right shift of a W x sum into the neuron input
    "rmv_shift": int,  # the same for W^T y
})


def fixed_params(config: FixedConfig, exp: int, shape: tuple[int, int]) -> Any:
    """The :class:`FixedParams` of a (rows, cols) array at exponent ``exp``."""
    qmax = qmax_of(config.bits)
    q_a = qmax_of(config.act_bits)
    rows, cols = shape
    mv_check, mv_shift = _mac_plan(cols, qmax, q_a, config.mac_bits)
    rmv_check, rmv_shift = _mac_plan(rows, qmax, q_a, config.mac_bits)
    return build_record(
        FixedParams, config, exp=exp, qmax=qmax, act_qmax=q_a,
        frac=config.acc_bits - config.bits - 1, acc_max=(1 << (config.acc_bits - 1)) - 1,
        mac_max=(1 << (config.mac_bits - 1)) - 1, mv_check=mv_check, rmv_check=rmv_check,
        mv_shift=mv_shift, rmv_shift=rmv_shift)


def _mac_plan(n: int, qmax_w: int, qmax_a: int, mac_bits: int) -> tuple[int, int]:
    """(check, shift) of a read summing n products: check if the worst case can exceed
    the accumulator; shift the fixed right shift of the sum into the neuron input."""
    bound = n * qmax_w * qmax_a
    mac_max = (1 << (mac_bits - 1)) - 1
    if bound >= 1 << 62:
        raise InputError(f"a read of {n} products of {qmax_w} x {qmax_a} is beyond 62 bits")
    check = int(bound > mac_max)
    shift = max(0, min(bound, mac_max).bit_length() + 1 - NEURON_BITS)
    return check, shift


__all__ = ["INT8", "INT16", "KNOBS", "PRESETS", "FixedConfig", "FixedParams", "cost_model",
           "fixed_params", "make_config"]
