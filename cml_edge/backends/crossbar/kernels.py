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

Randomness: one counter-based stream per array, ``uniform(rng[0], c)`` from
:mod:`cml_edge.rng` at the counter c = ``rng[1]``, advanced by one per uniform
drawn. Normal deviates come from those uniforms by the Marsaglia-Tsang ziggurat (256
layers; exact, and ~8x cheaper than the Box-Muller ``rng.normal`` that a read would
otherwise spend most of its time in).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from cml_edge.backends.crossbar.conductance import prog_sigma, snap_to_level
from cml_edge.backends.crossbar.config import BOUNDS, COMMITS, UPDATES
from cml_edge.rng import uniform, unit, word

# choice codes of the parameter record (the index of the value in the config's choices)
UPDATE_ANALOG, UPDATE_PULSED = UPDATES.index("analog"), UPDATES.index("pulsed")
COMMIT_PROGRAM, COMMIT_PULSE = COMMITS.index("program"), COMMITS.index("pulse")
BOUNDS_SOFT = BOUNDS.index("soft")

# counter indices (names in CrossbarArray.counter_names)
MATVECS, RMATVECS, ANALOG_MACS, DAC_CONVERSIONS, ADC_CONVERSIONS, ADC_SATURATIONS = 0, 1, 2, 3, 4, 5
OUTER_UPDATES, ACC_WRITES, LINE_PULSES, COINCIDENCES, DEVICE_PULSES = 6, 7, 8, 9, 10
DEVICES_WRITTEN, COMMITS, RNG_DRAWS = 11, 12, 13
N_COUNTERS = 14

# stuck codes
OK, STUCK_LOW, STUCK_HIGH = 0, 1, 2

_ONE = np.uint64(1)


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


@njit(cache=True)
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


@njit(cache=True)
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


@njit(cache=True)
def _popcount(v):
    n = 0
    while v:
        v &= v - 1
        n += 1
    return n


# reads ---------------------------------------------------------------------------------
@njit(cache=True)
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


@njit(cache=True)
def _convert_inputs(x, xs, n_in, dac):
    """xs = DAC(x / max|x|); returns (max|x|, nonzero inputs, sum xs^2)."""
    xmax = 0.0
    for j in range(n_in):
        a = abs(x[j])
        if a > xmax:
            xmax = a
    if not xmax > 0.0:
        return xmax, 0, 0.0
    inv = 1.0 / xmax
    if dac > 0.0:
        inv_dac = 1.0 / dac
        for j in range(n_in):
            v = x[j] * inv
            xs[j] = math.copysign(math.floor(abs(v) * inv_dac + 0.5), v) * dac
    else:
        for j in range(n_in):
            xs[j] = x[j] * inv
    nnz = 0
    sq = 0.0
    for j in range(n_in):
        v = xs[j]
        nnz += v != 0.0
        sq += v * v
    return xmax, nnz, sq


@njit(cache=True)
def _mac(Gp, Gm, xs, buf, transposed):
    """buf = (G+ - G-) xs, or (G+ - G-)^T xs: the analog sums (micro-siemens)."""
    rows, cols = Gp.shape
    if not transposed:  # W x = sum_j x_j (G+ - G-)[:, j], along contiguous columns
        for i in range(rows):
            buf[i] = 0.0
        for j in range(cols):
            v = xs[j]
            if v != 0.0:
                for i in range(rows):
                    buf[i] += (Gp[i, j] - Gm[i, j]) * v
        return
    for o in range(cols):  # W^T y: one reduction per column, eight partial sums
        s0 = s1 = s2 = s3 = s4 = s5 = s6 = s7 = 0.0
        k = 0
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


@njit(cache=True)
def _convert_outputs(buf, out, n_out, g_min, g_max, adc, bound, sigma, scale, rng):
    """Normalise, add the read noise, ADC (step ``adc``, 0 = ideal; clipping at
    +-``bound``), rescale; returns the saturated outputs."""
    inv_g = 1.0 / (g_max - g_min)
    if sigma > 0.0:
        key = rng[0]
        ctr = rng[1]
        for o in range(n_out):
            z, ctr = normal_at(key, ctr)
            buf[o] = buf[o] * inv_g + sigma * z
        rng[1] = ctr
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


@njit(cache=True, inline="always")
def _read(state, x, out, transposed):
    """out = W x (or W^T x) as the array reads it (module docstring, steps 1-5)."""
    P = state.params
    rows, cols = state.Gp.shape
    n_in = rows if transposed else cols
    n_out = cols if transposed else rows
    xmax, nnz, sq = _convert_inputs(x, state.xbuf, n_in, P.dac_step)
    if not xmax > 0.0:  # no input drives the array: nothing is read
        for i in range(n_out):
            out[i] = 0.0 if xmax == 0.0 else math.nan
        return
    _mac(state.Gp, state.Gm, state.xbuf, state.ybuf, transposed)
    rn = P.read_noise
    on = P.out_noise
    sigma = math.sqrt(2.0 * rn * rn * sq + on * on)
    start = state.rng[1]
    saturated = _convert_outputs(state.ybuf, out, n_out, P.g_min, P.g_max, P.adc_step,
                                 P.adc_bound, sigma, P.w_max * xmax * state.alpha[0],
                                 state.rng)
    c = state.counters
    c[RNG_DRAWS] += np.int64(state.rng[1] - start)
    c[ANALOG_MACS] += nnz * n_out
    c[DAC_CONVERSIONS] += nnz
    c[ADC_CONVERSIONS] += n_out
    c[ADC_SATURATIONS] += saturated


@njit(cache=True, inline="always")
def xbar_matvec(state, x, out):
    _read(state, x, out, False)
    state.counters[MATVECS] += 1


@njit(cache=True, inline="always")
def xbar_rmatvec(state, y, out):
    _read(state, y, out, True)
    state.counters[RMATVECS] += 1


@njit(cache=True, inline="always")
def xbar_sigmoid(state, z, out):
    """The affordance nonlinearity: a digital peripheral function, computed exactly."""
    for i in range(z.shape[0]):
        out[i] = 1.0 / (1.0 + math.exp(-z[i]))


# writes --------------------------------------------------------------------------------
@njit(cache=True)
def _move(g, up, s, z, P):
    """A device at conductance g after one pulse (up or down) of relative size s (1 + c2c z)."""
    g_min = P.g_min
    g_max = P.g_max
    d = P.dG * s * (1.0 + P.dw_min_std * z)
    if P.bounds == BOUNDS_SOFT:
        if up:
            d *= 2.0 * (g_max - g) / (g_max - g_min)
        else:
            d *= 2.0 * (g - g_min) / (g_max - g_min)
    g = g + d if up else g - d
    return min(max(g, g_min), g_max)


@njit(cache=True)
def _pulse_pair(Gp, Gm, step, age, stuck, P, i, j, n, positive, key, ctr):
    """n pulses on pair (i, j): positive raises G+ and lowers G-, else the reverse."""
    noisy = P.dw_min_std != 0.0
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
    age[0, i, j] = 0.0
    age[1, i, j] = 0.0
    return ctr


@njit(cache=True)
def _program_device(G, delta, P, key, ctr):
    """Write-verify a device to the level nearest G + delta, with programming noise."""
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
    return target, ctr


@njit(cache=True)
def _pulsed_update(state, post, pre, lr):
    Gp = state.Gp
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
                ctr = _pulse_pair(Gp, state.Gm, state.step, state.age, state.stuck, P, i, j, n,
                                  (post[i] > 0.0) == (pre[j] > 0.0), key, ctr)
    state.rng[1] = ctr
    c[RNG_DRAWS] += np.int64(ctr - start)
    c[LINE_PULSES] += line_pulses
    c[COINCIDENCES] += coincidences
    c[DEVICE_PULSES] += 2 * coincidences
    c[DEVICES_WRITTEN] += 2 * pairs


@njit(cache=True)
def _analog_update(state, post, pre, lr):
    """The exact change (an ideal device), stochastically rounded to the grid if any."""
    Gp = state.Gp
    Gm = state.Gm
    P = state.params
    rows, cols = Gp.shape
    g_min = P.g_min
    g_max = P.g_max
    dG = P.dG
    half = 0.5 * P.g_per_w
    stuck = state.stuck
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
            if stuck[0, i, j] == OK:
                Gp[i, j] = min(max(Gp[i, j] + d, g_min), g_max)
            if stuck[1, i, j] == OK:
                Gm[i, j] = min(max(Gm[i, j] - d, g_min), g_max)
            state.age[0, i, j] = 0.0
            state.age[1, i, j] = 0.0
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
        for j in range(cols):  # column-major: along columns, skipping zero pre factors
            q = pre[j]
            if q == 0.0:
                continue
            touched += rows
            for i in range(rows):
                acc[i, j] += (lr * post[i]) * q
        c[ACC_WRITES] += touched
    elif state.params.update == UPDATE_PULSED:
        _pulsed_update(state, post, pre, lr)
    else:
        _analog_update(state, post, pre, lr)


@njit(cache=True)
def _commit(state):
    Gp = state.Gp
    Gm = state.Gm
    acc = state.acc
    P = state.params
    stuck = state.stuck
    rows, cols = Gp.shape
    dw_min = P.dw_min
    dG = P.dG
    half = 0.5 * P.g_per_w
    pulse = P.commit == COMMIT_PULSE
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
            written += 2
            if pulse:
                pulses += 2 * abs(n)
                ctr = _pulse_pair(Gp, Gm, state.step, state.age, state.stuck, P, i, j, abs(n),
                                  n > 0, key, ctr)
                continue
            if stuck[0, i, j] == OK:
                Gp[i, j], ctr = _program_device(Gp[i, j], delta, P, key, ctr)
            if stuck[1, i, j] == OK:
                Gm[i, j], ctr = _program_device(Gm[i, j], -delta, P, key, ctr)
            state.age[0, i, j] = 0.0
            state.age[1, i, j] = 0.0
    state.rng[1] = ctr
    c = state.counters
    c[RNG_DRAWS] += np.int64(ctr - start)
    c[DEVICE_PULSES] += pulses
    c[LINE_PULSES] += 2 * pulses  # a serial programming pulse drives one row and one column
    c[DEVICES_WRITTEN] += written


@njit(cache=True, inline="always")
def xbar_commit(state):
    state.counters[COMMITS] += 1
    _commit(state)


# construction and time -----------------------------------------------------------------
@njit(cache=True)
def xbar_program(state, W):
    """Draw the per-device constants and program W (the array's construction).

    Draw order, all from the array's stream, and always the same number of normals
    whatever the parameters, so that sweeps compare the same devices: a uniform per
    device for stuck-at faults (stuck low if u < f_low, high if u < f_low + f_high);
    two normals per device for its pulse-step scale (1 + dtod z1, clipped at 0) and
    asymmetry (up_down + up_down_dtod z2); one normal per device for nu (clipped at 0);
    one normal per device for the programming noise. Devices are visited row by row,
    G+ before G-.
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
    g_min = P.g_min
    g_max = P.g_max
    g_c = 0.5 * (g_min + g_max)
    half = 0.5 * P.g_per_w
    w_max = P.w_max
    for i in range(rows):
        for j in range(cols):
            w = min(max(W[i, j], -w_max), w_max)
            for d in range(2):
                G = snap_to_level(g_c + w * half if d == 0 else g_c - w * half, g_min, g_max,
                                  P.dG)
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
    state.rng[1] = ctr
    return np.int64(ctr - start)


@njit(cache=True)
def xbar_elapse(state, seconds):
    """Let ``seconds`` pass: each unstuck device drifts from its age a to a + seconds,
    G <- G ((a + seconds + t0) / (a + t0))^-nu (= G0 ((t + t0) / t0)^-nu since its last
    write), clipped at g_min; with compensation, alpha *= calibration read before /
    after (the read is sum |G+ - G-|, i.e. the array's response to a calibration input,
    taken noise-free)."""
    if not seconds > 0.0:
        return
    Gp = state.Gp
    Gm = state.Gm
    P = state.params
    rows, cols = Gp.shape
    t0 = P.drift_t0
    g_min = P.g_min
    before = 0.0
    after = 0.0
    for i in range(rows):
        for j in range(cols):
            before += abs(Gp[i, j] - Gm[i, j])
            for d in range(2):
                a = state.age[d, i, j]
                state.age[d, i, j] = a + seconds
                if state.stuck[d, i, j] != OK:
                    continue
                f = ((a + seconds + t0) / (a + t0)) ** (-state.nu[d, i, j])
                if d == 0:
                    Gp[i, j] = max(Gp[i, j] * f, g_min)
                else:
                    Gm[i, j] = max(Gm[i, j] * f, g_min)
            after += abs(Gp[i, j] - Gm[i, j])
    if P.drift_compensation != 0 and after > 0.0:
        state.alpha[0] *= before / after
    state.elapsed[0] += seconds
