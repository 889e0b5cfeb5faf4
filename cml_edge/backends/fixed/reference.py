"""The fixed-point array's arithmetic as plain loops: the readable model its kernels are
held to.

Not dead code: the integer reads and the local rule (the paper's Eqs. 1-3 in Loihi-style
fixed point) step by step as :mod:`cml_edge.backends.fixed.kernels` documents them, in
Python integers (which cannot overflow, so every int64 register of the kernels is
visibly wide enough), without their vectorised lines, ranked draws or bit tricks;
``tests/backends/test_references.py`` runs each kernel and its function here on copies
of the same state and requires the same bits, states, counters and errors. Integer sums
are exact in any order; the draws of stochastic rounding are made cell by cell in the
kernels' order (column by column for a narrow matrix, row by row otherwise), one per
product with a fraction.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from cml_edge.backends.fixed.kernels import (
    ACC_SATURATIONS,
    ACC_WRITES,
    BYTES_READ,
    BYTES_WRITTEN,
    CELLS_CHANGED,
    COMMITS,
    MAC_SATURATIONS,
    MACS,
    MATVECS,
    OUTER_UPDATES,
    RMATVECS,
    RNG_DRAWS,
    SATURATIONS,
    UPDATE_MACS,
    WEIGHT_READS,
    WEIGHT_WRITES,
)
from cml_edge.backends.quant import (
    NARROW,
    NEAREST,
    SIGMOID_OUT_BITS,
    STOCHASTIC,
    SaturationError,
    sigmoid_entry,
)
from cml_edge.errors import InputError
from cml_edge.jit.rng import uniform

SCRATCH = ("xq", "yq", "sums", "tally")
"""The state's work space, which this model needs none of."""
State = Any  # a FixedState


# formats ---------------------------------------------------------------------------------
def exponent_for(top: float, qmax: int) -> int:
    """The finest e with top 2^-e <= qmax (top > 0 finite)."""
    e = math.frexp(top)[1] - qmax.bit_length()
    return e + 1 if math.ldexp(top, -e) > qmax else e


def quantise(x: np.ndarray, qmax: int) -> tuple[int, list[int]]:
    """(e, m): mantissas m = rint(x 2^-e) (ties to even) at the finest e that holds max|x|
    in [-qmax, qmax]; e = 0 for an all-zero x. A non-finite entry is refused."""
    if not all(math.isfinite(v) for v in x):
        raise InputError("non-finite input to a fixed-point array")
    top = max([abs(v) for v in x], default=0.0)
    if top == 0.0:
        return 0, [0] * len(x)
    e = exponent_for(top, qmax)
    return e, [int(np.rint(math.ldexp(v, -e))) for v in x]


def lr_mantissa(lr: float, lr_bits: int) -> tuple[int, int]:
    """lr ~ m 2^e with m an lr_bits-bit mantissa (nearest, ties to even)."""
    if not math.isfinite(lr):
        raise InputError("non-finite learning rate")
    if lr == 0.0:
        return 0, 0
    f, ex = math.frexp(abs(lr))
    m, e = float(np.rint(math.ldexp(f, lr_bits))), ex - lr_bits
    if m >= 2 ** lr_bits:
        m, e = m / 2.0, e + 1
    return int(m) if lr > 0 else -int(m), e


def clip(v: int, limit: int) -> tuple[int, int]:
    """(v clipped to [-limit, limit], 1 if it was clipped)."""
    w = min(max(v, -limit), limit)
    return w, int(w != v)


class Stream:
    """The array's stream: (key, counter), one word per draw."""

    def __init__(self, state: State) -> None:
        self.state, self.key, self.ctr = state, state.rng[0], int(state.rng[1])
        self.start = self.ctr

    def uniform(self) -> float:
        u = uniform(self.key, self.ctr)
        self.ctr += 1
        return u

    def close(self) -> int:
        self.state.rng[1] = np.uint64(self.ctr)
        return self.ctr - self.start


def shifted(v: int, k: int, mode: int, rng: Stream) -> int:
    """v 2^-k rounded to an integer by ``mode`` (k <= 0: exact): floor; nearest, ties to
    even; stochastic, floor plus one when a uniform u has u 2^k < the fraction r (r in
    units of 2^-k; beyond 62 bits, u < v 2^-k - floor as a float), drawn only when there
    is a fraction."""
    if k <= 0:
        return v << -k
    q = v >> k  # floor
    r = v - (q << k)
    if r == 0:
        return q
    if mode == NEAREST:
        half = 1 << (k - 1)
        return q + 1 if r > half or (r == half and q % 2 != 0) else q
    if mode == STOCHASTIC:
        u = rng.uniform()
        if k <= 62:
            return q + 1 if u * 2.0 ** k < float(r) else q
        return q + 1 if u < math.ldexp(float(v), -k) - float(q) else q
    return q


# the read ------------------------------------------------------------------------------
def read(state: State, x: np.ndarray, transposed: bool) -> np.ndarray:
    """W x (W^T x): the input quantised to ``act_bits``, the exact integer MAC of the
    weights with the nonzero inputs, saturated to ``mac_bits`` where the shape allows an
    overflow (counted; strict mode raises), shifted right (floor) into the neuron input,
    scaled by 2^(e_w + e_x + shift)."""
    p = state.params
    m = state.mantissa.T if transposed else state.mantissa
    n_out, n_in = m.shape
    e, xq = quantise(x, p.act_qmax)
    sums = [sum(int(m[i, j]) * xq[j] for j in range(n_in)) for i in range(n_out)]
    check, shift = (p.rmv_check, p.rmv_shift) if transposed else (p.mv_check, p.mv_shift)
    sats = 0
    if check:
        for i in range(n_out):
            sums[i], sat = clip(sums[i], p.mac_max)
            sats += sat
        if sats and p.strict:
            raise SaturationError("read accumulator overflow (strict mode)")
    out = np.array([math.ldexp(float(s >> shift), p.exp + e + shift) for s in sums])
    done = sum(v != 0 for v in xq) * n_out
    c = state.counters
    c[RMATVECS if transposed else MATVECS] += 1
    c[MACS] += done
    c[WEIGHT_READS] += done
    c[BYTES_READ] += done * state.mantissa.itemsize
    c[MAC_SATURATIONS] += sats
    return out


def matvec(state: State, x: np.ndarray) -> np.ndarray:
    return read(state, x, False)


def rmatvec(state: State, y: np.ndarray) -> np.ndarray:
    return read(state, y, True)


# the update and the commit ---------------------------------------------------------------
def outer_update(state: State, post: np.ndarray, pre: np.ndarray, lr: float,
                 defer: bool) -> None:
    """W += lr post pre^T in integers: each cell with both factors nonzero forms
    P = lr_m m_post[i] m_pre[j] (units 2^(lr_e + e_p + e_q)), rounded by the array's mode
    to the accumulator's unit 2^(e_w - F) (``defer``) or the weight's 2^e_w, and added
    with saturation. int64 registers: when the largest product would pass 2^62, every
    nonzero product saturates."""
    p = state.params
    c = state.counters
    c[OUTER_UPDATES] += 1
    lr_m, lr_e = lr_mantissa(lr, p.lr_bits)
    rows, cols = state.mantissa.shape
    e_p, rf = quantise(post, p.act_qmax)
    e_q, cq = quantise(pre, p.act_qmax)
    if lr_m == 0:
        return
    rf = [lr_m * v for v in rf]  # the row factors lr_m m_post[i]
    if defer:
        target, limit, k = state.acc, p.acc_max, p.exp - p.frac - (lr_e + e_p + e_q)
    else:
        target, limit, k = state.mantissa, p.qmax, p.exp - (lr_e + e_p + e_q)
    top = max(abs(v) for v in rf) * p.act_qmax
    beyond = k < 0 and (k < -62 or top >= (1 << 62) >> -k)
    cells = [(i, j) for j in range(cols) for i in range(rows)] if cols <= NARROW else \
        [(i, j) for i in range(rows) for j in range(cols)]
    rng = Stream(state)
    written = changed = sats = 0
    for i, j in cells:
        if rf[i] == 0 or cq[j] == 0:
            continue
        prod = rf[i] * cq[j]
        d = (1 << 62) * (1 if prod > 0 else -1) if beyond else shifted(prod, k, p.rounding, rng)
        if d == 0:
            continue
        old = int(target[i, j])
        new, sat = clip(old + d, limit)
        target[i, j] = new
        written += 1
        changed += new != old
        sats += sat
    size = (state.acc if defer else state.mantissa).itemsize
    if defer:
        c[ACC_WRITES] += written
        c[ACC_SATURATIONS] += sats
    else:
        c[WEIGHT_READS] += written
        c[WEIGHT_WRITES] += written
        c[CELLS_CHANGED] += changed
        c[SATURATIONS] += sats
    c[BYTES_READ] += written * size
    c[BYTES_WRITTEN] += written * size
    c[UPDATE_MACS] += sum(v != 0 for v in rf) * sum(v != 0 for v in cq)
    c[RNG_DRAWS] += rng.close()
    if sats and p.strict:
        raise SaturationError("fixed-point value saturated (strict mode)")


def commit(state: State) -> None:
    """Each accumulator, row by row, rounded to the weight's unit (F bits dropped by the
    rounding mode), added to the weight with saturation, and cleared."""
    p = state.params
    m, acc = state.mantissa, state.acc
    rows, cols = m.shape
    rng = Stream(state)
    cleared = written = changed = sats = 0
    for i in range(rows):
        for j in range(cols):
            a = int(acc[i, j])
            if a == 0:
                continue
            acc[i, j] = 0
            cleared += 1
            d = shifted(a, p.frac, p.rounding, rng)
            if d == 0:
                continue
            old = int(m[i, j])
            new, sat = clip(old + d, p.qmax)
            m[i, j] = new
            written += 1
            changed += new != old
            sats += sat
    c = state.counters
    c[COMMITS] += 1
    c[WEIGHT_READS] += written
    c[WEIGHT_WRITES] += written
    c[CELLS_CHANGED] += changed
    c[SATURATIONS] += sats
    c[RNG_DRAWS] += rng.close()
    c[BYTES_READ] += rows * cols * acc.itemsize + written * m.itemsize
    c[BYTES_WRITTEN] += cleared * acc.itemsize + written * m.itemsize
    if sats and p.strict:
        raise SaturationError("fixed-point weight saturated at commit (strict mode)")


def sigmoid(state: State, z: np.ndarray) -> np.ndarray:
    """sigmoid(z) from the 256-entry table (``quant.sigmoid_entry``), the entry a 16-bit
    fraction."""
    return np.array([math.ldexp(float(sigmoid_entry(v)), -SIGMOID_OUT_BITS) for v in z])
