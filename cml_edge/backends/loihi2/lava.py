"""Lava's weight utilities, re-implemented (not copied) from what Lava's source does.

Intel's Lava (lava-nc/lava, read at b6822fbc) prepares the weights of a ``Dense`` process
with the functions of ``src/lava/utils/weightutils.py``. This module does the same
arithmetic in our own code, so that the ``loihi2`` array programs exactly the integers,
``num_weight_bits`` and ``weight_exp`` Lava would give, without Lava (it does not install
on Python 3.11 and is no dependency). Each function names the Lava function it follows;
``tests/backends/loihi2/test_loihi2.py`` holds them to golden values read from Lava's own tests.

Sign modes are Lava's ``SignMode`` (a plain ``Enum``: NULL 0, MIXED 1, EXCITATORY 2,
INHIBITORY 3); here they are the strings of :data:`SIGN_MODES` and their integer codes
:data:`SIGN_MODE_CODES` (what the hardware and ``SignMode(code)`` take). NULL is left out:
Lava's models treat it as excitatory, and nothing here needs it.

The one thing Lava does not do is map a float matrix to its integer weights (its functions
expect integers already in [-256, 255]; ``GradedDense`` multiplies by 2^7 and truncates).
:func:`float_scale` is that map here (ours, documented there).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from cml_edge.errors import InputError

SIGN_MODES = ("mixed", "excitatory", "inhibitory")
SIGN_MODE_CODES = {"mixed": 1, "excitatory": 2, "inhibitory": 3}
"""Lava's ``SignMode`` values (``weightutils.SignMode``): what ``SignMode(code)`` takes."""
LAVA_SIGN_MODES = {"mixed": "MIXED", "excitatory": "EXCITATORY", "inhibitory": "INHIBITORY"}
"""The names of Lava's ``SignMode`` members (``SignMode[name]``): what an export carries.
``Dense`` compares its ``sign_mode`` with the members, so a bare code (1) is not MIXED there
and clips every negative weight."""
MAX_NUM_WEIGHT_BITS = 8  # Lava: W_WEIGHTS_U = 8, the default num_weight_bits

STANDARD_RANGE = {"mixed": (-128, 127), "excitatory": (0, 255), "inhibitory": (-255, 0)}
"""Lava's standard 8-bit weights per sign mode: the integers :func:`optimize_weight_bits`
maps to ``num_weight_bits`` <= 8 without loss (signed 8 bits when mixed, an 8-bit
magnitude otherwise). Mixed weights beyond [-128, 127] lose their LSB (Lava drops it in
mixed mode), and ``optimize_weight_bits(..., loihi2=True)`` refuses odd ones there."""


def _check_mode(sign_mode: str) -> str:
    if sign_mode not in SIGN_MODES:
        raise InputError(f"unknown sign mode {sign_mode!r} (allowed: {', '.join(SIGN_MODES)})")
    return sign_mode


def determine_sign_mode(weights: np.ndarray) -> str:
    """Lava ``determine_sign_mode``: excitatory if min >= 0 (also all zero), inhibitory
    if max <= 0, else mixed."""
    W = np.asarray(weights)
    if W.min() >= 0:
        return "excitatory"
    if W.max() <= 0:
        return "inhibitory"
    return "mixed"


def weight_limits(sign_mode: str, num_bits: int = 8) -> tuple[int, int]:
    """The range Lava ``clip_weights(W, sign_mode, num_bits)`` clips to: mixed
    [-2^num_bits, 2^num_bits - 1], excitatory [0, 2^num_bits - 1], inhibitory
    [-(2^num_bits - 1), 0] (it negates inhibitory weights, clips to [0, max], negates back)."""
    top = (1 << num_bits) - 1
    mode = _check_mode(sign_mode)
    if mode == "mixed":
        return -(1 << num_bits), top
    return (0, top) if mode == "excitatory" else (-top, 0)


def clip_weights(weights: np.ndarray, sign_mode: str, num_bits: int = 8) -> np.ndarray:
    """Lava ``clip_weights`` (``learning_simulation`` False, the only value Lava passes):
    int32 truncation toward zero, then the clip of :func:`weight_limits`."""
    lo, hi = weight_limits(sign_mode, num_bits)
    return np.clip(np.asarray(weights).astype(np.int32), lo, hi)


def truncate_weights(weights: np.ndarray, sign_mode: str, num_weight_bits: int,
                     max_num_weight_bits: int = MAX_NUM_WEIGHT_BITS) -> np.ndarray:
    """Lava ``truncate_weights``: drop k = max_num_weight_bits - num_weight_bits (+1 in
    mixed mode) low bits by an arithmetic shift, (W >> k) << k.

    After int32 truncation toward zero. The shift floors, so a negative mixed weight moves
    away from zero (-255 -> -256); inhibitory weights are negated first, so their
    magnitude floors toward zero (-255 -> -254 at 7 bits). Mixed mode always drops the LSB:
    at 8 bits mixed weights are even.
    """
    mode = _check_mode(sign_mode)
    W = np.asarray(weights).astype(np.int32)
    if mode == "inhibitory":
        W = -W
    k = max_num_weight_bits - int(num_weight_bits) + (1 if mode == "mixed" else 0)
    if k < 0:
        raise InputError(f"num_weight_bits {num_weight_bits} is beyond "
                         f"{max_num_weight_bits} (a negative shift count)")
    W = (W >> k) << k
    return -W if mode == "inhibitory" else W


@dataclass(frozen=True)
class OptimizedWeights:
    """What Lava ``optimize_weight_bits`` returns (its ``OptimizedWeights`` dataclass)."""

    weights: np.ndarray
    num_weight_bits: int
    weight_exp: int


def _validate(W: np.ndarray, sign_mode: str) -> None:
    """Lava ``_validate_weights``: mixed [-256, 255], excitatory [0, 255], inhibitory
    [-255, 0]; ValueError otherwise."""
    m, x, i = (sign_mode == "mixed"), (sign_mode == "excitatory"), (sign_mode == "inhibitory")
    lo, hi = -256 * (m + i) + i, 255 * (m + x)
    if W.size and (W.min() < lo or W.max() > hi):
        raise InputError(f"weights have to be between {lo} and {hi} for sign mode "
                         f"{sign_mode} (got {W.min()}..{W.max()})")


def _weight_exp(W: np.ndarray, sign_mode: str) -> int:
    """Lava ``_determine_weight_exp``: the exponent that moves the largest magnitude into
    the top of the 8-bit range (mixed: 127 / max or -128 / min, whichever is smaller, one
    bit more for the sign)."""
    w_max, w_min = float(W.max()), float(W.min())
    if w_max == 0 and w_min == 0:
        return 0
    if sign_mode == "mixed":
        pos = 127.0 / w_max if w_max > 0 else math.inf
        neg = -128.0 / w_min if w_min < 0 else math.inf
        scale = min(pos, neg)
    elif sign_mode == "inhibitory":
        scale = -255.0 / w_min
    else:
        scale = 255.0 / w_max
    bits = math.floor(math.log2(scale))
    if sign_mode == "mixed":
        bits += 1
    return -bits


def _num_weight_bits(W: np.ndarray, weight_exp: int, sign_mode: str) -> int:
    """Lava ``_determine_num_weight_bits``: 8 + weight_exp - n, n the largest power of two
    (<= 8) dividing every weight, one less in mixed mode. Not clipped to 1..8 (0 for an
    all-zero matrix, 9 for odd mixed weights at full range)."""
    n = 8
    while n > 0:
        q = W / float(1 << n)
        if np.sum(np.abs(q - np.round(q))) == 0:
            break
        n -= 1
    if sign_mode == "mixed":
        n -= 1
    return 8 + weight_exp - n


def optimize_weight_bits(weights: np.ndarray, sign_mode: str,
                         loihi2: bool = False) -> OptimizedWeights:
    """Lava ``optimize_weight_bits(weights, sign_mode, loihi2)``, step by step:

    1. validate the range (:func:`_validate`): the input is already integer-scale;
    2. ``weight_exp`` (:func:`_weight_exp`) and ``num_weight_bits`` (:func:`_num_weight_bits`);
    3. int32 truncation toward zero, then a shift left by -weight_exp (the 8-bit,
       MSB-aligned weights; a negative shift count gives zeros, as NumPy does there);
    4. with ``loihi2``: divided by 2^(8 - num_weight_bits) and, in mixed mode, by 2 more,
       truncating toward zero: the ``num_weight_bits``-bit mantissas. ValueError
       ("negative shift count") when num_weight_bits > 8, as in Lava.
    """
    mode = _check_mode(sign_mode)
    W = np.asarray(weights)
    _validate(W, mode)
    exp = _weight_exp(W, mode)
    nb = _num_weight_bits(W, exp, mode)
    out = W.astype(np.int32)
    out = (out << -exp) if exp <= 0 else np.zeros_like(out)
    if loihi2:
        if nb > MAX_NUM_WEIGHT_BITS:
            raise InputError(f"num_weight_bits {nb} > {MAX_NUM_WEIGHT_BITS}: negative shift "
                             "count (Lava's optimize_weight_bits with loihi2=True)")
        out = np.trunc(out / float(1 << (MAX_NUM_WEIGHT_BITS - nb))).astype(np.int32)
        if mode == "mixed":
            out = np.trunc(out / 2.0).astype(np.int32)
    return OptimizedWeights(out, int(nb), int(exp))


def float_scale(W: np.ndarray, sign_mode: str) -> int:
    """The exponent S of our float -> integer map: the largest S for which rint(W 2^S)
    (ties to even) lies in :data:`STANDARD_RANGE` of the sign mode, after the weights of
    the wrong sign are clipped to zero (excitatory: negatives; inhibitory: positives).

    This is not Lava's (Lava has no float map; the largest scale keeps the most of the
    float's precision). Then :func:`optimize_weight_bits` of rint(W 2^S) gives the
    mantissas, ``num_weight_bits`` (8 for generic weights) and ``weight_exp`` (-1 when a
    mixed matrix reaches past +-64). A matrix with nothing of its sign mode's sign gets S = 0.
    """
    lo, hi = STANDARD_RANGE[_check_mode(sign_mode)]
    W = np.clip(np.asarray(W, dtype=np.float64), -np.inf if lo < 0 else 0.0,
                np.inf if hi > 0 else 0.0)
    top = float(np.abs(W).max()) if W.size else 0.0
    if top == 0.0:
        return 0
    _, ex = math.frexp(top)  # top = f 2^ex, f in [0.5, 1): top 2^(8 - ex) in [128, 256)
    S = 8 - ex + 1
    while True:
        q = np.rint(np.ldexp(W, S))
        if q.min() >= lo and q.max() <= hi:
            return S
        S -= 1


__all__ = ["LAVA_SIGN_MODES", "MAX_NUM_WEIGHT_BITS", "SIGN_MODES", "SIGN_MODE_CODES",
           "STANDARD_RANGE", "OptimizedWeights", "clip_weights", "determine_sign_mode",
           "float_scale", "optimize_weight_bits", "truncate_weights", "weight_limits"]
