"""The crossbar's write path: pulses, step models, cycle-to-cycle and write noise,
refresh, write-verify; the updates and the commit built from them.

Update, W += lr post pre^T:

- per walk (``defer``): lr post pre^T is added to a digital float64 accumulator
  (``acc``; :func:`accumulate`); the commit (:func:`commit_accumulated`) then, by
  ``commit`` mode, sends n = trunc(acc / dw_min) programming pulses to each pair (at most
  ``pulse_cap``, :data:`~cml_edge.backends.crossbar.config.PULSE_CAP_SWEEPS`; the excess is
  dropped and counted) and keeps the remainder in the accumulator (mixed precision), or
  write-verifies each pair whose target moved, drawing fresh programming noise for it
  (:func:`_program_device`);
- in place (not ``defer``), ``pulsed`` (:func:`pulsed_update`): the stochastic
  coincidence update of Gokmen & Vlasov (2016). BL = min(ceil(lr max|x| max|d| / dw_min),
  bl_max) slots; column j fires in each slot with probability A |x_j|, row i with
  B |d_i|, A = sqrt(lr / (dw_min BL)) sqrt(max|d| / max|x|), B = sqrt(lr / (dw_min BL))
  sqrt(max|x| / max|d|); each coincidence moves pair (i, j) one nominal step dw_min in
  the direction sign(x_j d_i) (G+ up and G- down, or the reverse), so
  E[dw_ij] = BL (A|x_j|)(B|d_i|) dw_min = lr x_j d_i. ``analog``
  (:func:`analog_update`): the exact change (an ideal device; stochastically rounded to
  the grid when there is one).

A pulse moves a device by dG s (1 + dw_min_std z) (:func:`_move`), dG the level
spacing (or ``pulse_step`` of the range: ``P.dP``), s the device's fixed up or down
scale (device-to-device spread and up/down asymmetry), z ~ N(0, 1) fresh per pulse; soft
bounds scale it by 2 (g_max - G) / (g_max - g_min) going up, 2 (G - g_min) / (g_max -
g_min) going down. Every write clips
a device to [g_min, g_max]; stuck devices never change. Only devices actually pulsed or
programmed are written (and get write noise); a write restarts the device's drift clock
(:func:`cml_edge.backends.crossbar.time.mark_written`).

Calibrated physics (each off at its config default, and then the code paths and draws
above are exactly those of earlier releases): a ``one-sided`` mapping programs one device
of a pair to g_min; a ``set_only`` pair sends each pulse to one device, up (G+ to raise
w, G- to lower it), and a ``refresh`` pair that saturates is RESET and its difference
write-verified onto the larger device (:func:`_refresh_pair`); ``step_model`` gives the
step's dependence on G (:func:`step_factor`) between the device's own bounds ``bnd``
and ``c2c`` its cycle-to-cycle noise (:func:`_move_model`); ``write_noise`` reads a
pulsed device as its hidden state plus a fresh offset (``wn``; :func:`_pulse_device`).
aihwkit's own behaviours (``--preset aihwkit:NAME``): a reference offset of each device's
internal state, per-device linear-step slopes (``aux``), a decay after every mini-batch
(:func:`_decay_sweep`) and aihwkit's refresh of one-sided pairs (:func:`_refresh_columns`).

Draw order (the array's stream): per pulse and device, the c2c normal then the
write-noise normal; a refresh's programming noise after its pair's pulses; a pulsed
update draws the column trains (column by column, each slot by slot), then each row's
train followed by the pulses of that row's coincidences, column by column; an analog
update one uniform per cell with both factors nonzero, row by row; a commit visits the
pairs row by row.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from cml_edge.backends.crossbar.codes import (
    ACC_WRITES,
    AUX_DECAY,
    AUX_GAMMA_DOWN,
    AUX_GAMMA_UP,
    AUX_PLANES,
    AUX_REF,
    AUX_RESET,
    BOUND_INWARD,
    BOUNDS_SOFT,
    C2C_ADD,
    C2C_MULT,
    COINCIDENCES,
    COMMIT_PULSE,
    DEVICE_PULSES,
    DEVICES_WRITTEN,
    LINE_PULSES,
    OK,
    ONE_SIDED,
    PAIR_GRID,
    PULSES_CAPPED,
    REFRESH_AIHWKIT,
    REFRESH_OPEN,
    REFRESH_PULSES,
    REFRESH_VERIFY,
    REFRESHES,
    RNG_DRAWS,
    SET_GAUSS,
    SINGLE,
    STEP_BOUNDS,
    STEP_EXP,
    STEP_LINEAR,
    STEP_POW,
    STEP_SOFT,
    TWO_SIDED,
)
from cml_edge.backends.crossbar.conductance import pair_targets, prog_sigma, snap_to_level
from cml_edge.backends.crossbar.config import REFRESH_READ_SIGMAS
from cml_edge.backends.crossbar.time import has_reference, mark_written
from cml_edge.jit.gauss import normal_at
from cml_edge.jit.kernel import kernel
from cml_edge.jit.rng import uniform
from cml_edge.jit.simd import popcount

_ONE = np.uint64(1)


# pulses --------------------------------------------------------------------------------
@njit(cache=True, inline="always")
def _pulse_train(p, bl, key, ctr):
    """A stochastic pulse train of ``bl`` slots, each fired with probability min(p, 1).

    Returns the train as a bitmask (bit t = slot t) and the advanced draw counter; a
    line with p == 0 draws nothing.
    """
    b = 0
    if p != 0.0:
        p = min(p, 1.0)
        for t in range(bl):  # branch-free: a slot fires at random, so a branch mispredicts
            b |= np.int64(uniform(key, ctr + np.uint64(t)) < p) << t
        ctr += np.uint64(bl)
    return b, ctr



@njit(cache=True, inline="always")
def devices_pulsed(P):
    """The devices one coincidence pulses: both of a two-sided or one-sided pair, one of a
    SET-only pair or a ``single`` mapping."""
    return 1 if P.set_only or P.mapping == SINGLE else 2


@njit(cache=True, inline="always")
def _move(g, up, s, z, P):
    """A device at conductance g after one pulse (up or down) of relative size s (1 + c2c z)
    (step_model ``bounds``, the model of earlier releases)."""
    g_min = P.g_min
    g_max = P.g_max
    d = P.dP * s * (1.0 + P.dw_min_std * z)
    if P.bounds == BOUNDS_SOFT:  # (values selected by up, never a branch: up is random)
        d *= 2.0 * ((g_max - g) if up else (g - g_min)) / (g_max - g_min)
    if P.set_only and d < 0.0:  # a SET pulse never lowers G
        d = 0.0
    g = g + (d if up else -d)  # (g - d exactly)
    return min(max(g, g_min), g_max)


@njit(cache=True, inline="always")
def weight_zero(lo, hi, P):
    """G0, the conductance of a device's weight zero: lo + step_center (hi - lo) of its own
    bounds (``bound_spread`` inward), or the nominal g_min + step_center (g_max - g_min)
    that its bounds spread around (symmetric, aihwkit: aihwkit measures w from 0)."""
    if P.bound_spread != BOUND_INWARD:
        return P.g_min + P.step_center * (P.g_max - P.g_min)
    return lo + P.step_center * (hi - lo)


@njit(cache=True, inline="always")
def step_factor(g, up, lo, hi, gu, gd, P):
    """The mean step of one pulse at conductance g, in units of the device's nominal step
    s dG (``step_model`` of :class:`~cml_edge.backends.crossbar.config.DeviceConfig`;
    lo / hi the device's bounds, gu / gd its ``linear`` slopes); never negative but
    for a ``soft`` device with a reference (``reference_*``), as aihwkit's."""
    m = P.step_model
    span = hi - lo
    if not span > 0.0:
        return 0.0
    g0 = weight_zero(lo, hi, P)
    if m in (STEP_LINEAR, STEP_SOFT):
        if P.mean_bound_reference and m == STEP_LINEAR:  # aihwkit: slopes on the nominal
            ref_hi = P.g_max  # bounds
            ref_lo = P.g_min
        else:
            ref_hi = hi
            ref_lo = lo
        gamma = (gu if up else gd) if m == STEP_LINEAR else 1.0
        f = 1.0 - gamma * (g - g0) / ((ref_hi if up else ref_lo) - g0)
    elif m == STEP_EXP:
        if P.bound_spread != BOUND_INWARD:
            zz = 2.0 * P.exp_a * ((g - g0) / span) + P.exp_b
        else:
            zz = 2.0 * P.exp_a * ((g - lo) / span - P.step_center) + P.exp_b
        f = 1.0 - (P.exp_a_up if up else P.exp_a_down) * math.exp(
            (P.exp_gamma_up if up else -P.exp_gamma_down) * zz)
    elif m == STEP_POW:
        r = ((hi - g) if up else (g - lo)) / span
        f = r ** P.pow_gamma if r > 0.0 else 0.0
    elif P.bounds == BOUNDS_SOFT:
        f = 2.0 * ((P.g_max - g) if up else (g - P.g_min)) / (P.g_max - P.g_min)
    else:
        f = 1.0
    if m == STEP_SOFT and has_reference(P):  # aihwkit's reference device: an internal
        return f  # state past its bound (a reference) steps back toward it
    return max(f, 0.0)


@njit(cache=True, inline="always")
def _move_model(g, up, s, z, lo, hi, gu, gd, P):
    """A device at g after one pulse of nominal size s dG under ``step_model`` and ``c2c``
    (module docstring), clipped to its bounds [lo, hi]; gu / gd its ``linear`` slopes."""
    dG = P.dP
    f = step_factor(g, up, lo, hi, gu, gd, P)
    step = dG * s * f
    c = P.c2c
    if c == C2C_MULT:
        sd = P.dw_min_std * step
    elif c == C2C_ADD:
        sd = P.dw_min_std * dG * s
    else:
        g0 = weight_zero(lo, hi, P)
        sd = P.dw_min_std * (step + P.c2c_add * (P.g_max - P.g_min)
                             + P.c2c_slope * abs(g - g0))
    if P.set_only and P.set_noise != SET_GAUSS:
        # a SET pulse never lowers G: the step is log-normal with the model's mean and std
        d = 0.0
        if step > 0.0:
            cv = sd / step
            v = math.log1p(cv * cv)
            d = step * math.exp(math.sqrt(v) * z - 0.5 * v)
    else:
        d = step + sd * z
    g = g + (d if up else -d)
    return min(max(g, lo), hi)


@njit(cache=True, inline="always")
def _pulse_device(P, step, wn, bnd, aux, G, d, i, j, up, z, w):
    """Device d of pair (i, j), at apparent conductance G, after one pulse; with write
    noise, the pulse moves the hidden state G - wn and a fresh offset w write_noise dG
    is read on top of it; with a reference, it moves the internal state h + ref (aihwkit
    ``SoftBoundsReferenceRPUDevice``: w += ref, the step, the bounds, w -= ref)."""
    s = step[2 * d + 1 - np.int64(up), i, j]  # (an index, not a branch: up is random)
    h = G - wn[d, i, j] if P.write_noise > 0.0 else G
    if P.step_model == STEP_BOUNDS:
        h = _move(h, up, s, z, P)
    else:
        k = AUX_PLANES * d
        gu = P.gamma_up
        gd = P.gamma_down
        if P.gamma_up_dtod > 0.0 or P.gamma_down_dtod > 0.0:
            gu = aux[k + AUX_GAMMA_UP, i, j]
            gd = aux[k + AUX_GAMMA_DOWN, i, j]
        lo = bnd[2 * d, i, j]
        hi = bnd[2 * d + 1, i, j]
        if has_reference(P):
            ref = aux[k + AUX_REF, i, j]
            h = _move_model(h + ref, up, s, z, lo, hi, gu, gd, P) - ref
        else:
            h = _move_model(h, up, s, z, lo, hi, gu, gd, P)
    if P.write_noise > 0.0:
        G = h + P.write_noise * P.dP * w
        if P.write_noise_clip:
            G = min(max(G, P.g_min), P.g_max)
        wn[d, i, j] = G - h
        return G
    return h


@njit(cache=True, inline="always")
def _pulse_device_n(P, step, wn, bnd, aux, G, live, d, i, j, up, n, key, ctr):
    """Device d of pair (i, j), at G, after n pulses (up or down); per pulse the c2c
    normal (if ``dw_min_std``) then the write-noise normal (if ``write_noise``), drawn
    whether or not the device is ``live`` (not stuck). Returns (G, the counter)."""
    for _ in range(n):
        z = 0.0
        w = 0.0
        if P.dw_min_std != 0.0:
            z, ctr = normal_at(key, ctr)
        if P.write_noise > 0.0:
            w, ctr = normal_at(key, ctr)
        if live:
            G = _pulse_device(P, step, wn, bnd, aux, G, d, i, j, up, z, w)
    return G, ctr



@kernel
def set_pulses(target, P):
    """SET pulses the mean device (s = 1, no noise, nominal bounds) needs from g_min to
    ``target``: what a refresh's write-verify costs (at most 100,000)."""
    if not P.dP > 0.0:
        return 0
    g = P.g_min
    n = 0
    while g < target and n < 100000:
        g2 = min(g + P.dP * step_factor(g, True, P.g_min, P.g_max, P.gamma_up, P.gamma_down, P),
                 P.g_max)
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
        mark_written(age, rn, nu, nu_z, P, d, i, j, target)
    counters[REFRESHES] += 1
    counters[REFRESH_PULSES] += pulses
    return ctr


@kernel
def _refresh_sweep(Gp, Gm, stuck, step, bnd, wn, aux, age, rn, nu, nu_z, c, P, key, ctr):
    """The open-loop refresh (``refresh_write`` open-loop): every pair read, device by
    device with noise; a pair whose reads cross the thresholds is RESET and the read
    difference written onto the device that read larger by one stochastic train pair.
    Draws, pair by pair, row by row, for the pairs near enough to the thresholds to
    cross them (:data:`~cml_edge.backends.crossbar.config.REFRESH_READ_SIGMAS`): the two
    read normals (G+, G-); for a refreshed pair
    the row train, the column train, then per pulse the c2c and write-noise normals."""
    rows, cols = Gp.shape
    rng = P.g_max - P.g_min
    sd = P.refresh_read_noise * rng
    near_up = P.g_min + P.refresh_upper * rng - REFRESH_READ_SIGMAS * sd
    near_lo = P.g_min + P.refresh_lower * rng - REFRESH_READ_SIGMAS * sd
    for i in range(rows):
        for j in range(cols):
            if not (max(Gp[i, j], Gm[i, j]) > near_up and min(Gp[i, j], Gm[i, j]) > near_lo):
                continue  # too far from the thresholds to be read across them
            zp, ctr = normal_at(key, ctr)
            zm, ctr = normal_at(key, ctr)
            rp = Gp[i, j] + sd * zp
            rm = Gm[i, j] + sd * zm
            up_ = (rp - P.g_min) / rng
            um = (rm - P.g_min) / rng
            if not (max(up_, um) > P.refresh_upper and min(up_, um) > P.refresh_lower):
                continue
            big = 0 if rp > rm else 1
            diff = abs(rp - rm)
            for d in range(2):
                if stuck[d, i, j] == OK:
                    if d == 0:
                        Gp[i, j] = P.g_min
                    else:
                        Gm[i, j] = P.g_min
                    wn[d, i, j] = 0.0
            bl = max(1, min(int(math.ceil(diff / P.dP)), P.bl_max))
            p = math.sqrt(diff / (P.dP * bl))
            a, ctr = _pulse_train(p, bl, key, ctr)
            b, ctr = _pulse_train(p, bl, key, ctr)
            n = popcount(a & b)
            G, ctr = _pulse_device_n(P, step, wn, bnd, aux, Gp[i, j] if big == 0 else Gm[i, j],
                                     stuck[big, i, j] == OK, big, i, j, True, n, key, ctr)
            if big == 0:
                Gp[i, j] = G
            else:
                Gm[i, j] = G
            mark_written(age, rn, nu, nu_z, P, 0, i, j, Gp[i, j])
            mark_written(age, rn, nu, nu_z, P, 1, i, j, Gm[i, j])
            c[REFRESHES] += 1
            c[REFRESH_PULSES] += 2 + n
    return ctr


@njit(cache=True, inline="always")
def _refresh_read(G, z, sd, q, P):
    """The ``aihwkit`` refresh's read of a device at G: G0 plus (G - G0 + sd z) rounded to
    the refresh ADC's step q (none where q is 0)."""
    v = G + sd * z
    if q > 0.0:
        g0 = P.g_min + P.step_center * (P.g_max - P.g_min)
        v = g0 + math.floor((v - g0) / q + 0.5) * q
    return v


@kernel
def _refresh_columns(Gp, Gm, stuck, step, bnd, wn, aux, age, rn, nu, nu_z, c, P, key, ctr,
                     flag, diff):
    """The ``aihwkit`` refresh (``refresh_write``; aihwkit
    ``OneSidedRPUDevice::refreshWeights``), column by column. Draws: the pairs near enough
    to the thresholds to be read across them (:data:`~cml_edge.backends.crossbar.config.
    REFRESH_READ_SIGMAS` stds and a read step) read G+ then G-, row by row; the crossing
    pairs' G+ RESET, row by row, then their G- (a normal each where ``reset_std``); then
    the pulsed update onto G+: the column train, then per pair its row train and its
    pulses' normals, row by row; then onto G-. ``flag`` (int) and ``diff`` are work space
    of one entry per row."""
    rows, cols = Gp.shape
    grange = P.g_max - P.g_min
    sd = P.refresh_read_noise * grange
    q = P.refresh_read_step * grange
    margin = REFRESH_READ_SIGMAS * sd + q
    near_up = P.g_min + P.refresh_upper * grange - margin
    near_lo = P.g_min + P.refresh_lower * grange - margin
    gran = P.pulse_gain * P.dP  # aihwkit's weight granularity, in uS
    for j in range(cols):
        dmax_p = 0.0
        dmax_m = 0.0
        found = False
        for i in range(rows):
            flag[i] = 0
            if not (max(Gp[i, j], Gm[i, j]) > near_up and min(Gp[i, j], Gm[i, j]) > near_lo):
                continue
            zp, ctr = normal_at(key, ctr)
            zm, ctr = normal_at(key, ctr)
            rp = _refresh_read(Gp[i, j], zp, sd, q, P)
            rm = _refresh_read(Gm[i, j], zm, sd, q, P)
            up_ = (rp - P.g_min) / grange
            um = (rm - P.g_min) / grange
            if not (max(up_, um) > P.refresh_upper and min(up_, um) > P.refresh_lower):
                continue
            diff[i] = abs(rp - rm)
            found = True
            if rp > rm:
                flag[i] = 1
                dmax_p = max(dmax_p, diff[i])
            else:
                flag[i] = 2
                dmax_m = max(dmax_m, diff[i])
        if not found:
            continue
        for d in range(2):  # RESET: G+ of every crossing pair, then G-
            for i in range(rows):
                if flag[i] == 0:
                    continue
                z = 0.0
                if P.reset_std > 0.0:
                    z, ctr = normal_at(key, ctr)
                if stuck[d, i, j] != OK:
                    continue
                lo = bnd[2 * d, i, j]
                hi = bnd[2 * d + 1, i, j]
                b = aux[AUX_PLANES * d + AUX_RESET, i, j] if P.reset_dtod > 0.0 else \
                    P.reset * grange
                G = min(max(weight_zero(lo, hi, P) + b + P.reset_std * grange * z, lo), hi)
                if d == 0:
                    Gp[i, j] = G
                else:
                    Gm[i, j] = G
                wn[d, i, j] = 0.0
        for d in range(2):  # the write: a pulsed update of the column onto G+, then G-
            dmax = dmax_p if d == 0 else dmax_m
            if not dmax > 0.0:
                continue
            k = dmax / gran
            bl = max(1, min(int(math.ceil(k)), P.bl_max))
            dval = dmax * P.bl_max / k if k > P.bl_max else dmax
            a, ctr = _pulse_train(math.sqrt(dval / (gran * bl)), bl, key, ctr)
            scale = 1.0 / math.sqrt(dval * gran * bl)
            for i in range(rows):
                if flag[i] != d + 1:
                    continue
                b, ctr = _pulse_train(diff[i] * scale, bl, key, ctr)
                n = popcount(a & b)
                G, ctr = _pulse_device_n(P, step, wn, bnd, aux, Gp[i, j] if d == 0 else Gm[i, j],
                                         stuck[d, i, j] == OK, d, i, j, True, n, key, ctr)
                if d == 0:
                    Gp[i, j] = G
                else:
                    Gm[i, j] = G
                c[REFRESH_PULSES] += n
        for i in range(rows):
            if flag[i] != 0:
                mark_written(age, rn, nu, nu_z, P, 0, i, j, Gp[i, j])
                mark_written(age, rn, nu, nu_z, P, 1, i, j, Gm[i, j])
                c[REFRESHES] += 1
                c[REFRESH_PULSES] += 2  # the two RESETs
    return ctr


@njit(cache=True, inline="always")
def _pulse_pair(Gp, Gm, stuck, step, bnd, wn, aux, age, rn, nu, nu_z, counters, P, i, j, n,
                positive, key, ctr):
    """n pulses on pair (i, j): positive raises the weight. A two-sided (bidirectional)
    pair raises G+ and lowers G- per pulse (or the reverse); a SET-only pair potentiates
    G+ (or G-) alone; a ``single`` device moves G+ alone, up or down. Draws per pulse
    and device: the c2c normal (if ``dw_min_std``), then the write-noise normal (if
    ``write_noise``); a refresh then draws its programming noise. Inlined into
    :func:`pulsed_update`, whose per-step update writes few pulses per pair (a call per
    pair took half its time); the commit calls it through :func:`_pulse_pair_call`."""
    # one device move, in a loop over the one or two devices pulsed: inlined once, not
    # three times, _pulse_pair_call compiled in 10-11 s instead of 48-64 s
    # (benchmarks/README.md, "Every core on the first run")
    set_only = P.set_only  # one device pulsed, up: G+ or G-
    first = (0 if positive else 1) if set_only else 0
    nd = devices_pulsed(P)
    noisy = P.dw_min_std != 0.0
    wnoisy = P.write_noise > 0.0
    g0 = Gp[i, j] if first == 0 else Gm[i, j]
    g1 = Gm[i, j]
    live0 = stuck[first, i, j] == OK
    live1 = stuck[1, i, j] == OK
    for _ in range(n):
        # per pulse, each device's c2c then write-noise normal, all before the moves: the
        # same draws in the same order, whatever is live
        z0 = w0 = z1 = w1 = 0.0
        if noisy:
            z0, ctr = normal_at(key, ctr)
        if wnoisy:
            w0, ctr = normal_at(key, ctr)
        if nd == 2:
            if noisy:
                z1, ctr = normal_at(key, ctr)
            if wnoisy:
                w1, ctr = normal_at(key, ctr)
        for k in range(nd):
            if k == 0:
                live, g, up, z, w = live0, g0, set_only or positive, z0, w0
            else:
                live, g, up, z, w = live1, g1, not positive, z1, w1
            if live:
                g = _pulse_device(P, step, wn, bnd, aux, g, first + k, i, j, up, z, w)
                if k == 0:
                    g0 = g
                else:
                    g1 = g
    if first == 0:
        Gp[i, j] = g0
    else:
        Gm[i, j] = g0
    mark_written(age, rn, nu, nu_z, P, first, i, j, g0)
    if nd == 2:
        Gm[i, j] = g1
        mark_written(age, rn, nu, nu_z, P, 1, i, j, g1)
    if P.refresh != 0 and P.refresh_write == REFRESH_VERIFY:
        ctr = _refresh_pair(Gp, Gm, stuck, bnd, wn, age, rn, nu, nu_z, counters, P, i, j, key,
                            ctr)
    return ctr


@kernel
def _pulse_pair_call(Gp, Gm, stuck, step, bnd, wn, aux, age, rn, nu, nu_z, counters, P, i, j,
                     n, positive, key, ctr):
    """:func:`_pulse_pair` compiled once, as the commit's call per written pair: inlined into
    the commit, compiled for both layouts of the state, it was most of the commit's compile
    time; the call costs the per-walk training step 2-11 % (benchmarks/README.md, "The
    pulse path compiled once")."""
    return _pulse_pair(Gp, Gm, stuck, step, bnd, wn, aux, age, rn, nu, nu_z, counters, P, i,
                       j, n, positive, key, ctr)


# write-verify ---------------------------------------------------------------------------
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
def _decay_sweep(Gp, Gm, stuck, bnd, wn, aux, P, key, ctr):
    """One mini-batch's decay (``lifetime``; aihwkit ``PulsedRPUDevice::decayWeights``):
    every unstuck device's hidden state h <- G0 + (h - G0) x its decay scale, clipped to
    its bounds; with write noise, then a fresh offset on every device
    (``applyUpdateWriteNoise``), one normal per device, pair by pair, row by row, G+
    before G-."""
    rows, cols = Gp.shape
    for i in range(rows):
        for j in range(cols):
            for d in range(2):
                G = Gp[i, j] if d == 0 else Gm[i, j]
                live = stuck[d, i, j] == OK
                h = G - wn[d, i, j] if P.write_noise > 0.0 else G
                if live:
                    lo = bnd[2 * d, i, j]
                    hi = bnd[2 * d + 1, i, j]
                    g0 = weight_zero(lo, hi, P)
                    h = min(max(g0 + (h - g0) * aux[AUX_PLANES * d + AUX_DECAY, i, j], lo), hi)
                    G = h
                if P.write_noise > 0.0:
                    w, ctr = normal_at(key, ctr)
                    if live:
                        G = h + P.write_noise * P.dP * w
                        if P.write_noise_clip:
                            G = min(max(G, P.g_min), P.g_max)
                        wn[d, i, j] = G - h
                if d == 0:
                    Gp[i, j] = G
                else:
                    Gm[i, j] = G
    return ctr


# updates and the commit ------------------------------------------------------------------
@njit(cache=True, inline="always")
def accumulate(acc, counters, post, pre, lr):
    """acc += lr post pre^T on the cells whose pre factor is nonzero, each (lr post_i)
    pre_j; counts the cells written (``acc_writes``)."""
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
    counters[ACC_WRITES] += touched


@kernel
def pulsed_update(state, post, pre, lr):
    Gp, Gm, stuck, step, bnd, wn = (state.Gp, state.Gm, state.stuck, state.step, state.bnd,
                                   state.wn)
    aux, age, rn, nu, nu_z = state.aux, state.age, state.rn, state.nu, state.nu_z
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
            line_pulses += popcount(b)
    coincidences = 0
    pairs = 0
    for i in range(rows):
        b, ctr = _pulse_train(B * abs(post[i]), bl, key, ctr)
        bits[i] = b
        if b == 0:
            continue
        line_pulses += popcount(b)
        for k in range(live):
            j = idx[k]
            n = popcount(b & bits[rows + j])
            if n:
                coincidences += n
                pairs += 1
                ctr = _pulse_pair(Gp, Gm, stuck, step, bnd, wn, aux, age, rn, nu, nu_z, c, P, i,
                                  j, n, (post[i] > 0.0) == (pre[j] > 0.0), key, ctr)
    if P.refresh != 0 and P.refresh_write == REFRESH_OPEN:
        ctr = _refresh_sweep(Gp, Gm, stuck, step, bnd, wn, aux, age, rn, nu, nu_z, c, P, key,
                             ctr)
    elif P.refresh != 0 and P.refresh_write == REFRESH_AIHWKIT:
        ctr = _refresh_columns(Gp, Gm, stuck, step, bnd, wn, aux, age, rn, nu, nu_z, c, P, key,
                               ctr, idx, state.ybuf)
    if P.lifetime > 0.0:
        ctr = _decay_sweep(Gp, Gm, stuck, bnd, wn, aux, P, key, ctr)
    state.rng[1] = ctr
    per_pair = devices_pulsed(P)
    c[RNG_DRAWS] += np.int64(ctr - start)
    c[LINE_PULSES] += line_pulses
    c[COINCIDENCES] += coincidences
    c[DEVICE_PULSES] += per_pair * coincidences
    c[DEVICES_WRITTEN] += per_pair * pairs


@kernel
def analog_update(state, post, pre, lr):
    """The exact change (an ideal device), stochastically rounded to the grid if any. A
    SET-only pair puts the whole change on G+ (raising w) or G- (lowering it), a
    ``single`` device on G+."""
    Gp = state.Gp
    Gm = state.Gm
    P = state.params
    rows, cols = Gp.shape
    g_min = P.g_min
    g_max = P.g_max
    dG = P.dG
    set_only = P.set_only != 0
    lone = P.mapping == SINGLE
    half = P.g_per_w if set_only or lone else 0.5 * P.g_per_w
    pair = P.pair_grid == PAIR_GRID and dG > 0.0 and not set_only and P.mapping == TWO_SIDED
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
            if pair:  # whole levels of the pair's difference, stochastically rounded
                n = math.floor(2.0 * d / dG + uniform(key, ctr))
                ctr += _ONE
                if n == 0:
                    continue
                tp, tm = pair_targets(math.floor((Gp[i, j] - Gm[i, j]) / dG + 0.5) + n,
                                      g_min, g_max, dG)
                if stuck[0, i, j] == OK:
                    Gp[i, j] = min(max(tp, g_min), g_max)
                if stuck[1, i, j] == OK:
                    Gm[i, j] = min(max(tm, g_min), g_max)
                mark_written(age, rn, nu, nu_z, P, 0, i, j, Gp[i, j])
                mark_written(age, rn, nu, nu_z, P, 1, i, j, Gm[i, j])
                written += 2
                continue
            if dG > 0.0:
                d = math.floor(d / dG + uniform(key, ctr)) * dG
                ctr += _ONE
                if d == 0.0:
                    continue
            if lone:
                if stuck[0, i, j] == OK:
                    Gp[i, j] = min(max(Gp[i, j] + d, g_min), g_max)
                mark_written(age, rn, nu, nu_z, P, 0, i, j, Gp[i, j])
                written += 1
                continue
            if set_only:
                k = 0 if d > 0.0 else 1
                if stuck[k, i, j] == OK:
                    if k == 0:
                        Gp[i, j] = min(max(Gp[i, j] + d, g_min), g_max)
                    else:
                        Gm[i, j] = min(max(Gm[i, j] - d, g_min), g_max)
                mark_written(age, rn, nu, nu_z, P, k, i, j, Gp[i, j] if k == 0 else Gm[i, j])
                written += 1
                continue
            if stuck[0, i, j] == OK:
                Gp[i, j] = min(max(Gp[i, j] + d, g_min), g_max)
            if stuck[1, i, j] == OK:
                Gm[i, j] = min(max(Gm[i, j] - d, g_min), g_max)
            mark_written(age, rn, nu, nu_z, P, 0, i, j, Gp[i, j])
            mark_written(age, rn, nu, nu_z, P, 1, i, j, Gm[i, j])
            written += 2
    if P.lifetime > 0.0:
        ctr = _decay_sweep(Gp, Gm, stuck, state.bnd, state.wn, state.aux, P, key, ctr)
    state.rng[1] = ctr
    state.counters[RNG_DRAWS] += np.int64(ctr - start)
    state.counters[DEVICES_WRITTEN] += written



@kernel
def commit_accumulated(state):
    Gp = state.Gp
    Gm = state.Gm
    acc = state.acc
    P = state.params
    stuck = state.stuck
    bnd = state.bnd
    wn = state.wn
    aux = state.aux
    step = state.step
    counters = state.counters
    age, rn, nu, nu_z = state.age, state.rn, state.nu, state.nu_z
    rows, cols = Gp.shape
    dw_min = P.dw_min
    dG = P.dG
    lone = P.mapping == SINGLE
    half = P.g_per_w if lone else 0.5 * P.g_per_w
    pulse = P.commit == COMMIT_PULSE
    one_sided = P.mapping == ONE_SIDED
    # a write-verified two-sided pair on the pair's grid: one level of difference a step
    pair = not pulse and P.pair_grid == PAIR_GRID and dG > 0.0 and P.mapping == TWO_SIDED
    unit = dG / P.g_per_w if pair else dw_min
    if not pulse and P.pulse_step > 0.0 and dG > 0.0:  # write-verified whole levels, not
        unit = dw_min / P.dP * dG  # pulses of pulse_step
    per_pair = devices_pulsed(P)
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
            if dG > 0.0 or pulse:  # pulses (of dP, on a grid of dG or on none)
                n = int(a / unit)  # whole steps, toward zero; the rest stays
                if n == 0:
                    continue
                acc[i, j] = a - n * unit
                delta = n * dG
            else:
                acc[i, j] = 0.0
                delta = a * half
            if pulse:
                if abs(n) > P.pulse_cap:  # more would only hold the pair at its bound
                    counters[PULSES_CAPPED] += abs(n) - P.pulse_cap
                    n = P.pulse_cap if n > 0 else -P.pulse_cap
                written += per_pair
                pulses += per_pair * abs(n)
                ctr = _pulse_pair_call(Gp, Gm, stuck, step, bnd, wn, aux, age, rn, nu, nu_z,
                                       counters, P, i, j, abs(n), n > 0, key, ctr)
                continue
            written += 1 if lone else 2
            tp = Gp[i, j] + delta
            tm = Gm[i, j] - delta
            if one_sided:  # retarget both devices from the weight they hold
                w = (Gp[i, j] - Gm[i, j]) / P.g_per_w + (n * unit if dG > 0.0 else a)
                w = min(max(w, -P.w_max), P.w_max)
                tp = P.g_min + max(w, 0.0) * P.g_per_w
                tm = P.g_min + max(-w, 0.0) * P.g_per_w
            elif pair:  # both devices retargeted from the difference they hold
                tp, tm = pair_targets(math.floor((Gp[i, j] - Gm[i, j]) / dG + 0.5) + n,
                                      P.g_min, P.g_max, dG)
            if stuck[0, i, j] == OK:
                Gp[i, j], ctr = _program_device(tp, 0.0, P, key, ctr, bnd[0, i, j],
                                                bnd[1, i, j])
                wn[0, i, j] = 0.0
            if stuck[1, i, j] == OK:
                Gm[i, j], ctr = _program_device(tm, 0.0, P, key, ctr, bnd[2, i, j],
                                                bnd[3, i, j])
                wn[1, i, j] = 0.0
            mark_written(age, rn, nu, nu_z, P, 0, i, j, tp)
            if not lone:  # (a lone device's G- is its fixed reference)
                mark_written(age, rn, nu, nu_z, P, 1, i, j, tm)
    if pulse and P.refresh != 0 and P.refresh_write == REFRESH_OPEN:
        ctr = _refresh_sweep(Gp, Gm, stuck, step, bnd, wn, aux, age, rn, nu, nu_z, counters,
                             P, key, ctr)
    elif pulse and P.refresh != 0 and P.refresh_write == REFRESH_AIHWKIT:
        ctr = _refresh_columns(Gp, Gm, stuck, step, bnd, wn, aux, age, rn, nu, nu_z, counters,
                               P, key, ctr, state.idx, state.ybuf)
    if P.lifetime > 0.0:
        ctr = _decay_sweep(Gp, Gm, stuck, bnd, wn, aux, P, key, ctr)
    state.rng[1] = ctr
    c = counters
    c[RNG_DRAWS] += np.int64(ctr - start)
    c[DEVICE_PULSES] += pulses
    c[LINE_PULSES] += 2 * pulses  # a serial programming pulse drives one row and one column
    c[DEVICES_WRITTEN] += written
