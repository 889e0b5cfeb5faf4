"""Kernels of the ``loihi2`` array: Loihi 2's dendrite and learning engine as Lava models them.

One source of truth: :class:`cml_edge.backends.loihi2.array.Loihi2Array` calls these
kernels from Python and the compiled training and planning loops call them through the
seam. Each step below names the Lava file and function it follows (lava-nc/lava at
b6822fbc); where Lava is silent, the choice is ours and says so. Weights are the
integers ``state.w`` (9-bit signed, as Lava's learning ``Dense`` holds them); a weight w
stands for w 2^(E - S) (E = ``params.exp``, the weight exponent; S = ``params.scale_exp``).

Read, W x (and W^T y the same way on the same weights: the Dense of W^T):

1. x becomes graded-spike payloads s = rint(x 2^-e) (ties to even), signed integers
   with |s| <= 2^(num_message_bits - 1) - 1, one power-of-two scale e per vector
   (the sender's format; Lava leaves it to the network): the finest at which the
   payloads fit and, with ``payload_scale`` ``safe``, the read cannot overflow the
   neuron's 24-bit input for any 9-bit weights (:func:`encode`);
2. the dendritic sum over the nonzero payloads (event-driven), exact in int64, then
   shifted by the weight exponent as ``AbstractPyDenseModelBitAcc.run_spk`` does
   (``>> -E``, a floor, or ``<< E``): the Dense's a_out;
3. the neuron's input: a_out << 6 into the state u, as ``PyLifModelBitAcc`` adds its
   input to u (with ``du`` = 4095 the current decays fully each step, so u is exactly the
   input). Where a read overflows, it is computed as Lava computes it
   (:func:`neuron_input`): the dot product and the shifts in int32, then one 2^24
   correction of u (past +-2^23), counted (``neuron_wraps``), or raising in strict mode.
   The default ``safe`` payload scale never overflows. The chip's dendritic accumulator
   width is not public: the 24-bit u is the one bounded register Lava's bit-accurate
   models define;
4. the output u x 2^(e - S - 6), exactly.

Update, W += lr post pre^T, as Lava's learning engine (``connection.py``,
``LearningConnectionModelBitApproximate``; ``learning_rule_applier.py``,
``LearningRuleApplierBitApprox``) forms a product term and writes back:

1. lr becomes the rule's literal m 2^e_lr with a 4-bit signed mantissa |m| in 4..7 (the
   most precise of Lava's [-8, 7]; :func:`lr_literal`); post and pre become traces with
   one power-of-two scale per vector. The post traces Y_i = rint(post_i 2^-e_y), |Y_i| <=
   127, reach the synapses signed, as the post neurons' third factor (Lava's ``y1``,
   written by ``s_in_y1``). The pre trace is Lava's ``x1``, set by the pre neuron's graded
   spike to round(payload / 2) and unsigned (0..127). A pre vector without a negative
   entry travels as it is: X_j <= 127, payload 2 X_j, rule factor ``x1``. A pre vector
   with one (W_q's position o', W_k's state s) is carried offset: |X_j| <= 63,
   payload 2 (X_j + 64), and the rule's factor ``(x1 - 64)``, a constant Lava's rule
   syntax holds (``Factor.const``; the engine adds it before the product and clips the
   factor to [-128, 127]): one bit of the pre trace's resolution for its sign, and no
   neuron, synapse or spike more. A zero entry does not spike, so its synapses form no
   term (the rule's ``x0``). The host picks the offset per update from the sign of the
   vector, as it picks the scales (:func:`engine_traces`);
2. the traces as the rule reads them: Lava's engine evaluates a term with dependency x0
   on the traces at the pre spike's time in the epoch, one step after the spike (and the
   third factor's write): each trace decayed for one step with time constant 65535 (the
   longest a 16-bit constant holds; the one Lava's 3-factor rule gives ``y1``, and
   ``x1``'s here), ``_decay_trace``'s floor(v e^(-1/65535)) plus one where a uniform draw
   (one per epoch for the x traces, one for the y traces, each shared by the vector) is
   below the fraction: a trace v loses one unit (a negative one gains one) with
   probability about |v| / 65535 (:func:`decay_traces`; an offset pre trace decays as
   x1 = X + 64). Lava's ``y1`` variable keeps the undecayed value (its 3-factor model
   writes the history back to the x traces only);
3. each synapse's product term as ``LearningRuleApplierBitApprox.apply`` forms it:
   P = (m X_j Y_i) >> 3 (two 7-bit factors and the 4-bit mantissa are 18 bits, shifted
   by 18 - 15; an arithmetic shift: negative terms floor away from zero, as on the
   chip), then P << k with k = e_lr + e_x + e_y + S - E + 10 the rule's stored exponent
   (e + 7 in 0..15), clipped to [-32769, 32767], and added to the synapse's 16-bit
   learning accumulator with 7 fraction bits, clipped again (both clips counted,
   ``product_saturations`` / ``acc_saturations``). When k would be negative, the engine
   cannot shift the term that far: the traces are formed coarser instead, first by the
   low bits every trace of a vector has zero (lossless; a one-hot vector has 6), then a
   bit at a time from the factor with the larger trace (:func:`coarsen`). A term below 8
   then floors to 0 (positive) or -1 (negative): the engine's bias. With ``traces``
   ``stochastic`` the traces are rounded stochastically at the same final scales, the
   pre traces with their low 3 - t bits zero (t the trailing zero bits of m), so that
   the shift by 3 is exact and each term unbiased (:func:`engine_traces`);
4. the write-back at the end of a learning epoch (:func:`end_epoch`), as
   ``_apply_learning_rules``: the accumulator (which holds w << 7 plus the epoch's terms)
   is saturated by sign mode (excitatory >= 0, inhibitory <= 0), stochastically rounded to
   the weight: up when r 2^7 < its 7 fraction bits, r one uniform draw shared by every
   synapse of the array in the epoch (Lava's ``ConnVarRandom``; ``draws`` ``independent``:
   one draw per synapse, at counter base + i cols + j), then clipped by ``clip_weights``
   (mixed [-256, 255], counted ``weight_saturations``). The accumulator is then w << 7.

``terms`` ``exact`` (not the chip; for measuring what step 2 costs): each term is
lr post_i pre_j in accumulator units, computed in float64 and rounded stochastically
(one draw per term from the array's stream), then clipped and added as above.

An epoch ends at ``commit`` (the per-walk schedule: one epoch per walk) and, for updates
not deferred, every ``t_epoch`` updates (1: every step). Within an epoch, each update's
product terms are formed at the engine's precision and summed in the accumulator; Lava's
engine forms its terms once per epoch from traces, and no single term expresses the
CML's sum of a walk's outer products, so this is the emulation of an engine that keeps
its accumulator across the epoch.

Randomness: the array's counter-based stream (``uniform(rng[0], rng[1])``), advanced at
each update that forms terms by one per trace entry with a fraction (post, then pre) with
``traces`` ``stochastic``, then by two (the x and y traces' decay draws), and at each
write-back by one shared draw or by rows x cols with independent draws.

Counters (``Loihi2Array.counter_names``): ``macs`` / ``weight_reads`` the synaptic
operations of reads (nonzero payloads x fan-out); ``neuron_wraps``; ``update_macs``
the product terms formed; ``epochs``; ``weight_writes`` and ``cells_changed``;
``sign_clips`` (accumulators saturated by sign mode); ``rng_draws``; bits and bytes
moved (weights at 9 bits, the accumulator at 16).

The same arithmetic as plain loops, which the tests hold these kernels to:
:mod:`cml_edge.backends.loihi2.reference`.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from cml_edge.backends.quant import (
    NARROW,
    SIGMOID_IN_FRAC_BITS,
    SIGMOID_INDEX_BITS,
    SIGMOID_LUT,
    SIGMOID_OUT_BITS,
    SaturationError,
    count_nonzero,
    exponent_for,
    int_matvec,
    int_rmatvec,
    pow2,
    quantize_vector,
)
from cml_edge.errors import InputError
from cml_edge.jit.kernel import kernel
from cml_edge.jit.rng import uniform

# counter indices (names in Loihi2Array.counter_names)
MATVECS, RMATVECS, MACS, WEIGHT_READS, NEURON_WRAPS, OUTER_UPDATES = 0, 1, 2, 3, 4, 5
UPDATE_MACS, PRODUCT_SATURATIONS, ACC_SATURATIONS, COMMITS, EPOCHS = 6, 7, 8, 9, 10
WEIGHT_WRITES, CELLS_CHANGED, WEIGHT_SATURATIONS, SIGN_CLIPS, PROGRAM_CLIPS = 11, 12, 13, 14, 15
RNG_DRAWS, BITS_READ, BITS_WRITTEN, BYTES_READ, BYTES_WRITTEN = 16, 17, 18, 19, 20
N_COUNTERS = 21

# the chip's numbers, as Lava's constants and models state them
ACC_MAX = 32767  # learning accumulator: clip(., -(2^15) - 1, 2^15 - 1) (Lava's bounds)
ACC_MIN = -32769
FRAC_BITS = 7  # W_ACCUMULATOR_S - W_SYN_VAR_S = 16 - 9
TRACE_MAX = 127  # 7-bit traces
PRE_OFFSET = 64  # a signed pre trace X travels as x1 = X + 64, read by the factor (x1 - 64)
SIGNED_TRACE_MAX = PRE_OFFSET - 1  # |X| <= 63: x1 in 1..127
TRACE_TAU = 65535  # the traces' decay time constant: Lava's y1 (Loihi3FLearningRule), and x1
TRACE_DECAY = math.exp(-1.0 / TRACE_TAU)  # one step of it (np.exp gives the same double)
PRODUCT_SHIFT = 3  # 7 + 7 + 4 (W_S_MANT) - 15
MAX_TERM_SHIFT = 16  # a term shifted by >= 16 saturates the accumulator whatever it is
LR_MANT_BITS = 3  # |m| < 8: 4-bit signed mantissa
U_HALF = np.int64(1) << np.int64(23)  # the neuron's 24-bit u: (-2^23, 2^23]
I32_HALF = np.int64(1) << np.int64(31)  # NumPy int32 arithmetic: [-2^31, 2^31)
I32_MASK = (np.int64(1) << np.int64(32)) - np.int64(1)
ACT_SHIFT = 6  # PyLifModelBitAcc act_shift: a_in << 6
WEIGHT_BITS = 9  # W_WEIGHTS_S: a learned weight's storage bits
ACC_BITS = 16  # W_ACCUMULATOR_S
SHARED = 0  # index of "shared" in config.DRAWS
SAFE = 0  # index of "safe" in config.PAYLOAD_SCALES
EXACT = 1  # index of "exact" in config.TERMS
STOCHASTIC = 1  # index of "stochastic" in config.TRACES
MIXED, EXCITATORY, INHIBITORY = 0, 1, 2  # indices in lava.SIGN_MODES


# the neuron's 24-bit input ------------------------------------------------------------
@kernel
def int32(v):
    """v as NumPy's int32 arithmetic holds it: wrapped modulo 2^32 into [-2^31, 2^31)."""
    return ((v + I32_HALF) & I32_MASK) - I32_HALF


@kernel
def correct24(d):
    """(u, wrapped): the one 2^24 correction ``PyLifModelBitAcc`` applies to its current:
    d - 2^24 where d > 2^23, d + 2^24 where d <= -2^23 (so -2^23 becomes +2^23), else d;
    wrapped is 1 when u != d. One correction only: a d beyond 3 2^23 stays beyond 24 bits,
    as in Lava's model."""
    if d > U_HALF:
        return d - (U_HALF << np.int64(1)), 1
    if d <= -U_HALF:
        return d + (U_HALF << np.int64(1)), 1
    return d, 0


@kernel
def dense_output(total, exp):
    """Lava's ``Dense`` ``a_out`` for the exact dendritic sum ``total``: the dot product
    wraps to int32, then is shifted by the weight exponent (a floor right shift by -exp,
    or left by exp, in int32)."""
    t = int32(total)
    return t >> np.int64(-exp) if exp < 0 else int32(t << np.int64(exp))


@kernel
def neuron_input(total, exp):
    """(u, wrapped): the neuron's current u for the exact dendritic sum ``total``, as Lava's
    ``Dense`` and ``PyLifModelBitAcc`` compute it in int32: :func:`dense_output` goes << 6
    (int32) into the current, which gets the one correction of :func:`correct24`. wrapped
    is 1 when u differs from the exact (total >> -exp) << 6."""
    e = np.int64(-exp) if exp < 0 else np.int64(exp)
    exact = (total >> e if exp < 0 else total << e) << np.int64(ACT_SHIFT)
    u, _ = correct24(int32(dense_output(total, exp) << np.int64(ACT_SHIFT)))
    return u, 1 if u != exact else 0


# inputs as graded-spike payloads ---------------------------------------------------------
@kernel
def quantize_at(x, n, e, out):
    """out[:n] = rint(x 2^-e) (ties to even); returns the L1 norm of out[:n]."""
    l1 = np.int64(0)
    if -e > 1000:
        for i in range(n):
            out[i] = np.int64(np.rint(math.ldexp(x[i], -e)))
            l1 += abs(out[i])
        return l1
    scale = pow2(-e)
    for i in range(n):
        out[i] = np.int64(np.rint(x[i] * scale))
        l1 += abs(out[i])
    return l1


@kernel
def l1_exponent(x, n, l1_max):
    """exponent_for(sum |x[:n]|, l1_max), the sum taken in index order.

    That sum is a chain of n dependent additions, so eight running sums go
    first. Both sums are within (n + 8) 2^-53 of sum |x| relative to it (non-negative
    terms: n - 1 roundings in order; at most n / 8 + 10 in a running sum and the
    combination), so the index-order sum lies well within 4 (n + 8) 2^-53 of the
    eight-lane one t. exponent_for is monotone, so where it gives one exponent at both
    ends of that interval, that is the exponent of the index-order sum. Elsewhere (near
    a boundary, or not finite) the index-order sum is taken.
    """
    s0 = s1 = s2 = s3 = s4 = s5 = s6 = s7 = 0.0
    i = 0
    while i + 8 <= n:
        s0 += abs(x[i])
        s1 += abs(x[i + 1])
        s2 += abs(x[i + 2])
        s3 += abs(x[i + 3])
        s4 += abs(x[i + 4])
        s5 += abs(x[i + 5])
        s6 += abs(x[i + 6])
        s7 += abs(x[i + 7])
        i += 8
    while i < n:
        s0 += abs(x[i])
        i += 1
    t = ((s0 + s1) + (s2 + s3)) + ((s4 + s5) + (s6 + s7))
    d = 4.0 * (n + 8) * 1.1102230246251565e-16  # 4 (n + 8) 2^-53
    lo = t * (1.0 - d)
    hi = t * (1.0 + d)
    if lo > 0.0 and hi < math.inf:
        e = exponent_for(lo, l1_max)
        if exponent_for(hi, l1_max) == e:
            return e
    total = 0.0
    for i in range(n):
        total += abs(x[i])
    return exponent_for(total, l1_max)


@kernel
def encode(x, n, qmax, l1_max, safe, out):
    """Payloads out[:n] of x[:n] and their scale e (x ~ out 2^e).

    e is the finest power of two at which every |payload| <= qmax (nearest, ties to even;
    an all-zero vector gets e = 0) and, if ``safe``, the payloads' L1 norm is <= l1_max.
    """
    e = quantize_vector(x, n, qmax, out)
    if not safe:
        return e
    l1 = np.int64(0)
    for i in range(n):
        l1 += abs(out[i])
    if l1 <= l1_max:
        return e
    e1 = l1_exponent(x, n, l1_max)  # the finest e with sum |x| 2^-e <= l1_max
    if e1 > e:
        e = e1
    l1 = quantize_at(x, n, e, out)
    while l1 > l1_max:  # rounding up may pass the bound: one bit coarser
        e += 1
        l1 = quantize_at(x, n, e, out)
    return e


@kernel
def _emit(p, sums, n, e, out):
    """out[:n] = the neuron inputs of the dendritic sums, as floats; returns the wraps."""
    e_out = e - p.scale_exp - ACT_SHIFT
    wraps = 0
    big = not (-1000 < e_out < 1000)
    scale = pow2(e_out) if not big else 0.0
    for i in range(n):
        u, w = neuron_input(sums[i], p.exp)
        wraps += w
        out[i] = float(u) * scale if not big else math.ldexp(float(u), e_out)
    return wraps


@njit(cache=True, inline="always")
def loihi2_matvec(state, x, out):
    _read(state.w, state.params, state.xq, state.sums, state.counters, x, out, False)


@njit(cache=True, inline="always")
def loihi2_rmatvec(state, y, out):
    _read(state.w, state.params, state.xq, state.sums, state.counters, y, out, True)


@kernel
def _read(w, p, s, sums, c, x, out, transposed):
    """out = W x (W^T x if ``transposed``): graded spikes, the exact dendritic sums, the
    neuron inputs; on the state's arrays one by one (see
    :func:`cml_edge.backends.fixed.kernels.fixed_matvec`)."""
    rows, cols = w.shape
    n_in, fanout = (rows, cols) if transposed else (cols, rows)
    e = encode(x, n_in, p.msg_qmax, p.l1_max, p.payload_scale == SAFE, s)
    nnz = int_rmatvec(w, s, sums) if transposed else int_matvec(w, s, sums)
    wraps = _emit(p, sums, fanout, e, out)
    done = nnz * fanout
    c[RMATVECS if transposed else MATVECS] += 1
    c[MACS] += done
    c[WEIGHT_READS] += done
    c[NEURON_WRAPS] += wraps
    c[BITS_READ] += done * WEIGHT_BITS
    c[BYTES_READ] = (c[BITS_READ] + 7) >> 3
    if wraps and p.strict:
        raise SaturationError("loihi2: a read overflowed the neuron's 24-bit input "
                              "(strict mode)")


# the learning engine ----------------------------------------------------------------------
@kernel
def lr_literal(lr):
    """lr as the rule literal (m, e): lr ~ m 2^e with |m| in 4..7 (nearest, ties to even;
    a 4-bit signed mantissa), m carrying lr's sign; (0, 0) for lr = 0."""
    if not abs(lr) <= 1.7976931348623157e308:
        raise InputError("non-finite learning rate")
    if lr == 0.0:
        return np.int64(0), 0
    f, ex = math.frexp(abs(lr))  # f in [0.5, 1)
    m = np.rint(math.ldexp(f, LR_MANT_BITS))  # 4..8
    e = ex - LR_MANT_BITS
    if m >= float(1 << LR_MANT_BITS):
        m = m / 2.0
        e += 1
    mi = np.int64(m)
    return (mi if lr > 0 else -mi), e


@kernel
def engine_term(m, x, y, k):
    """(term, saturated): one product term as ``LearningRuleApplierBitApprox`` forms it
    for the rule ``m 2^(k - 7) x1 y1`` (k the stored exponent e + 7; x the factor, x1 - 64
    for an offset pre trace): (m x y) >> 3, << k
    (k >= 16 saturates whatever the product), clipped to [-32769, 32767]."""
    v = (m * x * y) >> np.int64(PRODUCT_SHIFT)
    if v == 0:
        return np.int64(0), 0
    if k >= MAX_TERM_SHIFT:
        return (np.int64(ACC_MAX), 1) if v > 0 else (np.int64(ACC_MIN), 1)
    v = v << np.int64(k)
    if v > ACC_MAX:
        return np.int64(ACC_MAX), 1
    if v < ACC_MIN:
        return np.int64(ACC_MIN), 1
    return v, 0


@kernel
def accumulate(a, term):
    """(a + term clipped to [-32769, 32767], saturated): Lava's clip of the result."""
    r = a + term
    if r > ACC_MAX:
        return np.int64(ACC_MAX), 1
    if r < ACC_MIN:
        return np.int64(ACC_MIN), 1
    return r, 0


@kernel
def write_back(a, r, sign, w_min, w_max):
    """(w, sign_clipped, saturated): the accumulator a (7 fraction bits) written back
    to a weight as ``_apply_learning_rules`` does: saturated by sign mode (excitatory
    max(0, a), inhibitory min(0, a)), stochastically rounded with the uniform r (up when
    r 2^7 < a's fraction bits: Lava's r < frac), clipped to [w_min, w_max]."""
    clipped = 0
    if (sign == EXCITATORY and a < 0) or (sign == INHIBITORY and a > 0):
        a = np.int64(0)
        clipped = 1
    q = a >> np.int64(FRAC_BITS)
    f = a & np.int64((1 << FRAC_BITS) - 1)
    if f != 0 and r * float(1 << FRAC_BITS) < float(f):
        q += 1
    if q > w_max:
        return np.int64(w_max), clipped, 1
    if q < w_min:
        return np.int64(w_min), clipped, 1
    return q, clipped, 0


@kernel
def _trailing_zeros(v, n):
    """The number of low zero bits every nonzero v[:n] has (62 if all are zero): those of
    the OR of them all (v and -v have the same; one pass that vectorises)."""
    bits = np.int64(0)
    for i in range(n):
        bits |= v[i]
    if bits == 0:
        return 62
    tz = 0
    while (bits & 1) == 0:
        bits >>= 1
        tz += 1
    return tz


@kernel
def _max_abs(v, n):
    top = np.int64(0)
    for i in range(n):
        a = abs(v[i])
        if a > top:
            top = a
    return top


@kernel
def coarsen(deficit, X, nx, Y, ny):
    """(cx, cy): how many bits coarser the pre (X) and post (Y) traces are formed so
    that the rule's exponent rises by ``deficit``: first the low bits all of a vector's
    traces have zero (pre first; lossless), then one bit at a time from the factor
    whose largest trace is larger (post on a tie)."""
    tzx = _trailing_zeros(X, nx)
    tzy = _trailing_zeros(Y, ny)
    cx = min(deficit, tzx)
    deficit -= cx
    cy = min(deficit, tzy)
    deficit -= cy
    mx = _max_abs(X, nx) >> np.int64(cx)
    my = _max_abs(Y, ny) >> np.int64(cy)
    while deficit > 0 and (mx > 0 or my > 0):
        if my >= mx:
            cy += 1
            my >>= 1
        else:
            cx += 1
            mx >>= 1
        deficit -= 1
    if deficit > 0:  # both traces are gone: nothing to learn
        cx += deficit
    return cx, cy


@kernel
def end_epoch(state):
    """The write-back of a learning epoch (module docstring, step 4); the accumulator
    then holds w << 7 again."""
    w = state.w
    acc = state.acc
    p = state.params
    rows, cols = w.shape
    key = state.rng[0]
    ctr = np.int64(state.rng[1])
    shared = p.draws == SHARED
    r = 0.0
    if shared:
        r = uniform(key, ctr)
        draws = 1
    else:
        draws = rows * cols
    changed = 0
    sats = 0
    signs = 0
    for i in range(rows):
        for j in range(cols):
            a = np.int64(acc[i, j])
            if not shared and (a & np.int64((1 << FRAC_BITS) - 1)) != 0:
                r = uniform(key, ctr + i * cols + j)
            q, sc, sat = write_back(a, r, p.sign_mode, p.w_min, p.w_max)
            signs += sc
            sats += sat
            if q != w[i, j]:
                changed += 1
                w[i, j] = q
            acc[i, j] = q << np.int64(FRAC_BITS)
    state.rng[1] = np.uint64(ctr + draws)
    state.epoch[0] = 0
    c = state.counters
    n = rows * cols
    c[EPOCHS] += 1
    c[RNG_DRAWS] += draws
    c[WEIGHT_WRITES] += changed
    c[CELLS_CHANGED] += changed
    c[WEIGHT_SATURATIONS] += sats
    c[SIGN_CLIPS] += signs
    c[BITS_READ] += n * ACC_BITS
    c[BITS_WRITTEN] += changed * WEIGHT_BITS + n * ACC_BITS
    c[BYTES_READ] = (c[BITS_READ] + 7) >> 3
    c[BYTES_WRITTEN] = (c[BITS_WRITTEN] + 7) >> 3
    if (sats or signs) and p.strict:
        raise SaturationError("loihi2: a weight was clipped at write-back (strict mode)")


@njit(cache=True, inline="always")
def _term_line(line, mf, factors, k, clip):
    """line[b] += the engine's term of (mf factors[b]) (:func:`engine_term`,
    :func:`accumulate`) where factors[b] != 0, the other cells kept: written without
    branches so that it vectorises. A zero term keeps the cell with no select,
    as no cell is ever beyond the accumulator's range (validated on load, clipped at every
    write; 0.58 -> 0.44 ns per cell in a throwaway loop). ``clip``: whether a term may
    leave the accumulator's range (:func:`_terms_may_clip`); when none can, LLVM's copy
    of the loop for that case has no clip of the term (0.44 -> 0.37 ns per cell). Returns
    (product saturations, accumulator saturations); the caller counts the terms (the
    nonzero factors) once."""
    psat = 0
    asat = 0
    big = k >= MAX_TERM_SHIFT
    kk = np.int64(0) if big else np.int64(k)
    for b in range(line.shape[0]):
        v = (mf * factors[b]) >> np.int64(PRODUCT_SHIFT)
        if big:
            t = np.int64(ACC_MAX) if v > 0 else (np.int64(ACC_MIN) if v < 0 else np.int64(0))
            ps = v != 0
        else:
            u = v << kk
            t = min(max(u, np.int64(ACC_MIN)), np.int64(ACC_MAX)) if clip else u
            ps = t != u
        r = np.int64(line[b]) + t
        a = min(max(r, np.int64(ACC_MIN)), np.int64(ACC_MAX))
        line[b] = a
        psat += ps
        asat += a != r
    return psat, asat


@njit(cache=True, inline="always")
def _terms_may_clip(mf, top, k):
    """Whether a term of (mf f) with |f| <= top, ((mf f) >> PRODUCT_SHIFT) << k, may leave
    the accumulator's range: |floor(p / 2^s)| <= floor(|p| / 2^s) + 1."""
    if k >= MAX_TERM_SHIFT:
        return True
    return ((((abs(mf) * top) >> np.int64(PRODUCT_SHIFT)) + 1) << np.int64(k)) > ACC_MAX


@kernel
def _add_terms(acc, m, X, cols, Y, rows, k, tally):
    """acc += the product terms of the nonzero traces; tally[:3] = terms formed (the
    nonzero X times the nonzero Y), product saturations, accumulator saturations. Narrow
    matrices (a one-hot pre) are walked column by column."""
    terms = count_nonzero(X, cols) * count_nonzero(Y, rows)
    psat = 0
    asat = 0
    if cols <= NARROW:
        top = _max_abs(Y, rows)
        for j in range(cols):
            if X[j] != 0:
                mf = m * X[j]
                s1, s2 = _term_line(acc[:, j], mf, Y, k, _terms_may_clip(mf, top, k))
                psat += s1
                asat += s2
    else:
        top = _max_abs(X, cols)
        for i in range(rows):
            if Y[i] != 0:
                mf = m * Y[i]
                s1, s2 = _term_line(acc[i], mf, X, k, _terms_may_clip(mf, top, k))
                psat += s1
                asat += s2
    tally[0] = terms
    tally[1] = psat
    tally[2] = asat


@kernel
def _add_exact(state, post, pre, lr, tally):
    """The ``exact`` terms (not the chip): lr post_i pre_j in accumulator units, floor plus
    one uniform draw per term (up with probability the fraction), clipped and added as
    the engine's; tally[:3] as :func:`_add_terms`, tally[3] the draws."""
    p = state.params
    acc = state.acc
    rows, cols = acc.shape
    scale = lr * math.ldexp(1.0, p.scale_exp - p.exp + FRAC_BITS)
    key = state.rng[0]
    ctr = np.int64(state.rng[1])
    ctr0 = ctr
    terms = 0
    psat = 0
    asat = 0
    for i in range(rows):
        if post[i] == 0.0:
            continue
        for j in range(cols):
            if pre[j] == 0.0:
                continue
            terms += 1
            v = scale * post[i] * pre[j]
            if not abs(v) < 1e18:
                t = np.int64(ACC_MAX) if v > 0 else np.int64(ACC_MIN)
                psat += 1
            else:
                f = math.floor(v)
                t = np.int64(f)
                if v != f:
                    if uniform(key, ctr) < v - f:
                        t += 1
                    ctr += 1
                if t > ACC_MAX:
                    t = np.int64(ACC_MAX)
                    psat += 1
                elif t < ACC_MIN:
                    t = np.int64(ACC_MIN)
                    psat += 1
            if t != 0:
                a, s2 = accumulate(np.int64(acc[i, j]), t)
                asat += s2
                acc[i, j] = a
    state.rng[1] = np.uint64(ctr)
    tally[0] = terms
    tally[1] = psat
    tally[2] = asat
    return ctr - ctr0


@kernel
def exact_shift_bits(m):
    """z: the low bits a pre trace keeps zero so that 2^3 divides m X Y and the engine's
    ``>> 3`` drops nothing: 3 minus the trailing zero bits of m (m = 4: 1; m odd: 3)."""
    a = abs(m)
    t = 0
    while t < PRODUCT_SHIFT and a != 0 and (a & 1) == 0:
        a >>= 1
        t += 1
    return PRODUCT_SHIFT - t


@kernel
def stochastic_at(x, n, e, key, ctr, out):
    """out[:n] = x 2^-e rounded stochastically: the floor, plus one where the draw
    ``uniform(key, c)`` is below the fraction, c counting from ``ctr`` over the entries
    with a fraction, in index order (an entry without one draws nothing). Returns the
    draws."""
    used = 0
    near = -1000 <= e <= 1000
    scale = pow2(-e) if near else 0.0
    for i in range(n):
        v = x[i] * scale if near else math.ldexp(x[i], -e)
        f = math.floor(v)
        q = np.int64(f)
        if v != f:
            if uniform(key, ctr + used) < v - f:
                q += 1
            used += 1
        out[i] = q
    return used


@kernel
def _has_negative(v, n):
    i = 0
    while i < n and v[i] >= 0:
        i += 1
    return i < n


@kernel
def engine_traces(post, pre, rows, cols, lr, gain_exp, stochastic, rng, X, Y):
    """(m, k, c, draws): the rule literal's mantissa m, the term's shift k and the pre
    traces' offset c (0, or :data:`PRE_OFFSET` for a pre vector with a negative entry) of
    the update lr post pre^T (module docstring, step 1), with the traces, as the neurons
    send them, in Y[:rows] (post) and X[:cols] (pre); ``gain_exp`` is scale_exp -
    weight_exp. Where k would be negative, the traces are formed coarser (:func:`coarsen`)
    and k is 0. The rule this is in Lava's syntax: ``m * 2^(k - 7) * x0 * x1 * y1``, or
    with ``(x1 - 64)`` for x1 where c is 64.

    With ``stochastic`` (``traces`` ``stochastic``, for m != 0) the pre traces keep
    :func:`exact_shift_bits` low bits zero (their scale holds max |pre| in qmax >> z,
    qmax 127 or 63), the coarsening is chosen on the nearest traces as above, and then
    both vectors are rounded stochastically at their final scales (:func:`stochastic_at`,
    post first, then pre) from the stream ``rng`` (key, next counter; advanced by the
    draws, which are returned; 0 otherwise)."""
    m, e_lr = lr_literal(lr)
    sr = stochastic and m != 0
    z = exact_shift_bits(m) if sr else 0
    c = PRE_OFFSET if _has_negative(pre, cols) else 0
    e_y = quantize_vector(post, rows, TRACE_MAX, Y)
    e_x = quantize_vector(pre, cols, (SIGNED_TRACE_MAX if c else TRACE_MAX) >> z, X)
    k = e_lr + e_x - z + e_y + gain_exp + PRODUCT_SHIFT + FRAC_BITS
    cx = 0
    cy = 0
    if m != 0 and k < 0:
        cx, cy = coarsen(-k, X, cols, Y, rows)
        k = 0
    if sr:
        key = rng[0]
        ctr = np.int64(rng[1])
        draws = stochastic_at(post, rows, e_y + cy, key, ctr, Y)
        draws += stochastic_at(pre, cols, e_x + cx, key, ctr + draws, X)
        for j in range(cols):
            X[j] <<= np.int64(z)
        rng[1] = np.uint64(ctr + draws)
        return m, k, c, draws
    if cx > 0:
        quantize_at(pre, cols, e_x + cx, X)
    if cy > 0:
        quantize_at(post, rows, e_y + cy, Y)
    return m, k, c, 0


@kernel
def decayed(v, d, r):
    """One step of Lava's trace decay (``_decay_trace``): floor(d v), plus one where the
    uniform r is below its fraction."""
    s = d * float(v)
    f = math.floor(s)
    q = np.int64(f)
    if r < s - f:
        q += 1
    return q


@kernel
def decay_traces(X, cols, c, Y, rows, d, r_x, r_y):
    """The traces as the rule reads them (module docstring, step 2), in place: each spiking
    pre trace (X != 0) decayed as x1 = X + c with the draw r_x, each post trace with r_y,
    by the factor d (:data:`TRACE_DECAY`)."""
    for j in range(cols):
        if X[j] != 0:
            X[j] = decayed(X[j] + c, d, r_x) - c
    for i in range(rows):
        Y[i] = decayed(Y[i], d, r_y)


@kernel
def loihi2_outer_update(state, post, pre, lr, defer):
    w = state.w
    p = state.params
    rows, cols = w.shape
    c = state.counters
    c[OUTER_UPDATES] += 1
    Y = state.yq
    X = state.xq
    m, k, offset, draws = engine_traces(post, pre, rows, cols, lr, p.scale_exp - p.exp,
                                        p.traces == STOCHASTIC and p.terms != EXACT,
                                        state.rng, X, Y)
    c[RNG_DRAWS] += draws
    tally = state.tally
    tally[0] = 0
    tally[1] = 0
    tally[2] = 0
    if p.terms == EXACT:
        if lr != 0.0:
            c[RNG_DRAWS] += _add_exact(state, post, pre, lr, tally)
        m = 0
    if m != 0:
        ctr = np.int64(state.rng[1])
        decay_traces(X, cols, offset, Y, rows, TRACE_DECAY, uniform(state.rng[0], ctr),
                     uniform(state.rng[0], ctr + 1))
        state.rng[1] = np.uint64(ctr + 2)
        c[RNG_DRAWS] += 2
        _add_terms(state.acc, m, X, cols, Y, rows, k, tally)
    # tally[:3]: terms formed, product saturations, accumulator saturations
    terms = tally[0]
    c[UPDATE_MACS] += terms
    c[PRODUCT_SATURATIONS] += tally[1]
    c[ACC_SATURATIONS] += tally[2]
    c[BITS_READ] += terms * ACC_BITS
    c[BITS_WRITTEN] += terms * ACC_BITS
    c[BYTES_READ] = (c[BITS_READ] + 7) >> 3
    c[BYTES_WRITTEN] = (c[BITS_WRITTEN] + 7) >> 3
    if (tally[1] or tally[2]) and p.strict:
        raise SaturationError("loihi2: the learning accumulator saturated (strict mode)")
    if not defer:
        state.epoch[0] += 1
        if state.epoch[0] >= p.t_epoch:
            end_epoch(state)


@kernel
def loihi2_commit(state):
    state.counters[COMMITS] += 1
    end_epoch(state)


# the affordance nonlinearity ------------------------------------------------------------
LUT_HALF = 1 << (SIGMOID_INDEX_BITS - 1)


@njit(cache=True, inline="always")
def loihi2_sigmoid(state, z, out):
    """sigmoid(z) as a programmable neuron with a 256-entry table holds it: the index is
    z in steps of 1/16 (nearest, ties up), clipped to [-8, 8 - 1/16] (the neuron shifts
    its 24-bit u by the read's scale to form it), the entry a 16-bit unsigned fraction
    (``quant.SIGMOID_LUT``: 512 bytes of neuron memory), sent as an unsigned payload of
    min(num_message_bits, 16) bits (its low bits dropped)."""
    bits = min(state.params.num_message_bits, SIGMOID_OUT_BITS)
    drop = SIGMOID_OUT_BITS - bits
    unit = math.ldexp(1.0, -bits)
    for i in range(z.shape[0]):
        v = z[i]
        if v != v:
            raise InputError("non-finite input to the sigmoid lookup table")
        t = math.floor(v * (1 << SIGMOID_IN_FRAC_BITS) + 0.5)
        if t < -LUT_HALF:
            t = -LUT_HALF
        elif t > LUT_HALF - 1:
            t = LUT_HALF - 1
        out[i] = float(SIGMOID_LUT[int(t) + LUT_HALF] >> drop) * unit
