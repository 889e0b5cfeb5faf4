"""Kernels of the memristive crossbar array: noisy analog reads, pulsed in-situ updates.

One source of truth: :class:`cml_edge.backends.crossbar.array.CrossbarArray` calls these
kernels from Python, and the compiled training and planning loops call the same ones
through the seam (:mod:`cml_edge.backends.dispatch`). The device model (balanced pairs,
levels, programming noise) is described in :mod:`cml_edge.backends.crossbar.conductance`;
the kernels read the device's numbers from ``state.params``, the
:class:`~cml_edge.backends.crossbar.config.CrossbarParams` record of its config and scale
(``P.g_min``, ``P.dw_min``...), and keep what they change over time in state arrays: the
drift-compensation factor ``state.alpha[0]`` and the idle time ``state.elapsed[0]``.

Read, W x (W^T y the same way on the same conductances, with the roles of the lines
swapped: the transposed read of planning):

1. the input is divided by max|x| (aihwkit's ABS_MAX noise management) and quantised
   by the DAC (``dac_bits``);
2. the analog sum over the devices, y_i = sum_j (G+_ij - G-_ij) x_j, in micro-siemens,
   normalised by the conductance range (so that a weight of w_max reads as 1);
3. read noise, fresh on every read: each device's conductance fluctuates by
   N(0, (read_noise (g_max - g_min))^2) during the read, which puts exactly
   N(0, 2 read_noise^2 sum_j x_j^2) on each normalised output (a sum of independent
   Gaussians; drawn as one normal per output), plus the output noise N(0, out_noise^2);
4. the ADC clips at +-adc_bound (counted) and quantises (``adc_bits``);
5. the digital periphery multiplies by w_max max|x| and, after drift compensation, by
   the array's compensation factor alpha (``state.alpha[0]``).

Update, W += lr post pre^T:

- per walk (``defer``): lr post pre^T is added to a digital float64 accumulator
  (``acc``); ``commit`` then, by ``commit`` mode, sends n = trunc(acc / dw_min)
  programming pulses to each pair and keeps the remainder in the accumulator (mixed
  precision), or write-verifies each pair whose target moved, drawing fresh
  programming noise for it;
- in place (not ``defer``), ``pulsed``: the stochastic coincidence update of Gokmen &
  Vlasov (2016). BL = min(ceil(lr max|x| max|d| / dw_min), bl_max) slots; column j
  fires in each slot with probability A |x_j|, row i with B |d_i|,
  A = sqrt(lr / (dw_min BL)) sqrt(max|d| / max|x|), B = sqrt(lr / (dw_min BL))
  sqrt(max|x| / max|d|); each coincidence moves pair (i, j) one nominal step
  dw_min in the direction sign(x_j d_i) (G+ up and G- down, or the reverse), so
  E[dw_ij] = BL (A|x_j|)(B|d_i|) dw_min = lr x_j d_i. ``analog``: the exact change
  (an ideal device; stochastically rounded to the grid when there is one).

A pulse moves a device by dG s (1 + dw_min_std z), dG the level spacing, s the
device's fixed up or down scale (device-to-device spread and up/down asymmetry),
z ~ N(0, 1) fresh per pulse; soft bounds scale it by 2 (g_max - G) / (g_max - g_min)
going up, 2 (G - g_min) / (g_max - g_min) going down. Every write clips a device to
[g_min, g_max]; stuck devices never change. Only devices actually pulsed or
programmed are written (and get write noise); a write restarts the device's drift clock.

Calibrated physics (each off at its config default, and then the code paths
and draws above are exactly those of earlier releases): a ``one-sided`` mapping programs
one device of a pair to g_min; a ``set_only`` pair sends each pulse to one device, up (G+
to raise w, G- to lower it), and a ``refresh`` pair that saturates is RESET and its
difference write-verified onto the larger device; ``step_model`` gives the step's
dependence on G (:func:`step_factor`) between the device's own bounds ``bnd`` and
``c2c`` its cycle-to-cycle noise; ``write_noise`` reads a pulsed device as its hidden
state plus a fresh offset (``wn``); reads add ``read_noise_pcm`` (PCM_READ) per output
and, with ``bound_management``, repeat a saturated read with halved inputs; ``elapse``
adds the accumulated read noise (``rn``, one persistent draw per device per call), uses
the conductance-dependent nu, and compensates drift from calibration reads through the
periphery. Extra draws come after the existing ones of the same operation: per pulse
and device, the c2c normal then the write-noise normal; a refresh's programming noise
after its pair's pulses; at construction, the bounds after the programming noise; in
``elapse``, the calibration read before, then one normal per device (row by row, G+
before G-), then the calibration read after.

Randomness: one counter-based stream per array, ``uniform(rng[0], c)`` from
:mod:`cml_edge.jit.rng` at the counter c = ``rng[1]``, advanced by one per uniform
drawn. Normal deviates come from those uniforms by the Marsaglia-Tsang ziggurat (256
layers; exact, and ~8x cheaper than the Box-Muller ``rng.normal`` that a read would
otherwise spend most of its time in). A long read computes the ziggurat's fast path for
its words in one vectorised pass and takes the slow path only at the rejected words
(:func:`_add_noise`): the same normals at the same counters as drawing them one by one.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numba.cpython.unsafe.numbers import trailing_zeros

from cml_edge.backends.crossbar.conductance import prog_sigma, snap_to_level
from cml_edge.backends.crossbar.config import (
    BOUNDS,
    C2C_MODELS,
    COMMITS,
    COMPENSATION_READS,
    MAPPINGS,
    STEP_MODELS,
    UPDATES,
)
from cml_edge.backends.quant import max_abs
from cml_edge.jit.kernel import kernel
from cml_edge.jit.rng import uniform, unit, word
from cml_edge.jit.simd import band_sums, lane_sums

# choice codes of the parameter record (the index of the value in the config's choices)
UPDATE_ANALOG, UPDATE_PULSED = UPDATES.index("analog"), UPDATES.index("pulsed")
COMMIT_PROGRAM, COMMIT_PULSE = COMMITS.index("program"), COMMITS.index("pulse")
BOUNDS_SOFT = BOUNDS.index("soft")
ONE_SIDED = MAPPINGS.index("one-sided")
STEP_BOUNDS, STEP_LINEAR, STEP_SOFT, STEP_EXP, STEP_POW = (
    STEP_MODELS.index(m) for m in ("bounds", "linear", "soft", "exp", "pow"))
C2C_MULT, C2C_ADD = C2C_MODELS.index("mult"), C2C_MODELS.index("add")
COMP_PERIPHERY = COMPENSATION_READS.index("periphery")

# counter indices (names in CrossbarArray.counter_names)
MATVECS, RMATVECS, ANALOG_MACS, DAC_CONVERSIONS, ADC_CONVERSIONS, ADC_SATURATIONS = 0, 1, 2, 3, 4, 5
OUTER_UPDATES, ACC_WRITES, LINE_PULSES, COINCIDENCES, DEVICE_PULSES = 6, 7, 8, 9, 10
DEVICES_WRITTEN, COMMITS, RNG_DRAWS = 11, 12, 13
REFRESHES, REFRESH_PULSES, CALIBRATION_READS, BM_REREADS = 14, 15, 16, 17
N_COUNTERS = 18

# stuck codes
OK, STUCK_LOW, STUCK_HIGH = 0, 1, 2

_ONE = np.uint64(1)

BAND_ROWS = 16
"""A forward read of at most this many rows sums them as vector lanes (:func:`_mac`); a
taller one (W_q, W_v) as one axpy per nonzero column, which skips the zero inputs of a
one-hot read once for all rows."""
SPARSE_READ = 8
"""A forward read with at most 1 in this many inputs nonzero (the grid's one-hot and
two-hot observations) visits their columns from the DAC's masks instead of testing every
input (:func:`_mac`)."""
BLOCK_OUTPUTS = 64
"""A read with at least this many outputs takes its normals' fast path in one vectorised
pass (:func:`_add_noise`); a shorter one draws in order."""
BLOCK_PAD = 16
"""Candidates beyond the outputs, for the words the slow paths consume (5.6 on average in a
read of 256 outputs); past them a read draws in order."""


# ziggurat tables (Marsaglia & Tsang 2000, 256 layers) ----------------------------------
def _ziggurat_tables() -> tuple[np.ndarray, np.ndarray, float]:
    n, r, v = 256, 3.6541528853610088, 0.00492867323399
    x = np.zeros(n + 1)
    x[0] = v / math.exp(-0.5 * r * r)
    x[1] = r
    for i in range(2, n):
        x[i] = math.sqrt(-2.0 * math.log(v / x[i - 1] + math.exp(-0.5 * x[i - 1] ** 2)))
    return x, np.exp(-0.5 * x * x), r


ZIG_X, ZIG_F, ZIG_R = _ziggurat_tables()


@kernel
def _normal_slow(key, ctr, i, x, negative):
    """The rare branches of :func:`normal_at` (~1 % of draws): the tail (layer 0) or the
    wedge test, and on rejection the whole draw again, until one is accepted."""
    while True:
        if i == 0:  # the tail beyond r (Marsaglia 1964)
            while True:
                a = -math.log(1.0 - uniform(key, ctr)) / ZIG_R
                b = -math.log(1.0 - uniform(key, ctr + _ONE))
                ctr += np.uint64(2)
                if b + b > a * a:
                    break
            x = ZIG_R + a
            return (-x if negative else x), ctr
        y = ZIG_F[i] + uniform(key, ctr) * (ZIG_F[i + 1] - ZIG_F[i])
        ctr += _ONE
        if y < math.exp(-0.5 * x * x):
            return (-x if negative else x), ctr
        w = word(key, ctr)
        ctr += _ONE
        i = np.int64(w & np.uint64(255))
        negative = (w >> np.uint64(8)) & _ONE != 0
        x = unit(w) * ZIG_X[i]
        if x < ZIG_X[i + 1]:
            return (-x if negative else x), ctr


@kernel
def normal_at(key, ctr):
    """A standard normal from the stream at counters ctr, ctr+1, ...; returns (z, next ctr).

    The 64-bit word behind ``uniform(key, c)`` (SplitMix64 at position c) gives the
    layer (bits 0-7), the sign (bit 8) and, in its top 53 bits, the uniform itself.
    """
    w = word(key, ctr)
    ctr += _ONE
    i = np.int64(w & np.uint64(255))
    negative = (w >> np.uint64(8)) & _ONE != 0
    x = unit(w) * ZIG_X[i]
    if x < ZIG_X[i + 1]:
        return (-x if negative else x), ctr
    return _normal_slow(key, ctr, i, x, negative)


@kernel
def _popcount(v):
    """The set bits of a 64-bit word (int64 or uint64; the SWAR sum, which LLVM compiles
    to one instruction)."""
    v = np.uint64(v)
    v = v - ((v >> np.uint64(1)) & np.uint64(0x5555555555555555))
    v = (v & np.uint64(0x3333333333333333)) + ((v >> np.uint64(2)) & np.uint64(0x3333333333333333))
    v = (v + (v >> np.uint64(4))) & np.uint64(0x0F0F0F0F0F0F0F0F)
    return np.int64((v * np.uint64(0x0101010101010101)) >> np.uint64(56))


# reads ---------------------------------------------------------------------------------
@kernel
def _pulse_train(p, bl, key, ctr):
    """A stochastic pulse train of ``bl`` slots, each fired with probability min(p, 1).

    Returns the train as a bitmask (bit t = slot t) and the advanced draw counter; a
    line with p == 0 draws nothing.
    """
    b = 0
    if p != 0.0:
        p = min(p, 1.0)
        for t in range(bl):
            if uniform(key, ctr) < p:
                b |= 1 << t
            ctr += _ONE
    return b, ctr


@kernel
def _convert_inputs(x, xs, n_in, dac, need_sq, nz):
    """xs = DAC(x / max|x|) (:func:`_quantise_inputs`); returns (max|x|, nonzero inputs,
    sum xs^2 if ``need_sq``)."""
    xmax = max_abs(x, n_in)[0]
    if not xmax > 0.0:
        return xmax, 0, 0.0
    nnz, sq = _quantise_inputs(x, xs, n_in, dac, 1.0 / xmax, need_sq, nz)
    return xmax, nnz, sq


@kernel
def _quantise_inputs(x, xs, n_in, dac, inv, need_sq, nz):
    """xs = DAC(x inv), and bit j % 64 of nz[j // 64] set where xs[j] != 0 (the inputs
    that drive the array, which :func:`_mac` visits); returns (nonzero inputs, sum xs^2 in
    index order if ``need_sq``, else 0: only the per-device read noise needs it). Each pass
    vectorises but the sum, which adds only the nonzero inputs' squares, in index order
    (a zero adds +0.0 to a sum that is never -0.0: the same bits as adding every square)."""
    if dac > 0.0:
        inv_dac = 1.0 / dac
        for j in range(n_in):
            v = x[j] * inv
            xs[j] = math.copysign(math.floor(abs(v) * inv_dac + 0.5), v) * dac
    else:
        for j in range(n_in):
            xs[j] = x[j] * inv
    nnz = 0
    for b in range((n_in + 63) >> 6):
        mk = np.uint64(0)
        for u in range(min(n_in - (b << 6), 64)):
            mk |= np.uint64(xs[(b << 6) + u] != 0.0) << np.uint64(u)
        nz[b] = np.int64(mk)
        nnz += _popcount(mk)
    sq = 0.0
    if need_sq:
        for b in range((n_in + 63) >> 6):
            m = np.uint64(nz[b])
            while m != 0:
                j = (b << 6) + np.int64(trailing_zeros(m))
                m &= m - _ONE
                sq += xs[j] * xs[j]
    return nnz, sq


@kernel
def _mac(Gp, Gm, xs, buf, transposed, nz, nnz):
    """buf = (G+ - G-) xs, or (G+ - G-)^T xs: the analog sums (micro-siemens).

    W x sums each output over the columns of the nonzero inputs, in order. With at most
    :data:`BAND_ROWS` rows (W_k's 8), the rows are summed as vector lanes
    (:func:`cml_edge.jit.simd.band_sums`: the same operations in the same order); otherwise as
    one axpy per driven column, found from the DAC's masks ``nz`` when there are few
    (``nnz``, :data:`SPARSE_READ`). W^T y sums each output in eight interleaved partial
    sums (:func:`cml_edge.jit.simd.lane_sums`), then the rows left over, then the eight."""
    rows, cols = Gp.shape
    if not transposed and rows <= BAND_ROWS and Gp.strides[0] == 8 and Gm.strides[0] == 8:
        i0 = 0
        while i0 + 8 <= rows:
            band_sums(Gp, Gm, xs, buf, i0, 8)
            i0 += 8
        if i0 + 4 <= rows:
            band_sums(Gp, Gm, xs, buf, i0, 4)
            i0 += 4
        if i0 + 2 <= rows:
            band_sums(Gp, Gm, xs, buf, i0, 2)
            i0 += 2
        if i0 < rows:
            band_sums(Gp, Gm, xs, buf, i0, 1)
        return
    if not transposed:  # W x = sum_j x_j (G+ - G-)[:, j], along contiguous columns
        for i in range(rows):
            buf[i] = 0.0
        if nnz * SPARSE_READ > cols:  # most inputs drive the array
            for j in range(cols):
                v = xs[j]
                if v != 0.0:
                    for i in range(rows):
                        buf[i] += (Gp[i, j] - Gm[i, j]) * v
            return
        for b in range((cols + 63) >> 6):  # a few inputs (one-hot): their columns in order
            m = np.uint64(nz[b])
            while m != 0:
                j = (b << 6) + np.int64(trailing_zeros(m))
                m &= m - _ONE
                v = xs[j]
                for i in range(rows):
                    buf[i] += (Gp[i, j] - Gm[i, j]) * v
        return
    lanes = Gp.strides[0] == 8 and Gm.strides[0] == 8
    for o in range(cols):  # W^T y: one reduction per column, eight partial sums
        s0 = s1 = s2 = s3 = s4 = s5 = s6 = s7 = 0.0
        k = 0
        if lanes:  # the eight sums as vector lanes (cml_edge.jit.simd.lane_sums), same order
            k = rows - rows % 8
            s0, s1, s2, s3, s4, s5, s6, s7 = lane_sums(Gp, Gm, xs, o, k)
        while k + 8 <= rows:
            s0 += (Gp[k, o] - Gm[k, o]) * xs[k]
            s1 += (Gp[k + 1, o] - Gm[k + 1, o]) * xs[k + 1]
            s2 += (Gp[k + 2, o] - Gm[k + 2, o]) * xs[k + 2]
            s3 += (Gp[k + 3, o] - Gm[k + 3, o]) * xs[k + 3]
            s4 += (Gp[k + 4, o] - Gm[k + 4, o]) * xs[k + 4]
            s5 += (Gp[k + 5, o] - Gm[k + 5, o]) * xs[k + 5]
            s6 += (Gp[k + 6, o] - Gm[k + 6, o]) * xs[k + 6]
            s7 += (Gp[k + 7, o] - Gm[k + 7, o]) * xs[k + 7]
            k += 8
        while k < rows:
            s0 += (Gp[k, o] - Gm[k, o]) * xs[k]
            k += 1
        buf[o] = ((s0 + s1) + (s2 + s3)) + ((s4 + s5) + (s6 + s7))


@kernel
def _fast_candidates(key, ctr, zc, masks, m):
    """The fast path of :func:`normal_at` for the words at counters ctr .. ctr + m - 1, in
    one pass that vectorises: zc[t] is the normal of the word at ctr + t where the fast path
    accepts it, and bit t % 64 of masks[t // 64] is set where it does not (~1.5 % of words:
    the slow path's). ``masks`` is int64 scratch holding the bits of uint64 words."""
    for b in range((m + 63) >> 6):
        mk = np.uint64(0)
        for u in range(min(m - (b << 6), 64)):
            t = (b << 6) + u
            w = word(key, ctr + np.uint64(t))
            i = np.int64(w & np.uint64(255))
            x = unit(w) * ZIG_X[i]
            mk |= np.uint64(not x < ZIG_X[i + 1]) << np.uint64(u)
            zc[t] = x - 2.0 * np.float64((w >> np.uint64(8)) & _ONE) * x  # x or -x, exact
        masks[b] = np.int64(mk)


@kernel
def _next_rejected(masks, t, limit):
    """The first word at or after t that the fast path rejects, or ``limit`` if none is
    below it."""
    while t < limit:
        b = t >> 6
        rest = np.uint64(masks[b]) >> np.uint64(t & 63)
        if rest != 0:
            return min(t + np.int64(trailing_zeros(rest)), limit)
        t = (b + 1) << 6
    return limit


@kernel
def _add_noise(buf, var, n_out, inv_g, sigma, wn, rng, zc, masks):
    """buf[o] = buf[o] inv_g + s_o z_o for every output o, z_o the o-th normal of
    :func:`normal_at` from the stream's counter on, s_o = sigma, or sqrt(sigma^2 +
    wn^2 var[o]) when wn > 0 (PCM_READ); advances the counter past the draws.

    The same draws at the same counters as calling :func:`normal_at` output after output,
    but faster for a long read: :func:`_fast_candidates` takes the fast path
    of up to ``zc.shape[0]`` words in one vectorised pass; the outputs then take the
    candidates run by run up to each rejected word, whose slow path (and the words it
    consumes) continues the draws at the counter it leaves, and the rest of the read, if
    the rejections carry it past the candidates, draws in order. A read of fewer than
    :data:`BLOCK_OUTPUTS` outputs draws in order (the pass would cost more than it saves).
    """
    key = rng[0]
    start = rng[1]
    per_output = wn > 0.0
    b2 = sigma * sigma
    w2 = wn * wn
    o = 0
    t = 0
    m = 0
    if n_out >= BLOCK_OUTPUTS:
        m = min(n_out + BLOCK_PAD, zc.shape[0])
        _fast_candidates(key, start, zc, masks, m)
    while o < n_out:
        if t < m:  # a run of accepted candidates (unsigned indices: the loop vectorises)
            e = _next_rejected(masks, t, min(t + n_out - o, m))
            uo = np.uint64(o)
            ut = np.uint64(t)
            for k in range(np.uint64(e - t)):
                s = math.sqrt(b2 + w2 * var[uo + k]) if per_output else sigma
                buf[uo + k] = buf[uo + k] * inv_g + s * zc[ut + k]
            o += e - t
            t = e
            if o == n_out or t == m:
                continue
            w = word(key, start + np.uint64(t))  # the rejected word: its slow path
            i = np.int64(w & np.uint64(255))
            z, c = _normal_slow(key, start + np.uint64(t) + _ONE, i, unit(w) * ZIG_X[i],
                                (w >> np.uint64(8)) & _ONE != 0)
        else:  # in order
            z, c = normal_at(key, start + np.uint64(t))
        s = math.sqrt(b2 + w2 * var[o]) if per_output else sigma
        buf[o] = buf[o] * inv_g + s * z
        o += 1
        t = np.int64(c - start)
    rng[1] = start + np.uint64(t)


@kernel
def _convert_outputs(buf, var, out, n_out, g_min, g_max, adc, bound, sigma, wn, scale, rng,
                     zc, masks):
    """Normalise, add the read noise (:func:`_add_noise`; none when sigma and wn are 0),
    ADC (step ``adc``, 0 = ideal; clipping at +-``bound``), rescale; returns the saturated
    outputs."""
    inv_g = 1.0 / (g_max - g_min)
    if sigma > 0.0 or wn > 0.0:
        _add_noise(buf, var, n_out, inv_g, sigma, wn, rng, zc, masks)
    else:
        for o in range(n_out):
            buf[o] = buf[o] * inv_g
    saturated = 0
    if adc > 0.0:
        inv_adc = 1.0 / adc
        unit = adc * scale
        for o in range(n_out):
            v = buf[o]
            saturated += abs(v) > bound
            v = min(max(v, -bound), bound)
            out[o] = math.copysign(math.floor(abs(v) * inv_adc + 0.5), v) * unit
    else:
        for o in range(n_out):
            out[o] = buf[o] * scale
    return saturated


@kernel
def _abs_w_x2(Gp, Gm, xs, buf, transposed, inv_g):
    """buf_i = sum_j |G+ - G-|_ij / range xs_j^2 (or over the rows, transposed): the
    variance of the PCM_READ per-read noise over read_noise_pcm^2."""
    rows, cols = Gp.shape
    if not transposed:
        for i in range(rows):
            buf[i] = 0.0
        for j in range(cols):
            v = xs[j] * xs[j]
            if v != 0.0:
                for i in range(rows):
                    buf[i] += abs(Gp[i, j] - Gm[i, j]) * inv_g * v
        return
    for o in range(cols):
        s = 0.0
        for k in range(rows):
            s += abs(Gp[k, o] - Gm[k, o]) * inv_g * (xs[k] * xs[k])
        buf[o] = s


@kernel
def _read(Gp, Gm, xbuf, ybuf, vbuf, bits, rng, alpha, counters, P, x, out, transposed,
          kind):
    """out = W x (or W^T x) as the array reads it (module docstring, steps 1-5, and the
    bound management's re-reads), counted as a read of ``kind`` (a counter index; -1: a
    calibration read, counted by its caller). The state's arrays come as arguments (issue
    15: compiled with reference counting, reading them from the state tuple paid their
    counts at every read; a :func:`~cml_edge.jit.kernel.kernel` pays none)."""
    if kind >= 0:
        counters[kind] += 1
    rows, cols = Gp.shape
    n_in = rows if transposed else cols
    n_out = cols if transposed else rows
    rn = P.read_noise
    on = P.out_noise
    xmax, nnz, sq = _convert_inputs(x, xbuf, n_in, P.dac_step, rn != 0.0, bits)
    if not xmax > 0.0:  # no input drives the array: nothing is read
        for i in range(n_out):
            out[i] = 0.0 if xmax == 0.0 else math.nan
        return
    div = xmax
    passes = 0
    while True:
        if passes > 0:  # a re-read: the input halved again (aihwkit ITERATIVE)
            div = div * 2.0
            nnz, sq = _quantise_inputs(x, xbuf, n_in, P.dac_step, 1.0 / div, rn != 0.0, bits)
            counters[BM_REREADS] += 1
        _mac(Gp, Gm, xbuf, ybuf, transposed, bits, nnz)
        sigma = math.sqrt(2.0 * rn * rn * sq + on * on)
        start = rng[1]
        scale = P.w_max * div * alpha[0]
        if P.read_noise_pcm > 0.0:
            _abs_w_x2(Gp, Gm, xbuf, vbuf, transposed, 1.0 / (P.g_max - P.g_min))
        # (xbuf and bits, free once the sums are formed, hold the noise's candidates)
        saturated = _convert_outputs(ybuf, vbuf, out, n_out, P.g_min, P.g_max, P.adc_step,
                                     P.adc_bound, sigma, P.read_noise_pcm, scale, rng, xbuf,
                                     bits)
        counters[RNG_DRAWS] += np.int64(rng[1] - start)
        counters[ANALOG_MACS] += nnz * n_out
        counters[DAC_CONVERSIONS] += nnz
        counters[ADC_CONVERSIONS] += n_out
        counters[ADC_SATURATIONS] += saturated
        passes += 1
        if P.bound_management == 0 or saturated == 0 or passes >= P.bm_passes:
            return


@njit(cache=True, inline="always")
def read(state, x, out, transposed, kind):
    """:func:`_read` on the state's arrays, in one statement."""
    _read(state.Gp, state.Gm, state.xbuf, state.ybuf, state.vbuf, state.bits, state.rng,
          state.alpha, state.counters, state.params, x, out, transposed, kind)


@njit(cache=True, inline="always")
def xbar_matvec(state, x, out):
    read(state, x, out, False, MATVECS)


@njit(cache=True, inline="always")
def xbar_rmatvec(state, y, out):
    read(state, y, out, True, RMATVECS)


@njit(cache=True, inline="always")
def xbar_sigmoid(state, z, out):
    """The affordance nonlinearity: a digital peripheral function, computed exactly."""
    for i in range(z.shape[0]):
        out[i] = 1.0 / (1.0 + math.exp(-z[i]))


# writes --------------------------------------------------------------------------------
@kernel
def _move(g, up, s, z, P):
    """A device at conductance g after one pulse (up or down) of relative size s (1 + c2c z)
    (step_model ``bounds``, the model of earlier releases)."""
    g_min = P.g_min
    g_max = P.g_max
    d = P.dG * s * (1.0 + P.dw_min_std * z)
    if P.bounds == BOUNDS_SOFT:
        if up:
            d *= 2.0 * (g_max - g) / (g_max - g_min)
        else:
            d *= 2.0 * (g - g_min) / (g_max - g_min)
    if P.set_only and d < 0.0:  # a SET pulse never lowers G
        d = 0.0
    g = g + d if up else g - d
    return min(max(g, g_min), g_max)


@kernel
def step_factor(g, up, lo, hi, P):
    """The mean step of one pulse at conductance g, in units of the device's nominal step
    s dG (``step_model`` of :class:`~cml_edge.backends.crossbar.config.DeviceConfig`;
    lo / hi the device's bounds); never negative."""
    m = P.step_model
    span = hi - lo
    if not span > 0.0:
        return 0.0
    g0 = lo + P.step_center * span
    if m in (STEP_LINEAR, STEP_SOFT):
        if up:
            f = 1.0 - (P.gamma_up if m == STEP_LINEAR else 1.0) * (g - g0) / (hi - g0)
        else:
            f = 1.0 - (P.gamma_down if m == STEP_LINEAR else 1.0) * (g - g0) / (lo - g0)
    elif m == STEP_EXP:
        zz = 2.0 * P.exp_a * ((g - lo) / span - P.step_center) + P.exp_b
        if up:
            f = 1.0 - P.exp_a_up * math.exp(P.exp_gamma_up * zz)
        else:
            f = 1.0 - P.exp_a_down * math.exp(-P.exp_gamma_down * zz)
    elif m == STEP_POW:
        r = (hi - g) / span if up else (g - lo) / span
        f = r ** P.pow_gamma if r > 0.0 else 0.0
    elif P.bounds == BOUNDS_SOFT:
        f = 2.0 * (P.g_max - g) / (P.g_max - P.g_min) if up else \
            2.0 * (g - P.g_min) / (P.g_max - P.g_min)
    else:
        f = 1.0
    return max(f, 0.0)


@kernel
def _move_model(g, up, s, z, lo, hi, P):
    """A device at g after one pulse of nominal size s dG under ``step_model`` and ``c2c``
    (module docstring), clipped to its bounds [lo, hi]."""
    dG = P.dG
    f = step_factor(g, up, lo, hi, P)
    step = dG * s * f
    c = P.c2c
    if c == C2C_MULT:
        sd = P.dw_min_std * step
    elif c == C2C_ADD:
        sd = P.dw_min_std * dG * s
    else:
        g0 = lo + P.step_center * (hi - lo)
        sd = P.dw_min_std * (step + P.c2c_add * (P.g_max - P.g_min)
                             + P.c2c_slope * abs(g - g0))
    if P.set_only:
        # a SET pulse never lowers G: the step is log-normal with the model's mean and std
        d = 0.0
        if step > 0.0:
            cv = sd / step
            v = math.log1p(cv * cv)
            d = step * math.exp(math.sqrt(v) * z - 0.5 * v)
    else:
        d = step + sd * z
    g = g + d if up else g - d
    return min(max(g, lo), hi)


@njit(cache=True, inline="always")
def _pulse_device(P, step, wn, bnd, G, d, i, j, up, z, w):
    """Device d of pair (i, j), at apparent conductance G, after one pulse; with write
    noise, the pulse moves the hidden state G - wn and a fresh offset w write_noise dG
    is read on top of it."""
    s = step[2 * d, i, j] if up else step[2 * d + 1, i, j]
    h = G - wn[d, i, j] if P.write_noise > 0.0 else G
    if P.step_model == STEP_BOUNDS:
        h = _move(h, up, s, z, P)
    else:
        h = _move_model(h, up, s, z, bnd[2 * d, i, j], bnd[2 * d + 1, i, j], P)
    if P.write_noise > 0.0:
        G = min(max(h + P.write_noise * P.dG * w, P.g_min), P.g_max)
        wn[d, i, j] = G - h
        return G
    return h


@kernel
def nu_of(g, z, P):
    """The drift exponent of a device written to g with fixed normal z (``drift_nu_g``)."""
    lg = math.log(max(abs(g / P.g_max), 1e-7))
    mu = min(max(P.nu_a * lg + P.nu_b, P.nu_lo), P.nu_hi)
    sd = min(max(P.nu_sa * lg + P.nu_sb, P.nu_slo), P.nu_shi)
    return abs(mu + sd * z)


@njit(cache=True, inline="always")
def _written(age, rn, nu, nu_z, P, d, i, j, g):
    """Bookkeeping of a write of device d of pair (i, j) to g: its drift clock restarts,
    its accumulated read noise is gone, its drift exponent follows g (``drift_nu_g``).

    The write kernels take the state's arrays as arguments, read from the state once per
    kernel (compiled with reference counting, a ``state.field`` inside a loop
    paid them on every pass and the per-walk commit was 5x slower)."""
    age[d, i, j] = 0.0
    if P.rn1f > 0.0:
        rn[d, i, j] = 0.0
    if P.drift_nu_g != 0:
        nu[d, i, j] = nu_of(g, nu_z[d, i, j], P)


@kernel
def set_pulses(target, P):
    """SET pulses the mean device (s = 1, no noise, nominal bounds) needs from g_min to
    ``target``: what a refresh's write-verify costs (at most 100,000)."""
    if not P.dG > 0.0:
        return 0
    g = P.g_min
    n = 0
    while g < target and n < 100000:
        g2 = min(g + P.dG * step_factor(g, True, P.g_min, P.g_max, P), P.g_max)
        n += 1
        if not g2 > g:
            break
        g = g2
    return n


@kernel
def _refresh_pair(Gp, Gm, stuck, bnd, wn, age, rn, nu, nu_z, counters, P, i, j, key, ctr):
    """Refresh pair (i, j) if it is saturated (``refresh``): RESET both devices, then
    write-verify the pair's difference onto the device that was larger."""
    rng = P.g_max - P.g_min
    up_ = (Gp[i, j] - P.g_min) / rng
    um = (Gm[i, j] - P.g_min) / rng
    big = max(up_, um)
    small = min(up_, um)
    if not (big > P.refresh_upper and small > P.refresh_lower):
        return ctr
    diff = Gp[i, j] - Gm[i, j]
    pulses = 2  # the two RESETs
    for d in range(2):
        target = P.g_min
        if d == 0 and diff > 0.0:
            target = P.g_min + diff
        elif d == 1 and diff < 0.0:
            target = P.g_min - diff
        if stuck[d, i, j] != OK:
            continue
        G, ctr = _program_device(target, 0.0, P, key, ctr, bnd[2 * d, i, j],
                                 bnd[2 * d + 1, i, j])
        if target > P.g_min:
            pulses += set_pulses(target, P)
        if d == 0:
            Gp[i, j] = G
        else:
            Gm[i, j] = G
        wn[d, i, j] = 0.0
        _written(age, rn, nu, nu_z, P, d, i, j, target)
    counters[REFRESHES] += 1
    counters[REFRESH_PULSES] += pulses
    return ctr


@kernel
def _pulse_pair(Gp, Gm, stuck, step, bnd, wn, age, rn, nu, nu_z, counters, P, i, j, n,
                positive, key, ctr):
    """n pulses on pair (i, j): positive raises the weight. A two-sided (bidirectional)
    pair raises G+ and lowers G- per pulse (or the reverse); a SET-only pair potentiates
    G+ (or G-) alone. Draws per pulse and device: the c2c normal (if ``dw_min_std``),
    then the write-noise normal (if ``write_noise``); a refresh then draws its
    programming noise."""
    noisy = P.dw_min_std != 0.0
    if P.step_model == STEP_BOUNDS and not P.set_only and P.write_noise == 0.0:
        # the pulse loop of earlier releases, draw for draw
        for _ in range(n):
            for d in range(2):
                up = positive if d == 0 else not positive
                z = 0.0
                if noisy:
                    z, ctr = normal_at(key, ctr)
                if stuck[d, i, j] != OK:
                    continue
                s = step[2 * d, i, j] if up else step[2 * d + 1, i, j]
                if d == 0:
                    Gp[i, j] = _move(Gp[i, j], up, s, z, P)
                else:
                    Gm[i, j] = _move(Gm[i, j], up, s, z, P)
        _written(age, rn, nu, nu_z, P, 0, i, j, Gp[i, j])
        _written(age, rn, nu, nu_z, P, 1, i, j, Gm[i, j])
    else:
        wnoisy = P.write_noise > 0.0
        first = 0 if (positive or not P.set_only) else 1
        last = 1 if (not positive or not P.set_only) else 0
        for _ in range(n):
            for d in range(first, last + 1):
                up = True if P.set_only else (positive if d == 0 else not positive)
                z = 0.0
                w = 0.0
                if noisy:
                    z, ctr = normal_at(key, ctr)
                if wnoisy:
                    w, ctr = normal_at(key, ctr)
                if stuck[d, i, j] != OK:
                    continue
                if d == 0:
                    Gp[i, j] = _pulse_device(P, step, wn, bnd, Gp[i, j], 0, i, j, up, z, w)
                else:
                    Gm[i, j] = _pulse_device(P, step, wn, bnd, Gm[i, j], 1, i, j, up, z, w)
        for d in range(first, last + 1):
            _written(age, rn, nu, nu_z, P, d, i, j, Gp[i, j] if d == 0 else Gm[i, j])
    if P.refresh != 0:
        ctr = _refresh_pair(Gp, Gm, stuck, bnd, wn, age, rn, nu, nu_z, counters, P, i, j, key,
                            ctr)
    return ctr


@kernel
def _program_device(G, delta, P, key, ctr, lo, hi):
    """Write-verify a device to the level nearest G + delta, with programming noise,
    within its bounds [lo, hi] (g_min / g_max unless ``bound_dtod_*``)."""
    g_min = P.g_min
    g_max = P.g_max
    target = snap_to_level(G + delta, g_min, g_max, P.dG)
    sigma = prog_sigma(target, P.prog_noise, P.prog_c0, P.prog_c1, P.prog_c2, P.prog_gref,
                       g_max)
    if sigma > 0.0:
        z, ctr = normal_at(key, ctr)
        target += sigma * z
        if target < g_min:
            target = g_min
        elif target > g_max:
            target = g_max
    return min(max(target, lo), hi), ctr


@kernel
def _pulsed_update(state, post, pre, lr):
    Gp, Gm, stuck, step, bnd, wn = (state.Gp, state.Gm, state.stuck, state.step, state.bnd,
                                   state.wn)
    age, rn, nu, nu_z = state.age, state.rn, state.nu, state.nu_z
    P = state.params
    bits = state.bits
    idx = state.idx
    rows, cols = Gp.shape
    c = state.counters
    dw_min = P.dw_min
    xmax = 0.0
    for j in range(cols):
        xmax = max(xmax, abs(pre[j]))
    dmax = 0.0
    for i in range(rows):
        dmax = max(dmax, abs(post[i]))
    if not (xmax > 0.0 and dmax > 0.0 and lr > 0.0):
        return
    bl = int(math.ceil(lr * xmax * dmax / dw_min))
    bl = max(1, min(bl, P.bl_max))
    base = math.sqrt(lr / (dw_min * bl))
    A = base * math.sqrt(dmax / xmax)
    B = base * math.sqrt(xmax / dmax)
    key = state.rng[0]
    ctr = state.rng[1]
    start = ctr
    line_pulses = 0
    live = 0
    for j in range(cols):
        b, ctr = _pulse_train(A * abs(pre[j]), bl, key, ctr)
        bits[rows + j] = b
        if b:
            idx[live] = j
            live += 1
            line_pulses += _popcount(b)
    coincidences = 0
    pairs = 0
    for i in range(rows):
        b, ctr = _pulse_train(B * abs(post[i]), bl, key, ctr)
        bits[i] = b
        if b == 0:
            continue
        line_pulses += _popcount(b)
        for k in range(live):
            j = idx[k]
            n = _popcount(b & bits[rows + j])
            if n:
                coincidences += n
                pairs += 1
                ctr = _pulse_pair(Gp, Gm, stuck, step, bnd, wn, age, rn, nu, nu_z, c, P, i, j,
                                  n, (post[i] > 0.0) == (pre[j] > 0.0), key, ctr)
    state.rng[1] = ctr
    per_pair = 1 if P.set_only else 2  # devices a coincidence pulses
    c[RNG_DRAWS] += np.int64(ctr - start)
    c[LINE_PULSES] += line_pulses
    c[COINCIDENCES] += coincidences
    c[DEVICE_PULSES] += per_pair * coincidences
    c[DEVICES_WRITTEN] += per_pair * pairs


@kernel
def _analog_update(state, post, pre, lr):
    """The exact change (an ideal device), stochastically rounded to the grid if any. A
    SET-only pair puts the whole change on G+ (raising w) or G- (lowering it)."""
    Gp = state.Gp
    Gm = state.Gm
    P = state.params
    rows, cols = Gp.shape
    g_min = P.g_min
    g_max = P.g_max
    dG = P.dG
    set_only = P.set_only != 0
    half = P.g_per_w if set_only else 0.5 * P.g_per_w
    stuck = state.stuck
    age, rn, nu, nu_z = state.age, state.rn, state.nu, state.nu_z
    key = state.rng[0]
    ctr = state.rng[1]
    start = ctr
    written = 0
    for i in range(rows):
        if post[i] == 0.0:
            continue
        p = lr * post[i]
        for j in range(cols):
            if pre[j] == 0.0:
                continue
            d = p * pre[j] * half
            if dG > 0.0:
                d = math.floor(d / dG + uniform(key, ctr)) * dG
                ctr += _ONE
                if d == 0.0:
                    continue
            if set_only:
                k = 0 if d > 0.0 else 1
                if stuck[k, i, j] == OK:
                    if k == 0:
                        Gp[i, j] = min(max(Gp[i, j] + d, g_min), g_max)
                    else:
                        Gm[i, j] = min(max(Gm[i, j] - d, g_min), g_max)
                _written(age, rn, nu, nu_z, P, k, i, j, Gp[i, j] if k == 0 else Gm[i, j])
                written += 1
                continue
            if stuck[0, i, j] == OK:
                Gp[i, j] = min(max(Gp[i, j] + d, g_min), g_max)
            if stuck[1, i, j] == OK:
                Gm[i, j] = min(max(Gm[i, j] - d, g_min), g_max)
            _written(age, rn, nu, nu_z, P, 0, i, j, Gp[i, j])
            _written(age, rn, nu, nu_z, P, 1, i, j, Gm[i, j])
            written += 2
    state.rng[1] = ctr
    state.counters[RNG_DRAWS] += np.int64(ctr - start)
    state.counters[DEVICES_WRITTEN] += written


@njit(cache=True, inline="always")
def xbar_outer_update(state, post, pre, lr, defer):
    c = state.counters
    c[OUTER_UPDATES] += 1
    if defer:
        acc = state.acc
        rows, cols = acc.shape
        touched = 0
        if rows >= cols:  # column-major (tall): along columns, skipping zero pre factors
            for j in range(cols):
                q = pre[j]
                if q == 0.0:
                    continue
                touched += rows
                for i in range(rows):
                    acc[i, j] += (lr * post[i]) * q
        else:  # row-major (wide): along rows, the same cells
            for j in range(cols):
                touched += rows * (pre[j] != 0.0)
            for i in range(rows):
                p = lr * post[i]
                for j in range(cols):
                    q = pre[j]
                    if q != 0.0:
                        acc[i, j] += p * q
        c[ACC_WRITES] += touched
    elif state.params.update == UPDATE_PULSED:
        _pulsed_update(state, post, pre, lr)
    else:
        _analog_update(state, post, pre, lr)


@kernel
def _commit(state):
    Gp = state.Gp
    Gm = state.Gm
    acc = state.acc
    P = state.params
    stuck = state.stuck
    bnd = state.bnd
    wn = state.wn
    step = state.step
    counters = state.counters
    age, rn, nu, nu_z = state.age, state.rn, state.nu, state.nu_z
    rows, cols = Gp.shape
    dw_min = P.dw_min
    dG = P.dG
    half = 0.5 * P.g_per_w
    pulse = P.commit == COMMIT_PULSE
    one_sided = P.mapping == ONE_SIDED
    per_pair = 1 if P.set_only else 2
    key = state.rng[0]
    ctr = state.rng[1]
    start = ctr
    pulses = 0
    written = 0
    for i in range(rows):
        for j in range(cols):
            a = acc[i, j]
            if a == 0.0:
                continue
            n = 0
            if dG > 0.0:
                n = int(a / dw_min)  # whole steps, toward zero; the rest stays
                if n == 0:
                    continue
                acc[i, j] = a - n * dw_min
                delta = n * dG
            else:
                acc[i, j] = 0.0
                delta = a * half
            if pulse:
                written += per_pair
                pulses += per_pair * abs(n)
                ctr = _pulse_pair(Gp, Gm, stuck, step, bnd, wn, age, rn, nu, nu_z, counters,
                                  P, i, j, abs(n), n > 0, key, ctr)
                continue
            written += 2
            tp = Gp[i, j] + delta
            tm = Gm[i, j] - delta
            if one_sided:  # retarget both devices from the weight they hold
                w = (Gp[i, j] - Gm[i, j]) / P.g_per_w + (n * dw_min if dG > 0.0 else a)
                w = min(max(w, -P.w_max), P.w_max)
                tp = P.g_min + max(w, 0.0) * P.g_per_w
                tm = P.g_min + max(-w, 0.0) * P.g_per_w
            if stuck[0, i, j] == OK:
                Gp[i, j], ctr = _program_device(tp, 0.0, P, key, ctr, bnd[0, i, j],
                                                bnd[1, i, j])
                wn[0, i, j] = 0.0
            if stuck[1, i, j] == OK:
                Gm[i, j], ctr = _program_device(tm, 0.0, P, key, ctr, bnd[2, i, j],
                                                bnd[3, i, j])
                wn[1, i, j] = 0.0
            _written(age, rn, nu, nu_z, P, 0, i, j, tp)
            _written(age, rn, nu, nu_z, P, 1, i, j, tm)
    state.rng[1] = ctr
    c = counters
    c[RNG_DRAWS] += np.int64(ctr - start)
    c[DEVICE_PULSES] += pulses
    c[LINE_PULSES] += 2 * pulses  # a serial programming pulse drives one row and one column
    c[DEVICES_WRITTEN] += written


@njit(cache=True, inline="always")
def xbar_commit(state):
    state.counters[COMMITS] += 1
    _commit(state)


# construction and time -----------------------------------------------------------------
@kernel
def xbar_program(state, W):
    """Draw the per-device constants and program W (the array's construction).

    Draw order, all from the array's stream, and always the same number of normals
    whatever the parameters, so that sweeps compare the same devices: a uniform per
    device for stuck-at faults (stuck low if u < f_low, high if u < f_low + f_high);
    two normals per device for its pulse-step scale (1 + dtod z1, clipped at 0) and
    asymmetry (up_down + up_down_dtod z2); one normal per device for nu (clipped at 0;
    kept as ``nu_z`` for ``drift_nu_g``); one normal per device for the programming
    noise. Devices are visited row by row, G+ before G-. Then, only when a bound spread
    is configured (``bound_dtod_up`` or ``_down`` > 0), two normals per device for its
    upper and lower bound, which clip it.
    """
    Gp = state.Gp
    Gm = state.Gm
    P = state.params
    rows, cols = Gp.shape
    key = state.rng[0]
    ctr = state.rng[1]
    start = ctr
    lo = P.stuck_low
    hi = lo + P.stuck_high
    for i in range(rows):
        for j in range(cols):
            for d in range(2):
                u = uniform(key, ctr)
                ctr += _ONE
                state.stuck[d, i, j] = STUCK_LOW if u < lo else (STUCK_HIGH if u < hi else OK)
    for i in range(rows):
        for j in range(cols):
            for d in range(2):
                z1, ctr = normal_at(key, ctr)
                z2, ctr = normal_at(key, ctr)
                s = max(1.0 + P.dw_min_dtod * z1, 0.0)
                a = P.up_down + P.up_down_dtod * z2
                state.step[2 * d, i, j] = max(s * (1.0 + a), 0.0)
                state.step[2 * d + 1, i, j] = max(s * (1.0 - a), 0.0)
    for i in range(rows):
        for j in range(cols):
            for d in range(2):
                z, ctr = normal_at(key, ctr)
                state.nu[d, i, j] = max(P.drift_nu + P.drift_nu_std * z, 0.0)
                state.nu_z[d, i, j] = z
    g_min = P.g_min
    g_max = P.g_max
    g_c = 0.5 * (g_min + g_max)
    half = 0.5 * P.g_per_w
    w_max = P.w_max
    one_sided = P.mapping == ONE_SIDED
    for i in range(rows):
        for j in range(cols):
            w = min(max(W[i, j], -w_max), w_max)
            for d in range(2):
                if one_sided:
                    t = g_min + max(w if d == 0 else -w, 0.0) * P.g_per_w
                else:
                    t = g_c + w * half if d == 0 else g_c - w * half
                G = snap_to_level(t, g_min, g_max, P.dG)
                if P.drift_nu_g != 0:  # from the target, as aihwkit draws it
                    state.nu[d, i, j] = nu_of(G, state.nu_z[d, i, j], P)
                z, ctr = normal_at(key, ctr)
                G += z * prog_sigma(G, P.prog_noise, P.prog_c0, P.prog_c1, P.prog_c2,
                                    P.prog_gref, g_max)
                G = min(max(G, g_min), g_max)
                code = state.stuck[d, i, j]
                if code == STUCK_LOW:
                    G = g_min
                elif code == STUCK_HIGH:
                    G = g_max
                if d == 0:
                    Gp[i, j] = G
                else:
                    Gm[i, j] = G
                state.age[d, i, j] = 0.0
                state.bnd[2 * d, i, j] = g_min
                state.bnd[2 * d + 1, i, j] = g_max
    if P.bound_dtod_up > 0.0 or P.bound_dtod_down > 0.0:
        g0 = g_min + P.step_center * (g_max - g_min)
        for i in range(rows):
            for j in range(cols):
                for d in range(2):
                    zu, ctr = normal_at(key, ctr)
                    zl, ctr = normal_at(key, ctr)
                    ru = min(max(abs(1.0 + P.bound_dtod_up * zu), 1e-3), 1.0)
                    rl = min(max(abs(1.0 + P.bound_dtod_down * zl), 1e-3), 1.0)
                    b_lo = g0 - (g0 - g_min) * rl
                    b_hi = g0 + (g_max - g0) * ru
                    state.bnd[2 * d, i, j] = b_lo
                    state.bnd[2 * d + 1, i, j] = b_hi
                    if state.stuck[d, i, j] != OK:
                        continue
                    if d == 0:
                        Gp[i, j] = min(max(Gp[i, j], b_lo), b_hi)
                    else:
                        Gm[i, j] = min(max(Gm[i, j], b_lo), b_hi)
    state.rng[1] = ctr
    return np.int64(ctr - start)


@kernel
def _calibration_readout(state):
    """The drift-compensation readout through the periphery (aihwkit
    ``GlobalDriftCompensation``): one read per input line with a one-hot input, the mean
    |output| over all of them (at least 1e-4)."""
    rows, cols = state.Gp.shape
    x = state.sbuf[:cols]
    out = state.sbuf[cols:cols + rows]
    total = 0.0
    for j in range(cols):
        for k in range(cols):
            x[k] = 0.0
        x[j] = 1.0
        read(state, x, out, False, -1)
        for i in range(rows):
            total += abs(out[i])
    state.counters[CALIBRATION_READS] += cols
    return max(total / (rows * cols), 1e-4)


@kernel
def xbar_elapse(state, seconds):
    """Let ``seconds`` pass: each unstuck device drifts from its age a to a + seconds,
    G <- G ((a + seconds + t0) / (a + t0))^-nu (= G0 ((t + t0) / t0)^-nu since its last
    write), clipped at g_min; with compensation, alpha *= calibration read before /
    after (``compensation_read`` ideal: the read is sum |G+ - G-|, the array's response
    to a calibration input, taken noise-free; periphery: :func:`_calibration_readout`).

    With accumulated read noise (``rn1f``; also at 0 s), each device's previous draw is
    taken off first, and after the drift one normal per device (row by row, G+ before
    G-, after the calibration read before) gives the new persistent draw."""
    P = state.params
    fresh = P.rn1f > 0.0
    if not (seconds > 0.0 or (fresh and seconds == 0.0)):
        return
    Gp = state.Gp
    Gm = state.Gm
    rows, cols = Gp.shape
    t0 = P.drift_t0
    g_min = P.g_min
    periphery = P.drift_compensation != 0 and P.compensation_read == COMP_PERIPHERY
    before = 0.0
    after = 0.0
    cal_before = 0.0
    if periphery:
        cal_before = _calibration_readout(state)
    key = state.rng[0]
    ctr = state.rng[1]
    start = ctr
    t_read = P.rn1f_t_read
    for i in range(rows):
        for j in range(cols):
            before += abs(Gp[i, j] - Gm[i, j])
            for d in range(2):
                a = state.age[d, i, j]
                state.age[d, i, j] = a + seconds
                if state.stuck[d, i, j] != OK:
                    continue
                G = Gp[i, j] if d == 0 else Gm[i, j]
                if fresh:
                    G = G - state.rn[d, i, j]
                f = ((a + seconds + t0) / (a + t0)) ** (-state.nu[d, i, j])
                G = max(G * f, g_min)
                if fresh:  # q_s of the conductance as written, the std of the drifted one
                    t = a + seconds + t0
                    g_prog = G * (t / t0) ** state.nu[d, i, j]
                    q = min(P.rn1f_q0 / max((abs(g_prog) / P.g_max) ** P.rn1f_qexp, 1e-3),
                            P.rn1f_qmax)
                    sig = P.rn1f * q * math.sqrt(math.log((t + t_read) / (2.0 * t_read)))
                    z, ctr = normal_at(key, ctr)
                    Gn = max(G + abs(G) * sig * z, g_min)
                    state.rn[d, i, j] = Gn - G
                    G = Gn
                if d == 0:
                    Gp[i, j] = G
                else:
                    Gm[i, j] = G
            after += abs(Gp[i, j] - Gm[i, j])
    state.rng[1] = ctr
    state.counters[RNG_DRAWS] += np.int64(ctr - start)
    if periphery:
        state.alpha[0] *= cal_before / _calibration_readout(state)
    elif P.drift_compensation != 0 and after > 0.0:
        state.alpha[0] *= before / after
    state.elapsed[0] += seconds
