"""The ``loihi2`` array's arithmetic as plain loops: the readable model its kernels are held
to.

Not dead code: Loihi 2's dendrite and learning engine as :mod:`cml_edge.backends.loihi2.kernels`
documents them step by step (graded spikes into 24-bit neurons; product terms of 7-bit
traces into a 16-bit accumulator; the stochastic write-back of an epoch), in Python
integers and without the kernels' speed (eight running sums before an index-order L1
norm, branch-free term lines, a skipped clip where no term can leave the range);
``tests/backends/test_references.py`` runs each kernel and its function here on copies
of the same state and requires the same bits, states, counters and errors. Integer sums
are exact in any order; the write-back's draws are one shared uniform per epoch, or one
per synapse at counter base + i cols + j; stochastic traces take one draw per entry with
a fraction, post then pre, before the update's terms, and the traces' decay two (pre,
post) after them.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from cml_edge.backends.fixed.reference import exponent_for, quantise
from cml_edge.backends.loihi2.kernels import (
    ACC_BITS,
    ACC_MAX,
    ACC_MIN,
    ACC_SATURATIONS,
    ACT_SHIFT,
    BITS_READ,
    BITS_WRITTEN,
    BYTES_READ,
    BYTES_WRITTEN,
    CELLS_CHANGED,
    COMMITS,
    EPOCHS,
    EXACT,
    EXCITATORY,
    FRAC_BITS,
    INHIBITORY,
    LR_MANT_BITS,
    MACS,
    MATVECS,
    MAX_TERM_SHIFT,
    NEURON_WRAPS,
    OUTER_UPDATES,
    PRE_OFFSET,
    PRODUCT_SATURATIONS,
    PRODUCT_SHIFT,
    RMATVECS,
    RNG_DRAWS,
    SAFE,
    SHARED,
    SIGN_CLIPS,
    SIGNED_TRACE_MAX,
    STOCHASTIC,
    TRACE_DECAY,
    TRACE_MAX,
    UPDATE_MACS,
    WEIGHT_BITS,
    WEIGHT_READS,
    WEIGHT_SATURATIONS,
    WEIGHT_WRITES,
)
from cml_edge.backends.quant import (
    SIGMOID_OUT_BITS,
    SaturationError,
    sigmoid_entry,
)
from cml_edge.errors import InputError
from cml_edge.jit.rng import uniform

SCRATCH = ("xq", "yq", "sums", "tally")
"""The state's work space, which this model needs none of."""
State = Any  # a Loihi2State

U_HALF = 1 << 23  # the neuron's 24-bit u: (-2^23, 2^23]


def _bytes(c: np.ndarray) -> None:
    c[BYTES_READ] = (c[BITS_READ] + 7) >> 3
    c[BYTES_WRITTEN] = (c[BITS_WRITTEN] + 7) >> 3


# the read: graded spikes, dendritic sums, 24-bit neurons --------------------------------
def payloads_at(x: np.ndarray, e: int) -> list[int]:
    """rint(x 2^-e), ties to even."""
    return [int(np.rint(math.ldexp(v, -e))) for v in x]


def encode(state: State, x: np.ndarray) -> tuple[int, list[int]]:
    """(e, s): payloads s ~ x 2^-e at the finest e where every |s| <= 2^(bits - 1) - 1
    and, with ``payload_scale`` safe, sum |s| <= l1_max (then from the index-order sum
    sum |x|, and one bit coarser while rounding up passes the bound)."""
    p = state.params
    e, s = quantise(x, p.msg_qmax)
    if p.payload_scale != SAFE or sum(abs(v) for v in s) <= p.l1_max:
        return e, s
    total = 0.0
    for v in x:
        total += abs(v)
    e = max(e, exponent_for(total, p.l1_max))
    s = payloads_at(x, e)
    while sum(abs(v) for v in s) > p.l1_max:
        e += 1
        s = payloads_at(x, e)
    return e, s


def _int32(v: int) -> int:
    return ((v + (1 << 31)) % (1 << 32)) - (1 << 31)


def neuron_input(total: int, exp: int) -> tuple[int, int]:
    """(u, wrapped): as Lava's ``Dense`` and ``PyLifModelBitAcc`` compute the current in
    int32: the sum wraps to int32, shifts by the weight exponent (floor), << 6, then one
    2^24 correction past +-2^23; wrapped when u differs from the exact shifted sum << 6."""
    exact = (total >> -exp if exp < 0 else total << exp) << ACT_SHIFT
    t = _int32(total)
    a = t >> -exp if exp < 0 else _int32(t << exp)
    d = _int32(a << ACT_SHIFT)
    if d > U_HALF:
        d -= 2 * U_HALF
    elif d <= -U_HALF:
        d += 2 * U_HALF
    return d, int(d != exact)


def read(state: State, x: np.ndarray, transposed: bool) -> np.ndarray:
    """W x (W^T x): payloads, the exact dendritic sums over the nonzero payloads, the
    neurons' inputs u, output u 2^(e - S - 6)."""
    p = state.params
    w = state.w.T if transposed else state.w
    n_out, n_in = w.shape
    e, s = encode(state, x)
    out = np.zeros(n_out)
    wraps = 0
    for i in range(n_out):
        u, wrapped = neuron_input(sum(int(w[i, j]) * s[j] for j in range(n_in)), p.exp)
        wraps += wrapped
        out[i] = math.ldexp(float(u), e - p.scale_exp - ACT_SHIFT)
    done = sum(v != 0 for v in s) * n_out
    c = state.counters
    c[RMATVECS if transposed else MATVECS] += 1
    c[MACS] += done
    c[WEIGHT_READS] += done
    c[NEURON_WRAPS] += wraps
    c[BITS_READ] += done * WEIGHT_BITS
    c[BYTES_READ] = (c[BITS_READ] + 7) >> 3
    if wraps and p.strict:
        raise SaturationError("loihi2: a read overflowed the neuron's 24-bit input")
    return out


def matvec(state: State, x: np.ndarray) -> np.ndarray:
    return read(state, x, False)


def rmatvec(state: State, y: np.ndarray) -> np.ndarray:
    return read(state, y, True)


# the learning engine -------------------------------------------------------------------------
def lr_literal(lr: float) -> tuple[int, int]:
    """lr ~ m 2^e with |m| in 4..7 (a 4-bit signed mantissa; nearest, ties to even)."""
    if not math.isfinite(lr):
        raise InputError("non-finite learning rate")
    if lr == 0.0:
        return 0, 0
    f, ex = math.frexp(abs(lr))
    m, e = float(np.rint(math.ldexp(f, LR_MANT_BITS))), ex - LR_MANT_BITS
    if m >= 2 ** LR_MANT_BITS:
        m, e = m / 2.0, e + 1
    return int(m) if lr > 0 else -int(m), e


def clip_acc(v: int) -> tuple[int, int]:
    """(v clipped to the accumulator's [-32769, 32767], 1 if it was clipped)."""
    w = min(max(v, ACC_MIN), ACC_MAX)
    return w, int(w != v)


def engine_term(m: int, x: int, y: int, k: int) -> tuple[int, int]:
    """(term, saturated): ((m x y) >> 3) << k clipped to the accumulator's range (k >= 16
    saturates any nonzero product)."""
    v = (m * x * y) >> PRODUCT_SHIFT
    if v == 0:
        return 0, 0
    if k >= MAX_TERM_SHIFT:
        return (ACC_MAX, 1) if v > 0 else (ACC_MIN, 1)
    return clip_acc(v << k)


def exact_shift_bits(m: int) -> int:
    """The low bits a pre trace keeps zero so that 8 divides m X Y: 3 minus the trailing
    zero bits of m, at most 3 of them."""
    a = abs(m)
    return PRODUCT_SHIFT - min(PRODUCT_SHIFT, (a & -a).bit_length() - 1)


def stochastic_traces(state: State, x: np.ndarray, e: int) -> list[int]:
    """x 2^-e rounded stochastically: floor, plus one where the next draw of the array's
    stream is below the fraction (one draw per entry with a fraction, in index order)."""
    key, ctr = state.rng[0], int(state.rng[1])
    out = []
    for v in x:
        s = math.ldexp(float(v), -e)
        q = math.floor(s)
        if s != q:
            q += uniform(key, ctr) < s - q
            ctr += 1
        out.append(int(q))
    state.counters[RNG_DRAWS] += ctr - int(state.rng[1])
    state.rng[1] = np.uint64(ctr)
    return out


def decayed(v: int, r: float) -> int:
    """Lava's one-step trace decay: floor(v e^(-1/65535)), plus one where r is below the
    fraction."""
    s = TRACE_DECAY * v
    return math.floor(s) + (r < s - math.floor(s))


def decay(state: State, X: list[int], offset: int, Y: list[int]) -> tuple[list, list]:
    """The traces the rule reads: each spiking pre trace decayed as x1 = X + offset with
    the stream's next draw, each post trace with the one after."""
    key, ctr = state.rng[0], int(state.rng[1])
    r_x, r_y = uniform(key, ctr), uniform(key, ctr + 1)
    state.rng[1] = np.uint64(ctr + 2)
    state.counters[RNG_DRAWS] += 2
    return ([decayed(v + offset, r_x) - offset if v else 0 for v in X],
            [decayed(v, r_y) for v in Y])


def coarsen(deficit: int, X: list[int], Y: list[int]) -> tuple[int, int]:
    """(cx, cy): bits by which the pre (X) and post (Y) traces are formed coarser so that
    the rule's exponent rises by ``deficit``: first the low bits every trace of a vector
    has zero (pre first), then one bit at a time from the factor with the larger trace
    (post on a tie)."""

    def common_zeros(v: list[int]) -> int:
        bits = 0
        for a in v:
            bits |= a
        return 62 if bits == 0 else (bits & -bits).bit_length() - 1

    cx = min(deficit, common_zeros(X))
    deficit -= cx
    cy = min(deficit, common_zeros(Y))
    deficit -= cy
    mx = max(abs(v) for v in X) >> cx
    my = max(abs(v) for v in Y) >> cy
    while deficit > 0 and (mx > 0 or my > 0):
        if my >= mx:
            cy, my = cy + 1, my >> 1
        else:
            cx, mx = cx + 1, mx >> 1
        deficit -= 1
    return cx + deficit, cy  # what is left when both are gone: nothing to learn


def outer_update(state: State, post: np.ndarray, pre: np.ndarray, lr: float,
                 defer: bool) -> None:
    """One update's product terms into the accumulator (the engine's, or ``exact``); an
    in-place update ends the epoch every ``t_epoch`` updates."""
    p = state.params
    c = state.counters
    c[OUTER_UPDATES] += 1
    m, e_lr = lr_literal(lr)
    stochastic = p.traces == STOCHASTIC and p.terms != EXACT and m != 0
    z = exact_shift_bits(m) if stochastic else 0
    offset = PRE_OFFSET if (np.asarray(pre) < 0).any() else 0  # x1 = X + 64: (x1 - 64)
    e_y, Y = quantise(post, TRACE_MAX)
    e_x, X = quantise(pre, (SIGNED_TRACE_MAX if offset else TRACE_MAX) >> z)
    k = e_lr + e_x - z + e_y + p.scale_exp - p.exp + PRODUCT_SHIFT + FRAC_BITS
    terms = psat = asat = 0
    acc = state.acc
    if p.terms == EXACT:
        if lr != 0.0:
            terms, psat, asat = exact_terms(state, post, pre, lr)
        m = 0
    else:
        cx = cy = 0
        if m != 0 and k < 0:  # the engine cannot shift that far: coarser traces
            cx, cy = coarsen(-k, X, Y)
            k = 0
        if stochastic:
            Y = stochastic_traces(state, post, e_y + cy)
            X = [v << z for v in stochastic_traces(state, pre, e_x + cx)]
        else:
            X = payloads_at(pre, e_x + cx) if cx > 0 else X
            Y = payloads_at(post, e_y + cy) if cy > 0 else Y
    if m != 0:
        X, Y = decay(state, X, offset, Y)
        terms = sum(v != 0 for v in X) * sum(v != 0 for v in Y)
        for i in range(len(Y)):
            for j in range(len(X)):
                if X[j] != 0 and Y[i] != 0:
                    t, ps = engine_term(m, X[j], Y[i], k)
                    acc[i, j], s2 = clip_acc(int(acc[i, j]) + t)
                    psat += ps
                    asat += s2
    c[UPDATE_MACS] += terms
    c[PRODUCT_SATURATIONS] += psat
    c[ACC_SATURATIONS] += asat
    c[BITS_READ] += terms * ACC_BITS
    c[BITS_WRITTEN] += terms * ACC_BITS
    _bytes(c)
    if (psat or asat) and p.strict:
        raise SaturationError("loihi2: the learning accumulator saturated (strict mode)")
    if not defer:
        state.epoch[0] += 1
        if state.epoch[0] >= p.t_epoch:
            end_epoch(state)


def exact_terms(state: State, post: np.ndarray, pre: np.ndarray,
                lr: float) -> tuple[int, int, int]:
    """``terms`` exact (not the chip): each lr post_i pre_j in accumulator units, floor
    plus one uniform draw (up with probability the fraction), clipped, added; returns
    (terms, product saturations, accumulator saturations)."""
    p = state.params
    scale = lr * math.ldexp(1.0, p.scale_exp - p.exp + FRAC_BITS)
    key, ctr = state.rng[0], int(state.rng[1])
    terms = psat = asat = 0
    for i in range(len(post)):
        for j in range(len(pre)):
            if post[i] == 0.0 or pre[j] == 0.0:
                continue
            terms += 1
            v = scale * post[i] * pre[j]
            if not abs(v) < 1e18:
                t = ACC_MAX if v > 0 else ACC_MIN
                psat += 1
            else:
                t = math.floor(v)
                if v != t:
                    t += uniform(key, ctr) < v - t
                    ctr += 1
                t, ps = clip_acc(t)
                psat += ps
            if t != 0:
                state.acc[i, j], s2 = clip_acc(int(state.acc[i, j]) + t)
                asat += s2
    state.counters[RNG_DRAWS] += ctr - int(state.rng[1])
    state.rng[1] = np.uint64(ctr)
    return terms, psat, asat


def end_epoch(state: State) -> None:
    """The write-back: each accumulator (7 fraction bits) saturated by sign mode,
    stochastically rounded (up when r 2^7 < its fraction bits), clipped to [w_min,
    w_max]; the accumulator then holds w << 7."""
    p = state.params
    w, acc = state.w, state.acc
    rows, cols = w.shape
    key, ctr = state.rng[0], int(state.rng[1])
    shared = p.draws == SHARED
    r = uniform(key, ctr) if shared else 0.0
    changed = sats = signs = 0
    for i in range(rows):
        for j in range(cols):
            a = int(acc[i, j])
            if (p.sign_mode == EXCITATORY and a < 0) or (p.sign_mode == INHIBITORY and a > 0):
                a = 0
                signs += 1
            q, f = a >> FRAC_BITS, a & ((1 << FRAC_BITS) - 1)
            if f != 0:
                u = r if shared else uniform(key, ctr + i * cols + j)
                q += u * float(1 << FRAC_BITS) < float(f)
            q_clipped = min(max(q, p.w_min), p.w_max)
            sats += q_clipped != q
            if q_clipped != w[i, j]:
                changed += 1
                w[i, j] = q_clipped
            acc[i, j] = q_clipped << FRAC_BITS
    draws = 1 if shared else rows * cols
    state.rng[1] = np.uint64(ctr + draws)
    state.epoch[0] = 0
    c = state.counters
    c[EPOCHS] += 1
    c[RNG_DRAWS] += draws
    c[WEIGHT_WRITES] += changed
    c[CELLS_CHANGED] += changed
    c[WEIGHT_SATURATIONS] += sats
    c[SIGN_CLIPS] += signs
    c[BITS_READ] += rows * cols * ACC_BITS
    c[BITS_WRITTEN] += changed * WEIGHT_BITS + rows * cols * ACC_BITS
    _bytes(c)
    if (sats or signs) and p.strict:
        raise SaturationError("loihi2: a weight was clipped at write-back (strict mode)")


def commit(state: State) -> None:
    state.counters[COMMITS] += 1
    end_epoch(state)


def sigmoid(state: State, z: np.ndarray) -> np.ndarray:
    """sigmoid(z) from the 256-entry table (``quant.sigmoid_entry``), sent as an unsigned
    payload of min(num_message_bits, 16) bits."""
    bits = min(state.params.num_message_bits, SIGMOID_OUT_BITS)
    return np.array([math.ldexp(float(sigmoid_entry(v) >> (SIGMOID_OUT_BITS - bits)), -bits)
                     for v in z])
