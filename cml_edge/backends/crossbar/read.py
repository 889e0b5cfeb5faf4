"""The crossbar's read path: DAC, analog multiply-accumulate, read noise, ADC, bound
management.

Read, W x (W^T y the same way on the same conductances, with the roles of the lines
swapped: the transposed read of planning):

1. the input is divided by max|x| (aihwkit's ABS_MAX noise management) and quantised
   by the DAC (``dac_bits``; :func:`_quantise_inputs`);
2. the analog sum over the devices, y_i = sum_j (G+_ij - G-_ij) x_j, in micro-siemens
   (:func:`_mac`; G- the fixed reference of a ``single`` device), normalised by the
   conductance range (so that a weight of w_max reads as 1 on a pair, 1/2 on a single);
3. read noise, fresh on every read: each device's conductance fluctuates by
   N(0, (read_noise (g_max - g_min))^2) during the read, which puts exactly
   N(0, 2 read_noise^2 sum_j x_j^2) on each normalised output (1 read_noise^2 on a
   single device, whose reference is exact; a sum of independent
   Gaussians; drawn as one normal per output), plus the output noise N(0, out_noise^2),
   plus, with ``read_noise_pcm`` (PCM_READ), N(0, read_noise_pcm^2 sum_j |w_ij| x_j^2)
   (:func:`_abs_w_x2`, :func:`_add_noise`);
4. the ADC clips at +-adc_bound (counted) and quantises (``adc_bits``;
   :func:`_convert_outputs`);
5. the digital periphery multiplies by the full swing's weight (w_max; 2 w_max on a
   single device: :func:`~cml_edge.backends.crossbar.conductance.swing`) max|x| and,
   after drift compensation, by
   the array's compensation factor alpha (``state.alpha[0]``).

With ``bound_management``, a read with a saturated output is repeated with the input
halved (aihwkit ITERATIVE), up to ``bm_passes`` passes, each with fresh noise; the last
is kept (:func:`_read`).

The normals come from :func:`cml_edge.jit.gauss.normals`, one per output in output
order. Speed, none of which moves a bit (``tests/backends/test_references.py`` holds
every read to the plain loops of :mod:`cml_edge.backends.crossbar.reference`): the
inputs that drive the array are marked in bit masks (``driven``) that a sparse read
visits; a short matrix sums its rows as vector lanes and a transposed read its eight
partial sums (:mod:`cml_edge.jit.simd`).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numba.cpython.unsafe.numbers import trailing_zeros

from cml_edge.backends.crossbar.codes import (
    ADC_CONVERSIONS,
    ADC_SATURATIONS,
    ANALOG_MACS,
    BM_REREADS,
    DAC_CONVERSIONS,
    RNG_DRAWS,
)
from cml_edge.backends.crossbar.conductance import swing
from cml_edge.backends.quant import max_abs
from cml_edge.jit.gauss import normals
from cml_edge.jit.kernel import kernel
from cml_edge.jit.simd import band_sums, lane_sums, nonzero_masks

_ONE = np.uint64(1)

BAND_ROWS = 16
"""A forward read of at most this many rows sums them as vector lanes (:func:`_mac`); a
taller one (W_q, W_v) as one axpy per nonzero column, which skips the zero inputs of a
one-hot read once for all rows."""
SPARSE_READ = 8
"""A forward read with at most 1 in this many inputs nonzero (the grid's one-hot and
two-hot observations) visits their columns from the DAC's masks instead of testing every
input (:func:`_mac`)."""


# 1. the DAC ----------------------------------------------------------------------------
@kernel
def _convert_inputs(x, xs, n_in, dac, need_sq, driven):
    """xs = DAC(x / max|x|) (:func:`_quantise_inputs`); returns (max|x|, nonzero inputs,
    sum xs^2 if ``need_sq``)."""
    xmax = max_abs(x, n_in)[0]
    if not xmax > 0.0:
        return xmax, 0, 0.0
    nnz, sq = _quantise_inputs(x, xs, n_in, dac, 1.0 / xmax, need_sq, driven)
    return xmax, nnz, sq


@kernel
def _quantise_inputs(x, xs, n_in, dac, inv, need_sq, driven):
    """xs = DAC(x inv), and ``driven`` the bit masks of the xs[j] != 0 (the inputs that
    drive the array, which :func:`_mac` visits); returns (nonzero inputs, sum xs^2 in
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
    nnz = nonzero_masks(xs, n_in, driven)
    sq = 0.0
    if need_sq:
        for b in range((n_in + 63) >> 6):
            m = np.uint64(driven[b])
            while m != 0:
                j = (b << 6) + np.int64(trailing_zeros(m))
                m &= m - _ONE
                sq += xs[j] * xs[j]
    return nnz, sq


# 2. the analog sums --------------------------------------------------------------------
@kernel
def _mac(Gp, Gm, xs, sums, transposed, driven, nnz):
    """sums = (G+ - G-) xs, or (G+ - G-)^T xs: the analog sums (micro-siemens).

    W x sums each output over the columns of the nonzero inputs, in order. With at most
    :data:`BAND_ROWS` rows (W_k's 8), the rows are summed as vector lanes
    (:func:`cml_edge.jit.simd.band_sums`: the same operations in the same order); otherwise
    as one axpy per driven column, found from the DAC's masks ``driven`` when there are
    few (``nnz``, :data:`SPARSE_READ`). W^T y sums each output in eight interleaved partial
    sums (:func:`cml_edge.jit.simd.lane_sums`), then the rows left over, then the eight."""
    rows, cols = Gp.shape
    if not transposed and rows <= BAND_ROWS and Gp.strides[0] == 8 and Gm.strides[0] == 8:
        i0 = 0
        while i0 + 8 <= rows:
            band_sums(Gp, Gm, xs, sums, i0, 8)
            i0 += 8
        if i0 + 4 <= rows:
            band_sums(Gp, Gm, xs, sums, i0, 4)
            i0 += 4
        if i0 + 2 <= rows:
            band_sums(Gp, Gm, xs, sums, i0, 2)
            i0 += 2
        if i0 < rows:
            band_sums(Gp, Gm, xs, sums, i0, 1)
        return
    if not transposed:  # W x = sum_j x_j (G+ - G-)[:, j], along contiguous columns
        for i in range(rows):
            sums[i] = 0.0
        if nnz * SPARSE_READ > cols:  # most inputs drive the array
            for j in range(cols):
                v = xs[j]
                if v != 0.0:
                    for i in range(rows):
                        sums[i] += (Gp[i, j] - Gm[i, j]) * v
            return
        for b in range((cols + 63) >> 6):  # a few inputs (one-hot): their columns in order
            m = np.uint64(driven[b])
            while m != 0:
                j = (b << 6) + np.int64(trailing_zeros(m))
                m &= m - _ONE
                v = xs[j]
                for i in range(rows):
                    sums[i] += (Gp[i, j] - Gm[i, j]) * v
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
        sums[o] = ((s0 + s1) + (s2 + s3)) + ((s4 + s5) + (s6 + s7))


# 3. the read noise ---------------------------------------------------------------------
@kernel
def _abs_w_x2(Gp, Gm, xs, var, transposed, inv_g):
    """var_i = sum_j |G+ - G-|_ij / range xs_j^2 (or over the rows, transposed): the
    variance of the PCM_READ per-read noise over read_noise_pcm^2."""
    rows, cols = Gp.shape
    if not transposed:
        for i in range(rows):
            var[i] = 0.0
        for j in range(cols):
            v = xs[j] * xs[j]
            if v != 0.0:
                for i in range(rows):
                    var[i] += abs(Gp[i, j] - Gm[i, j]) * inv_g * v
        return
    for o in range(cols):
        s = 0.0
        for k in range(rows):
            s += abs(Gp[k, o] - Gm[k, o]) * inv_g * (xs[k] * xs[k])
        var[o] = s


@kernel
def _add_noise(sums, var, n_out, inv_g, sigma, wn, rng, z, rejected):
    """sums[o] = sums[o] inv_g + s_o z_o for every output o, z_o the o-th normal from the
    stream's counter on (:func:`cml_edge.jit.gauss.normals`, into ``z``, with the
    ``rejected`` masks), s_o = sigma, or sqrt(sigma^2 + wn^2 var[o]) when wn > 0
    (PCM_READ); advances the counter past the draws."""
    rng[1] = normals(rng[0], rng[1], z, n_out, rejected)
    if wn > 0.0:
        b2 = sigma * sigma
        w2 = wn * wn
        for o in range(n_out):
            sums[o] = sums[o] * inv_g + math.sqrt(b2 + w2 * var[o]) * z[o]
    else:
        for o in range(n_out):
            sums[o] = sums[o] * inv_g + sigma * z[o]


# 4. and 5. the ADC and the periphery -----------------------------------------------------
@kernel
def _convert_outputs(sums, var, out, n_out, g_min, g_max, adc, bound, sigma, wn, scale, rng,
                     z, rejected):
    """Normalise, add the read noise (:func:`_add_noise`; none when sigma and wn are 0),
    ADC (step ``adc``, 0 = ideal; clipping at +-``bound``), rescale; returns the saturated
    outputs."""
    inv_g = 1.0 / (g_max - g_min)
    if sigma > 0.0 or wn > 0.0:
        _add_noise(sums, var, n_out, inv_g, sigma, wn, rng, z, rejected)
    else:
        for o in range(n_out):
            sums[o] = sums[o] * inv_g
    saturated = 0
    if adc > 0.0:
        inv_adc = 1.0 / adc
        lsb = adc * scale
        for o in range(n_out):
            v = sums[o]
            saturated += abs(v) > bound
            v = min(max(v, -bound), bound)
            out[o] = math.copysign(math.floor(abs(v) * inv_adc + 0.5), v) * lsb
    else:
        for o in range(n_out):
            out[o] = sums[o] * scale
    return saturated


# the whole read ------------------------------------------------------------------------
@kernel
def _read(Gp, Gm, xbuf, ybuf, vbuf, driven, zbuf, rejected, rng, alpha, counters, P, x, out,
          transposed, kind):
    """out = W x (or W^T x) as the array reads it (module docstring, steps 1-5, and the
    bound management's re-reads), counted as a read of ``kind`` (a counter index; -1: a
    calibration read, counted by its caller). The state's arrays come as arguments: a
    :func:`~cml_edge.jit.kernel.kernel` pays no reference counts for them (compiled with
    reference counting, reading them from the state tuple paid their counts at every
    read)."""
    if kind >= 0:
        counters[kind] += 1
    rows, cols = Gp.shape
    n_in = rows if transposed else cols
    n_out = cols if transposed else rows
    rn = P.read_noise
    on = P.out_noise
    xmax, nnz, sq = _convert_inputs(x, xbuf, n_in, P.dac_step, rn != 0.0, driven)
    if not xmax > 0.0:  # no input drives the array: nothing is read
        for i in range(n_out):
            out[i] = 0.0 if xmax == 0.0 else math.nan
        return
    div = xmax
    passes = 0
    while True:
        if passes > 0:  # a re-read: the input halved again (aihwkit ITERATIVE)
            div = div * 2.0
            nnz, sq = _quantise_inputs(x, xbuf, n_in, P.dac_step, 1.0 / div, rn != 0.0,
                                       driven)
            counters[BM_REREADS] += 1
        _mac(Gp, Gm, xbuf, ybuf, transposed, driven, nnz)
        w_swing, noisy = swing(P)
        sigma = math.sqrt(noisy * rn * rn * sq + on * on)
        start = rng[1]
        scale = w_swing * div * alpha[0]
        if P.read_noise_pcm > 0.0:
            _abs_w_x2(Gp, Gm, xbuf, vbuf, transposed, 1.0 / (P.g_max - P.g_min))
        saturated = _convert_outputs(ybuf, vbuf, out, n_out, P.g_min, P.g_max, P.adc_step,
                                     P.adc_bound, sigma, P.read_noise_pcm, scale, rng, zbuf,
                                     rejected)
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
    _read(state.Gp, state.Gm, state.xbuf, state.ybuf, state.vbuf, state.driven, state.zbuf,
          state.rejected, state.rng, state.alpha, state.counters, state.params, x, out,
          transposed, kind)

