"""Kernels of the Loihi-style fixed-point array: integer reads, integer local updates.

One source of truth: :class:`cml_edge.backends.fixed.array.FixedArray` calls these
kernels from Python and the compiled training and planning loops call them through
the seam (:mod:`cml_edge.backends.dispatch`). The formats are read from
``state.params``, the :class:`~cml_edge.backends.fixed.config.FixedParams` record of the
array's config and exponent (``p.exp``, ``p.qmax``...). All arithmetic on the weights is
integer (int64 registers emulating the widths in ``params``), so the order of a sum cannot
change a bit; the only floating-point steps are the exact power-of-two scalings at
the array's edge (float input -> mantissas, integer sum -> float output) and the
draws of stochastic rounding, which come from the counter-based generator keyed by
the array's stream (``rng[0]``) at the counter ``rng[1]``, advanced one per draw.

Read, W x (and W^T y the same way on the same mantissas):

1. x is quantised to ``act_bits`` with its own exponent e_x (nearest, ties to even);
2. integer multiply-accumulate of the weight mantissas with the nonzero input
   mantissas (an event-driven array does no work for a zero input) into a
   ``mac_bits`` accumulator (default 32). Overflow proof, checked for the shape when
   the array is built: |sum| <= n qmax_w qmax_x (n = cols, or rows for W^T y), e.g.
   256 x 127 x 127 = 4,129,024 < 2^31 for int8, 256 x 32767 x 127 = 1,065,320,448 < 2^31
   for int16. Where the bound exceeds the accumulator (``params.mv_check``) each sum
   is checked, saturated and counted (``mac_saturations``), or raises in strict mode;
3. ONE arithmetic right shift (floor) of the sum by a fixed amount into the 24-bit
   neuron input (zero for int8 x 8-bit activations; 7 for int16), then the output
   is that integer x 2^(e_w + e_x + shift), exactly.

Update, W += lr post pre^T:

1. post and pre are quantised to ``act_bits`` with their own exponents e_p, e_q;
   lr is an ``lr_bits`` mantissa x 2^lr_e (default 4 bits, as Lava: 0.001 = 8 x 2^-13);
2. each cell with both factors nonzero forms the integer product
   P = lr_m m_post[i] m_pre[j] (lr_bits + 2 (act_bits - 1) bits, 18 by default), in
   units of 2^(lr_e + e_p + e_q);
3. per walk (``defer``): P is narrowed to the learning accumulator's unit,
   2^(e_w - F) with F = acc_bits - bits - 1 fractional bits, by the array's rounding
   mode, and added there (saturating at +-(2^(acc_bits-1) - 1), counted); ``commit``
   rounds each accumulator to the weight's unit (drop F bits, the rounding mode),
   adds it to the weight, saturates (counted) and clears the accumulator: no sub-LSB
   state survives a commit;
   per step (not ``defer``): P is narrowed straight to the weight's unit 2^e_w by the
   rounding mode and added to the weight in place, saturated.

Counters (``FixedArray.counter_names``): ``macs`` are the integer multiply-adds of
reads; ``update_macs`` the integer products formed by updates; ``weight_reads`` the
weights read (reads, and read-modify-writes of a weight); ``acc_writes`` /
``weight_writes`` the cells written (a rounded update of zero is not written);
``cells_changed`` the weights whose stored value changed; ``saturations`` (weights),
``acc_saturations`` (learning accumulator), ``mac_saturations`` (read accumulator);
``rng_draws``; ``bytes_read`` / ``bytes_written`` the weight and accumulator bytes moved
(weights at their storage width, the accumulator at its own).

The same arithmetic as plain loops, which the tests hold these kernels to:
:mod:`cml_edge.backends.fixed.reference`.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from cml_edge.backends.quant import (
    NARROW,
    NEAREST,
    STOCHASTIC,
    SaturationError,
    count_nonzero,
    int_matvec,
    int_rmatvec,
    pow2,
    quantize_vector,
    saturate,
    shift_round,
    sigmoid_lut,
)
from cml_edge.errors import InputError
from cml_edge.jit.kernel import kernel
from cml_edge.jit.rng import uniform, word

# counter indices (names in FixedArray.counter_names)
MATVECS, RMATVECS, MACS, WEIGHT_READS, OUTER_UPDATES, UPDATE_MACS = 0, 1, 2, 3, 4, 5
ACC_WRITES, WEIGHT_WRITES, CELLS_CHANGED, COMMITS, SATURATIONS = 6, 7, 8, 9, 10
ACC_SATURATIONS, MAC_SATURATIONS, RNG_DRAWS, BYTES_READ, BYTES_WRITTEN = 11, 12, 13, 14, 15
N_COUNTERS = 16

NEURON_BITS = 24  # the neuron input a read's sum is shifted into
BIG_SHIFT = np.int64(1) << np.int64(62)


@kernel
def lr_mantissa(lr, lr_bits):
    """lr as (m, e) with m an lr_bits-bit mantissa (nearest, ties to even), lr ~ m 2^e."""
    if not abs(lr) <= 1.7976931348623157e308:
        raise InputError("non-finite learning rate")
    if lr == 0.0:
        return np.int64(0), 0
    f, ex = math.frexp(abs(lr))  # f in [0.5, 1)
    m = np.rint(math.ldexp(f, lr_bits))
    e = ex - lr_bits
    if m >= float(1 << lr_bits):
        m = m / 2.0
        e += 1
    mi = np.int64(m)
    return (mi if lr > 0 else -mi), e


@kernel
def _emit(p, sums, n, ex, check, shift, out, strict):
    """out[:n] = (saturated sums >> shift) x 2^(e_w + ex + shift); returns saturations."""
    e_out = p.exp + ex + shift
    sats = 0
    if check:
        mac_max = p.mac_max
        for i in range(n):
            s, sat = saturate(sums[i], mac_max)
            sums[i] = s
            sats += sat
        if sats and strict:
            raise SaturationError("read accumulator overflow (strict mode)")
    if -1000 < e_out < 1000:  # a power of two that is a normal double: exact multiply
        scale = pow2(e_out)
        for i in range(n):
            out[i] = float(sums[i] >> shift) * scale
    else:
        for i in range(n):
            out[i] = math.ldexp(float(sums[i] >> shift), e_out)
    return sats


@njit(cache=True, inline="always")
def fixed_matvec(state, x, out):
    _read(state.mantissa, state.params, state.xq, state.sums, state.counters, x, out, False)


@njit(cache=True, inline="always")
def fixed_rmatvec(state, y, out):
    _read(state.mantissa, state.params, state.xq, state.sums, state.counters, y, out, True)


@kernel
def _read(m, p, xq, sums, c, x, out, transposed):
    """out = W x (W^T x if ``transposed``): the input quantised, the exact integer MAC,
    the sums emitted. The state's arrays come one by one (one statement in the seam's
    kernels: reading them from the state inside the inlined step costs their reference
    counts)."""
    rows, cols = m.shape
    if transposed:
        e = quantize_vector(x, rows, p.act_qmax, xq)
        nnz = int_rmatvec(m, xq, sums)
        sats = _emit(p, sums, cols, e, p.rmv_check, p.rmv_shift, out, p.strict)
        done = nnz * cols
        c[RMATVECS] += 1
    else:
        e = quantize_vector(x, cols, p.act_qmax, xq)
        nnz = int_matvec(m, xq, sums)
        sats = _emit(p, sums, rows, e, p.mv_check, p.mv_shift, out, p.strict)
        done = nnz * rows
        c[MATVECS] += 1
    c[MACS] += done
    c[WEIGHT_READS] += done
    c[BYTES_READ] += done * m.itemsize
    c[MAC_SATURATIONS] += sats


@njit(cache=True, inline="always")
def _scaled(prod, pk, nk, big, mode, key, ctr, half, two_k):
    """round(prod 2^-k) in ``mode`` (k = pk > 0, or -nk <= 0 exact); returns (d, ctr)."""
    if pk == 0:  # exact; beyond any format if big
        return ((BIG_SHIFT if prod > 0 else -BIG_SHIFT) if big else prod << nk), ctr
    if pk > 62:
        d, drew = shift_round(prod, pk, mode, key, ctr)
        return d, ctr + drew
    d = prod >> pk  # floor
    r = prod - (d << pk)
    if r != 0:
        if mode == NEAREST:
            if r > half or (r == half and (d & 1) != 0):
                d += 1
        elif mode == STOCHASTIC:
            if uniform(key, ctr) * two_k < float(r):
                d += 1
            ctr += 1
    return d, ctr


@njit(cache=True, inline="always")
def _saturating_add(target, i, j, d, limit):
    """target[i, j] += d clipped to +-limit; returns (changed, saturated) as 0/1."""
    old = np.int64(target[i, j])
    new = old + d
    sat = 0
    if new > limit:
        new = limit
        sat = 1
    elif new < -limit:
        new = -limit
        sat = 1
    target[i, j] = new
    return int(new != old), sat


@njit(cache=True, inline="always")
def _exact_line(line, limit, fa, factors, nk, count_changed):
    """line[b] += (fa factors[b]) 2^nk, saturating at +-limit: the exact case of
    :func:`_add_outer`, written without branches so that it vectorises. A cell whose
    factor is 0 keeps its value with no select, as no cell is ever beyond +-limit
    (validated on load, clipped at every write). Returns (changed if ``count_changed``
    else 0, saturated); LLVM compiles the loop twice on the flag, so a caller that needs
    no change count pays none (0.50 -> 0.32 ns per cell in a throwaway loop,
    without the per-cell touched count, the select and the change count)."""
    changed = 0
    sats = 0
    for b in range(line.shape[0]):
        old = np.int64(line[b])
        t = old + ((fa * factors[b]) << nk)
        new = min(max(t, -limit), limit)  # a zero factor keeps the cell: |old| <= limit
        line[b] = new
        if count_changed:
            changed += new != old
        sats += t != new
    return changed, sats


RANKED_SHARE = 4
PROBE = 32
"""A stochastic line draws in the ranked, vectorised :func:`_ranked_line` when more than
1 in ``RANKED_SHARE`` of its first ``PROBE`` products have a fraction, else in
:func:`_ordered_line`. The ranked line costs about the same at every share, the ordered
one a branch per drawing product; both make the same draws, so the choice moves no bit
(in throwaway loops, the ordered line 1.24 ns per cell at a 15 % share and 1.99
at 50 %, the ranked one 1.31 at any share)."""


@njit(cache=True, inline="always")
def _stochastic_line(line, limit, fa, factors, pk, two_k, key, ctr, count_changed, rank):
    """line[b] += round(fa factors[b] 2^-pk) with stochastic rounding where factors[b] != 0
    (0 < pk <= 62), drawing as :func:`_scaled` does (a product draws when its factor is
    nonzero and it has a fraction, at the next counter), in the line that ``RANKED_SHARE``
    picks. Returns (written, changed if ``count_changed`` else 0, saturated, the next
    counter)."""
    if pk <= 53:
        low = (np.int64(1) << pk) - 1
        probe = min(line.shape[0], PROBE)
        draws = 0
        for b in range(probe):
            draws += ((fa * factors[b]) & low) != 0
        if draws * RANKED_SHARE > probe:
            return _ranked_line(line, limit, fa, factors, pk, key, ctr, count_changed, rank)
    return _ordered_line(line, limit, fa, factors, pk, two_k, key, ctr, count_changed)


@njit(cache=True, inline="always")
def _ordered_line(line, limit, fa, factors, pk, two_k, key, ctr, count_changed):
    """:func:`_stochastic_line` in one pass, the draw the only branch in the loop."""
    written = 0
    changed = 0
    sats = 0
    for b in range(line.shape[0]):
        fb = factors[b]
        prod = fa * fb
        d = prod >> pk  # floor
        r = prod - (d << pk)
        if r != 0:  # (r == 0 when fb == 0)
            d += np.int64(uniform(key, ctr) * two_k < float(r))
            ctr += 1
        live = d != 0
        old = np.int64(line[b])
        t = old + d
        new = min(max(t, -limit), limit)
        line[b] = new
        written += live
        if count_changed:
            changed += new != old
        sats += t != new
    return written, changed, sats, ctr


@njit(cache=True, inline="always")
def _ranked_line(line, limit, fa, factors, pk, key, ctr, count_changed, rank):
    """:func:`_stochastic_line`'s draws in two passes without a branch, so that they
    vectorise (0 < pk <= 53; the same draws at the same counters). The first writes each
    product's counter offset, the number of drawing products before it, into ``rank``;
    the second draws every product's word at its counter (used only where there is a
    fraction) and compares in integers: uniform 2^pk < r exactly when u < r 2^(53-pk),
    u the word's top 53 bits (exact as pk <= 53)."""
    low = (np.int64(1) << pk) - 1
    run = np.int64(0)
    for b in range(line.shape[0]):
        rank[b] = run
        run += ((fa * factors[b]) & low) != 0
    up = np.int64(53) - pk
    written = 0
    changed = 0
    sats = 0
    for b in range(line.shape[0]):
        prod = fa * factors[b]
        r = prod & low  # the fraction (prod - floor)
        u = np.int64(word(key, np.uint64(ctr + rank[b])) >> np.uint64(11))
        d = (prod >> pk) + np.int64((r != 0) & (u < (r << up)))
        old = np.int64(line[b])
        t = old + d
        new = min(max(t, -limit), limit)
        line[b] = new
        written += d != 0
        if count_changed:
            changed += new != old
        sats += t != new
    return written, changed, sats, ctr + run


@kernel
def _add_outer(target, limit, rf, cq, rows, cols, k, top, mode, rng, tally, count_changed,
               rank):
    """target += round(rf cq^T 2^-k) on the cells whose factors are both nonzero.

    ``top`` bounds |rf[i] cq[j]|. Saturates at +-limit; tally[:4] gets writes, changes
    (0 unless ``count_changed``: the per-walk accumulator does not count them),
    saturations, draws. Returns the number of cells touched (integer products formed):
    the nonzero row factors times the nonzero column factors. ``rank`` (int64, at least
    max(rows, cols) long) is work space of the stochastic line.
    Narrow matrices (cols <= NARROW) are walked column by column (a one-hot pre touches
    one column only), wide ones row by row; the order fixes which random draw each
    cell gets.
    """
    key = rng[0]
    ctr = np.int64(rng[1])
    ctr0 = ctr
    written = 0
    changed = 0
    sats = 0
    touched = count_nonzero(rf, rows) * count_nonzero(cq, cols)
    big = k < 0 and (k < -62 or top >= (BIG_SHIFT >> np.int64(-k)))
    nk = np.int64(-k) if k < 0 else np.int64(0)
    pk = np.int64(k) if k > 0 else np.int64(0)
    two_k = pow2(pk) if pk <= 62 else 0.0
    half = (np.int64(1) << (pk - 1)) if 0 < pk <= 62 else np.int64(0)
    if pk == 0 and not big:  # exact products: nothing to round or draw
        if cols <= NARROW:
            for a in range(cols):
                if cq[a] != 0:
                    c, s = _exact_line(target[:, a], limit, cq[a], rf, nk, count_changed)
                    changed += c
                    sats += s
        else:
            for a in range(rows):
                if rf[a] != 0:
                    c, s = _exact_line(target[a], limit, rf[a], cq, nk, count_changed)
                    changed += c
                    sats += s
        written = touched  # a nonzero exact product is a nonzero change
    elif mode == STOCHASTIC and 0 < pk <= 62:
        if cols <= NARROW:
            for a in range(cols):
                if cq[a] != 0:
                    w, c, s, ctr = _stochastic_line(target[:, a], limit, cq[a], rf, pk,
                                                    two_k, key, ctr, count_changed, rank)
                    written += w
                    changed += c
                    sats += s
        else:
            for a in range(rows):
                if rf[a] != 0:
                    w, c, s, ctr = _stochastic_line(target[a], limit, rf[a], cq, pk,
                                                    two_k, key, ctr, count_changed, rank)
                    written += w
                    changed += c
                    sats += s
    elif cols <= NARROW:
        for a in range(cols):
            fa = cq[a]
            if fa == 0:
                continue
            for b in range(rows):
                fb = rf[b]
                if fb == 0:
                    continue
                d, ctr = _scaled(fa * fb, pk, nk, big, mode, key, ctr, half, two_k)
                if d != 0:
                    ch, sat = _saturating_add(target, b, a, d, limit)
                    written += 1
                    changed += ch
                    sats += sat
    else:
        for a in range(rows):
            fa = rf[a]
            if fa == 0:
                continue
            for b in range(cols):
                fb = cq[b]
                if fb == 0:
                    continue
                d, ctr = _scaled(fa * fb, pk, nk, big, mode, key, ctr, half, two_k)
                if d != 0:
                    ch, sat = _saturating_add(target, a, b, d, limit)
                    written += 1
                    changed += ch
                    sats += sat
    rng[1] = np.uint64(ctr)
    tally[0] = written
    tally[1] = changed if count_changed else 0
    tally[2] = sats
    tally[3] = ctr - ctr0
    return touched


@njit(cache=True, inline="always")
def fixed_outer_update(state, post, pre, lr, defer):
    # the reads' sums vector, free during an update, holds the stochastic line's ranks
    _outer_update(state.mantissa, state.acc, state.params, state.rng, state.xq, state.yq,
                  state.tally, state.counters, state.sums, post, pre, lr, defer)


@kernel
def _outer_update(m, acc, p, rng, rf, cq, tally, c, rank, post, pre, lr, defer):
    """W += lr post pre^T (or into the accumulator when ``defer``) on the state's arrays
    (passed one by one: see :func:`cml_edge.backends.crossbar.read.read`); ``rank`` is
    work space of the stochastic line (:func:`_ranked_line`): the state's ``sums``."""
    rows, cols = m.shape
    c[OUTER_UPDATES] += 1
    lr_m, lr_e = lr_mantissa(lr, p.lr_bits)
    e_p = quantize_vector(post, rows, p.act_qmax, rf)
    e_q = quantize_vector(pre, cols, p.act_qmax, cq)
    if lr_m == 0:
        return
    top_r = np.int64(0)
    for i in range(rows):
        rf[i] *= lr_m  # row factor lr_m m_post[i]
        top_r = max(top_r, abs(rf[i]))
    top = top_r * p.act_qmax
    mode = p.rounding
    # P is in units of 2^(lr_e + e_p + e_q); the target's unit is 2^(e_w - F) or 2^e_w
    if defer:
        k = p.exp - p.frac - (lr_e + e_p + e_q)
        touched = _add_outer(acc, p.acc_max, rf, cq, rows, cols, k, top, mode, rng, tally,
                             False, rank)
        c[ACC_WRITES] += tally[0]
        c[ACC_SATURATIONS] += tally[2]
        c[BYTES_READ] += tally[0] * acc.itemsize
        c[BYTES_WRITTEN] += tally[0] * acc.itemsize
    else:
        k = p.exp - (lr_e + e_p + e_q)
        touched = _add_outer(m, p.qmax, rf, cq, rows, cols, k, top, mode, rng, tally, True,
                             rank)
        c[WEIGHT_READS] += tally[0]
        c[WEIGHT_WRITES] += tally[0]
        c[CELLS_CHANGED] += tally[1]
        c[SATURATIONS] += tally[2]
        c[BYTES_READ] += tally[0] * m.itemsize
        c[BYTES_WRITTEN] += tally[0] * m.itemsize
    c[UPDATE_MACS] += touched
    c[RNG_DRAWS] += tally[3]
    if tally[2] and p.strict:
        raise SaturationError("fixed-point value saturated (strict mode): the update was "
                              "clipped and the array is left as it is")


@kernel
def fixed_commit(state):
    m = state.mantissa
    acc = state.acc
    p = state.params
    rows, cols = m.shape
    frac = p.frac
    mode = p.rounding
    qmax = p.qmax
    strict = p.strict != 0
    key = state.rng[0]
    ctr = np.int64(state.rng[1])
    cleared = 0
    written = 0
    changed = 0
    sats = 0
    draws = 0
    for i in range(rows):
        for j in range(cols):
            a = np.int64(acc[i, j])
            if a == 0:
                continue
            acc[i, j] = 0
            cleared += 1
            d, drew = shift_round(a, frac, mode, key, ctr)
            ctr += drew
            draws += drew
            if d == 0:
                continue
            old = np.int64(m[i, j])
            new, sat = saturate(old + d, qmax)
            sats += sat
            m[i, j] = new
            written += 1
            changed += new != old
    state.rng[1] = np.uint64(ctr)
    c = state.counters
    c[COMMITS] += 1
    c[WEIGHT_READS] += written
    c[WEIGHT_WRITES] += written
    c[CELLS_CHANGED] += changed
    c[SATURATIONS] += sats
    c[RNG_DRAWS] += draws
    c[BYTES_READ] += rows * cols * acc.itemsize + written * m.itemsize
    c[BYTES_WRITTEN] += cleared * acc.itemsize + written * m.itemsize
    if sats and strict:
        raise SaturationError("fixed-point weight saturated at commit (strict mode): the "
                              "weights were clipped and the array is left as it is")


@njit(cache=True, inline="always")
def fixed_sigmoid(state, z, out):
    for i in range(z.shape[0]):
        out[i] = sigmoid_lut(z[i])
