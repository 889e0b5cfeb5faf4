"""The crossbar's arithmetic as plain loops: the readable model its fast kernels are held to.

Not dead code: this is the device model as a reader expects it (as Lava keeps float models
beside its bit-accurate ones), one function per kernel, written from the physics the
config documents (:mod:`cml_edge.backends.crossbar.config`), with none of the kernels'
speed (no bit masks, vector lanes, candidate passes or reference-count care).
``tests/backends/test_references.py`` runs every kernel and its function here on copies
of the same state and compares outputs, states and counters.

Each function takes a :class:`~cml_edge.backends.crossbar.array.CrossbarState` and
changes it in place as the kernel does (the work-space fields aside). Where the project
promises bits, the order is the kernels': sums in the order written below, the same
products and reciprocals, and the draws from the array's stream in the documented order,
one :func:`~cml_edge.jit.rng.uniform` or :func:`~cml_edge.jit.gauss.normal_at` at a time
(the sampler's own definition). So every kernel agrees bit for bit: reads, pulses,
updates, commits, programming, idle time and every draw (the physics that calls ``exp``,
``log`` or ``**`` too: CPython's ``math`` and Numba's compiled calls reach the same C
library). A NaN compares as NaN, whatever its payload.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from cml_edge.backends.crossbar import array
from cml_edge.backends.crossbar.codes import (
    ACC_WRITES,
    ADC_CONVERSIONS,
    ADC_SATURATIONS,
    ANALOG_MACS,
    AUX_DECAY,
    AUX_GAMMA_DOWN,
    AUX_GAMMA_UP,
    AUX_PLANES,
    AUX_REF,
    AUX_RESET,
    BM_REREADS,
    BOUND_AIHWKIT,
    BOUND_INWARD,
    BOUND_SYMMETRIC,
    BOUNDS_SOFT,
    C2C_ADD,
    C2C_MULT,
    CALIBRATION_READS,
    COINCIDENCES,
    COMMIT_PULSE,
    COMMITS,
    COMP_PERIPHERY,
    DAC_CONVERSIONS,
    DEVICE_PULSES,
    DEVICES_WRITTEN,
    LINE_PULSES,
    MATVECS,
    OK,
    ONE_SIDED,
    OUTER_UPDATES,
    PAIR_GRID,
    PULSES_CAPPED,
    REFERENCE,
    REFRESH_AIHWKIT,
    REFRESH_OPEN,
    REFRESH_PULSES,
    REFRESH_VERIFY,
    REFRESHES,
    RMATVECS,
    RNG_DRAWS,
    SET_GAUSS,
    SINGLE,
    SPREAD_LOGNORMAL,
    SPREAD_MULT,
    STEP_BOUNDS,
    STEP_EXP,
    STEP_LINEAR,
    STEP_POW,
    STEP_SOFT,
    STUCK_HIGH,
    STUCK_LOW,
    TWO_SIDED,
    UPDATE_PULSED,
)
from cml_edge.backends.crossbar.config import REFRESH_READ_SIGMAS
from cml_edge.jit.gauss import normal_at
from cml_edge.jit.rng import uniform

State = Any  # a CrossbarState

SCRATCH = array.SCRATCH
"""The state's work space, which this model needs none of."""


class Stream:
    """The array's stream: (key, counter), advanced one word per uniform."""

    def __init__(self, state: State) -> None:
        self.state = state
        self.key = state.rng[0]
        self.ctr = int(state.rng[1])
        self.start = self.ctr

    def uniform(self) -> float:
        u = uniform(self.key, self.ctr)
        self.ctr += 1
        return u

    def normal(self) -> float:
        z, ctr = normal_at(self.key, self.ctr)
        self.ctr = int(ctr)
        return z

    def close(self) -> int:
        """Store the counter in the state; returns the words drawn."""
        self.state.rng[1] = np.uint64(self.ctr)
        return self.ctr - self.start


def steps_of(v: float, step: float) -> float:
    """v in whole converter steps, to nearest, ties away from zero: copysign(floor(|v| /
    step + 1/2), v), the division a product with 1 / step. A NaN stays NaN."""
    if v != v:
        return v
    return math.copysign(math.floor(abs(v) * (1.0 / step) + 0.5), v)


# the read: DAC, MAC, noise, ADC, bound management --------------------------------------
def read(state: State, x: np.ndarray, transposed: bool, kind: int = -1) -> np.ndarray:
    """W x (W^T x if ``transposed``) as the array reads it (the steps of
    :mod:`cml_edge.backends.crossbar.read`); counted as a read of ``kind`` (-1: a
    calibration read, counted by the caller)."""
    P = state.params
    c = state.counters
    if kind >= 0:
        c[kind] += 1
    W = state.Gp - state.Gm  # G+ - G-, micro-siemens
    if transposed:
        W = W.T
    n_out, n_in = W.shape
    # 1. the inputs scaled by max|x| (a NaN is passed over) and converted by the DAC
    xmax = max([abs(v) for v in x if v == v], default=0.0)
    if not xmax > 0.0:
        return np.zeros(n_out)
    rn, on = P.read_noise, P.out_noise
    inv_g = 1.0 / (P.g_max - P.g_min)
    div = xmax
    passes = 0
    while True:
        if passes > 0:  # bound management: the input halved again
            div = div * 2.0
            c[BM_REREADS] += 1
        xs = [x[j] * (1.0 / div) for j in range(n_in)]
        if P.dac_step > 0.0:
            xs = [steps_of(v, P.dac_step) * P.dac_step for v in xs]
        driven = sum(v != 0.0 for v in xs)
        # 2. y_i = sum_j (G+ - G-)_ij xs_j: in column order; transposed, in the eight
        # interleaved partial sums of the array's columns (the order its sums are promised in)
        y = [column_order(W[i], xs) if not transposed else eight_lanes(W[i], xs)
             for i in range(n_out)]
        # 3. the read noise on the normalised outputs, one normal per output in order
        sq = 0.0
        if rn != 0.0:
            for v in xs:
                sq += v * v
        w_swing, noisy = (2.0 * P.w_max, 1.0) if P.mapping == SINGLE else (P.w_max, 2.0)
        sigma = math.sqrt(noisy * rn * rn * sq + on * on)
        wn = P.read_noise_pcm
        var = [0.0] * n_out
        if wn > 0.0:  # PCM_READ: sum_j |w_ij| xs_j^2, |w| = |G+ - G-| / range
            for i in range(n_out):
                for j in range(n_in):
                    var[i] += abs(W[i, j]) * inv_g * (xs[j] * xs[j])
        rng = Stream(state)
        for i in range(n_out):
            y[i] = y[i] * inv_g
            if sigma > 0.0 or wn > 0.0:
                s = math.sqrt(sigma * sigma + wn * wn * var[i]) if wn > 0.0 else sigma
                y[i] = y[i] + s * rng.normal()
        # 4. the ADC clips at +-adc_bound and quantises; 5. the periphery's scale
        scale = w_swing * div * state.alpha[0]
        saturated = 0
        out = np.zeros(n_out)
        for i in range(n_out):
            if P.adc_step > 0.0:
                saturated += abs(y[i]) > P.adc_bound
                v = min(max(y[i], -P.adc_bound), P.adc_bound)
                out[i] = steps_of(v, P.adc_step) * (P.adc_step * scale)
            else:
                out[i] = y[i] * scale
        c[RNG_DRAWS] += rng.close()
        c[ANALOG_MACS] += driven * n_out
        c[DAC_CONVERSIONS] += driven
        c[ADC_CONVERSIONS] += n_out
        c[ADC_SATURATIONS] += saturated
        passes += 1
        if not P.bound_management or saturated == 0 or passes >= P.bm_passes:
            return out


def column_order(w: np.ndarray, xs: list[float]) -> float:
    """sum_j w_j xs_j, from 0.0, in index order."""
    s = 0.0
    for j in range(len(xs)):
        s += w[j] * xs[j]
    return s


def eight_lanes(w: np.ndarray, xs: list[float]) -> float:
    """sum_k w_k xs_k as eight interleaved partial sums s_l = sum_c w_(8c+l) xs_(8c+l)
    over the whole groups of eight, the rows left over added to s_0, then
    ((s0 + s1) + (s2 + s3)) + ((s4 + s5) + (s6 + s7))."""
    s = [0.0] * 8
    n = len(xs)
    whole = n - n % 8
    for k in range(whole):
        s[k % 8] += w[k] * xs[k]
    for k in range(whole, n):
        s[0] += w[k] * xs[k]
    return ((s[0] + s[1]) + (s[2] + s[3])) + ((s[4] + s[5]) + (s[6] + s[7]))


def matvec(state: State, x: np.ndarray) -> np.ndarray:
    return read(state, x, False, MATVECS)


def rmatvec(state: State, y: np.ndarray) -> np.ndarray:
    return read(state, y, True, RMATVECS)


def sigmoid(state: State, z: np.ndarray) -> np.ndarray:
    """The affordance nonlinearity, a digital peripheral function: 1 / (1 + e^-z)."""
    return np.array([1.0 / (1.0 + math.exp(-v)) for v in z])


# one device, one pulse ---------------------------------------------------------------
def weight_zero(P: Any, lo: float, hi: float) -> float:
    """G0: lo + step_center (hi - lo) of the device's own bounds, or the nominal
    g_min + step_center (g_max - g_min) its bounds spread around (``bound_spread``)."""
    if P.bound_spread != BOUND_INWARD:
        return P.g_min + P.step_center * (P.g_max - P.g_min)
    return lo + P.step_center * (hi - lo)


def step_factor(P: Any, g: float, up: bool, lo: float, hi: float,
                gu: float, gd: float) -> float:
    """The mean step of one pulse at conductance g, in units of the device's nominal step
    (``step_model``; lo / hi the device's bounds, G0 its weight zero, gu / gd its
    ``linear`` slopes, referred to the nominal bounds with ``mean_bound_reference``)."""
    span = hi - lo
    if not span > 0.0:
        return 0.0
    g0 = weight_zero(P, lo, hi)
    m = P.step_model
    if m == STEP_LINEAR:  # aihwkit LinearStep
        ref_hi, ref_lo = (P.g_max, P.g_min) if P.mean_bound_reference else (hi, lo)
        f = 1.0 - gu * (g - g0) / (ref_hi - g0) if up else \
            1.0 - gd * (g - g0) / (ref_lo - g0)
    elif m == STEP_SOFT:  # SoftBounds: zero at each bound
        f = 1.0 - 1.0 * (g - g0) / (hi - g0) if up else 1.0 - 1.0 * (g - g0) / (lo - g0)
    elif m == STEP_EXP:  # ExpStep
        if P.bound_spread != BOUND_INWARD:
            z = 2.0 * P.exp_a * ((g - g0) / span) + P.exp_b
        else:
            z = 2.0 * P.exp_a * ((g - lo) / span - P.step_center) + P.exp_b
        f = 1.0 - P.exp_a_up * math.exp(P.exp_gamma_up * z) if up else \
            1.0 - P.exp_a_down * math.exp(-P.exp_gamma_down * z)
    elif m == STEP_POW:  # PowStep
        r = (hi - g) / span if up else (g - lo) / span
        f = r ** P.pow_gamma if r > 0.0 else 0.0
    elif P.bounds == BOUNDS_SOFT:  # the earlier releases' soft bounds, on the nominal range
        f = 2.0 * (P.g_max - g) / (P.g_max - P.g_min) if up else \
            2.0 * (g - P.g_min) / (P.g_max - P.g_min)
    else:
        f = 1.0
    if m == STEP_SOFT and has_reference(P):  # a reference device's internal state past
        return f  # its bound steps back toward it (aihwkit SoftBoundsReference)
    return max(f, 0.0)


def pulse(P: Any, g: float, up: bool, s: float, z: float, lo: float, hi: float,
          gu: float = 0.0, gd: float = 0.0) -> float:
    """A device at g after one pulse of nominal size s dG (``pulse_step``: dP) with
    cycle-to-cycle normal z (gu / gd its ``linear`` slopes)."""
    if P.step_model == STEP_BOUNDS:  # the model of earlier releases: multiplicative c2c
        d = P.dP * s * (1.0 + P.dw_min_std * z)
        if P.bounds == BOUNDS_SOFT:
            d *= 2.0 * (P.g_max - g) / (P.g_max - P.g_min) if up else \
                2.0 * (g - P.g_min) / (P.g_max - P.g_min)
        if P.set_only and d < 0.0:  # a SET pulse never lowers G
            d = 0.0
        g = g + d if up else g - d
        return min(max(g, P.g_min), P.g_max)
    step = P.dP * s * step_factor(P, g, up, lo, hi, gu, gd)
    if P.c2c == C2C_MULT:
        sd = P.dw_min_std * step
    elif P.c2c == C2C_ADD:
        sd = P.dw_min_std * P.dP * s
    else:  # complex
        g0 = weight_zero(P, lo, hi)
        sd = P.dw_min_std * (step + P.c2c_add * (P.g_max - P.g_min) + P.c2c_slope * abs(g - g0))
    if P.set_only and P.set_noise != SET_GAUSS:  # log-normal: a SET pulse never lowers G
        d = 0.0
        if step > 0.0:
            v = math.log1p((sd / step) * (sd / step))
            d = step * math.exp(math.sqrt(v) * z - 0.5 * v)
    else:
        d = step + sd * z
    g = g + d if up else g - d
    return min(max(g, lo), hi)


def mark_written(state: State, d: int, i: int, j: int, g: float) -> None:
    """A write of device d of pair (i, j) to g: its drift clock restarts, its accumulated
    read noise is gone, its drift exponent follows g (``drift_nu_g``)."""
    P = state.params
    state.age[d, i, j] = 0.0
    if P.rn1f > 0.0:
        state.rn[d, i, j] = 0.0
    if P.drift_nu_g:
        state.nu[d, i, j] = nu_of(P, g, state.nu_z[d, i, j])


def nu_of(P: Any, g: float, z: float) -> float:
    """nu = |mu(g) + sd(g) z|, g = max(G / g_max, 1e-7) (``drift_nu_g``)."""
    lg = math.log(max(abs(g / P.g_max), 1e-7))
    mu = min(max(P.nu_a * lg + P.nu_b, P.nu_lo), P.nu_hi)
    sd = min(max(P.nu_sa * lg + P.nu_sb, P.nu_slo), P.nu_shi)
    return abs(mu + sd * z)


def level(P: Any, g: float) -> float:
    """The grid level nearest g, in [g_min, g_max] (a continuous device: g clipped)."""
    if P.dG > 0.0:
        g = P.g_min + math.floor((g - P.g_min) / P.dG + 0.5) * P.dG
    return min(max(g, P.g_min), P.g_max)


def pair_split(P: Any, k: float) -> tuple[float, float]:
    """G+ and G- holding k levels of difference around the level c nearest the centre:
    c + (k - floor(k / 2)) dG, c - floor(k / 2) dG (``pair_grid`` pair)."""
    c = level(P, 0.5 * (P.g_min + P.g_max))
    h = math.floor(0.5 * k)
    return c + (k - h) * P.dG, c - h * P.dG


def prog_sigma(P: Any, G: float) -> float:
    """The programming noise's std at G: scale max(c0 + c1 g + c2 g^2, 0) g_max / g_ref,
    g = G / g_max (:mod:`cml_edge.backends.crossbar.conductance`)."""
    if P.prog_noise == 0.0:
        return 0.0
    g = G / P.g_max
    s = P.prog_c0 + P.prog_c1 * g + P.prog_c2 * g * g
    return 0.0 if s < 0.0 else P.prog_noise * s * P.g_max / P.prog_gref


def program_device(P: Any, G: float, rng: Stream, lo: float, hi: float) -> float:
    """Write-verify to the level nearest G, plus N(0, prog_sigma^2) (clipped to the
    range), within the device's bounds [lo, hi]."""
    target = level(P, G)
    sigma = prog_sigma(P, target)
    if sigma > 0.0:
        target = min(max(target + sigma * rng.normal(), P.g_min), P.g_max)
    return min(max(target, lo), hi)


# a pair -------------------------------------------------------------------------------
def device(state: State, d: int) -> np.ndarray:
    return state.Gp if d == 0 else state.Gm


def has_reference(P: Any) -> bool:
    """Whether each device has a reference subtracted (``reference_*``)."""
    return P.reference_mean != 0.0 or P.reference_std > 0.0 or bool(P.subtract_symmetry_point)


def pulse_device(state: State, d: int, i: int, j: int, up: bool, z: float, w: float) -> None:
    """One pulse on device d of pair (i, j) (not stuck), normals z (c2c) and w (write
    noise): it moves the hidden state G - wn, plus the reference if any (the internal
    state aihwkit's reference device steps), and a fresh offset is read on top."""
    P = state.params
    G = device(state, d)
    s = state.step[2 * d, i, j] if up else state.step[2 * d + 1, i, j]
    lo, hi = state.bnd[2 * d, i, j], state.bnd[2 * d + 1, i, j]
    k = AUX_PLANES * d
    gu, gd = P.gamma_up, P.gamma_down
    if P.gamma_up_dtod > 0.0 or P.gamma_down_dtod > 0.0:
        gu, gd = state.aux[k + AUX_GAMMA_UP, i, j], state.aux[k + AUX_GAMMA_DOWN, i, j]
    h = G[i, j] - state.wn[d, i, j] if P.write_noise > 0.0 else G[i, j]
    if P.step_model != STEP_BOUNDS and has_reference(P):
        ref = state.aux[k + AUX_REF, i, j]
        h = pulse(P, h + ref, up, s, z, lo, hi, gu, gd) - ref
    else:
        h = pulse(P, h, up, s, z, lo, hi, gu, gd)
    if P.write_noise > 0.0:
        G[i, j] = h + P.write_noise * P.dP * w
        if P.write_noise_clip:
            G[i, j] = min(max(G[i, j], P.g_min), P.g_max)
        state.wn[d, i, j] = G[i, j] - h
    else:
        G[i, j] = h


def pulse_pair(state: State, i: int, j: int, n: int, positive: bool, rng: Stream) -> None:
    """n pulses on pair (i, j), raising the weight if ``positive``: a two-sided pair moves
    G+ one way and G- the other per pulse, a SET-only pair potentiates G+ (or G-) alone,
    a ``single`` device moves G+ alone, either way.
    Per pulse and device: the c2c normal (if ``dw_min_std``), then the write-noise normal
    (if ``write_noise``); then the refresh (its programming noise)."""
    P = state.params
    devices = [0] if P.mapping == SINGLE else [0, 1] if not P.set_only else \
        ([0] if positive else [1])
    for _ in range(n):
        for d in devices:
            up = True if P.set_only else (positive if d == 0 else not positive)
            z = rng.normal() if P.dw_min_std != 0.0 else 0.0
            w = rng.normal() if P.write_noise > 0.0 else 0.0
            if state.stuck[d, i, j] == OK:
                pulse_device(state, d, i, j, up, z, w)
    for d in devices:
        mark_written(state, d, i, j, device(state, d)[i, j])
    if P.refresh and P.refresh_write == REFRESH_VERIFY:
        refresh_pair(state, i, j, rng)


def refresh_pair(state: State, i: int, j: int, rng: Stream) -> None:
    """If the larger device is above ``refresh_upper`` of the range and the smaller above
    ``refresh_lower``: RESET both and write-verify the difference onto the larger."""
    P = state.params
    grange = P.g_max - P.g_min
    up_, um = (state.Gp[i, j] - P.g_min) / grange, (state.Gm[i, j] - P.g_min) / grange
    if not (max(up_, um) > P.refresh_upper and min(up_, um) > P.refresh_lower):
        return
    diff = state.Gp[i, j] - state.Gm[i, j]
    pulses = 2  # the two RESETs
    for d in range(2):
        target = P.g_min
        if d == 0 and diff > 0.0:
            target = P.g_min + diff
        elif d == 1 and diff < 0.0:
            target = P.g_min - diff
        if state.stuck[d, i, j] != OK:
            continue
        G = program_device(P, target, rng, state.bnd[2 * d, i, j], state.bnd[2 * d + 1, i, j])
        if target > P.g_min:
            pulses += set_pulses(P, target)
        device(state, d)[i, j] = G
        state.wn[d, i, j] = 0.0
        mark_written(state, d, i, j, target)
    state.counters[REFRESHES] += 1
    state.counters[REFRESH_PULSES] += pulses


def refresh_sweep(state: State, rng: Stream) -> None:
    """The open-loop refresh (``refresh_write`` open-loop), after an update or a commit:
    each pair read device by device with noise, row by row; where the reads cross the
    thresholds both devices are RESET to g_min and the read difference D written onto the
    device that read larger by one pair of pulse trains (BL = min(ceil(D / dG), bl_max)
    slots, each fired with probability sqrt(D / (dG BL))), one pulse per coincidence."""
    P = state.params
    grange = P.g_max - P.g_min
    sd = P.refresh_read_noise * grange
    rows, cols = state.Gp.shape
    for i in range(rows):
        for j in range(cols):
            big, small = max(state.Gp[i, j], state.Gm[i, j]), min(state.Gp[i, j], state.Gm[i, j])
            if not (big > P.g_min + P.refresh_upper * grange - REFRESH_READ_SIGMAS * sd
                    and small > P.g_min + P.refresh_lower * grange - REFRESH_READ_SIGMAS * sd):
                continue  # too far from the thresholds to be read across them
            rp = state.Gp[i, j] + sd * rng.normal()
            rm = state.Gm[i, j] + sd * rng.normal()
            up_, um = (rp - P.g_min) / grange, (rm - P.g_min) / grange
            if not (max(up_, um) > P.refresh_upper and min(up_, um) > P.refresh_lower):
                continue
            big = 0 if rp > rm else 1
            diff = abs(rp - rm)
            for d in range(2):
                if state.stuck[d, i, j] == OK:
                    device(state, d)[i, j] = P.g_min
                    state.wn[d, i, j] = 0.0
            bl = max(1, min(int(math.ceil(diff / P.dP)), P.bl_max))
            p = min(math.sqrt(diff / (P.dP * bl)), 1.0)
            trains = [[rng.uniform() < p for _ in range(bl)] if p > 0.0 else [False] * bl
                      for _ in range(2)]
            n = sum(a and b for a, b in zip(*trains))
            for _ in range(n):
                z = rng.normal() if P.dw_min_std != 0.0 else 0.0
                w = rng.normal() if P.write_noise > 0.0 else 0.0
                if state.stuck[big, i, j] == OK:
                    pulse_device(state, big, i, j, True, z, w)
            for d in range(2):
                mark_written(state, d, i, j, device(state, d)[i, j])
            state.counters[REFRESHES] += 1
            state.counters[REFRESH_PULSES] += 2 + n


def refresh_read(P: Any, G: float, z: float) -> float:
    """The ``aihwkit`` refresh's read: G0 plus (G - G0 + noise) rounded to the read step."""
    v = G + P.refresh_read_noise * (P.g_max - P.g_min) * z
    q = P.refresh_read_step * (P.g_max - P.g_min)
    if q > 0.0:
        g0 = P.g_min + P.step_center * (P.g_max - P.g_min)
        v = g0 + math.floor((v - g0) / q + 0.5) * q
    return v


def refresh_columns(state: State, rng: Stream) -> None:
    """The ``aihwkit`` refresh (aihwkit ``OneSidedRPUDevice::refreshWeights``), column by
    column: each pair near the thresholds read (G+, G-); the crossing pairs' G+ RESET to
    G0 + reset bias + reset_std z, then their G-; then the read differences written by one
    pulsed update of the column per side, at aihwkit's weight granularity with its update
    management (config.py, ``refresh_write``)."""
    P = state.params
    grange = P.g_max - P.g_min
    sd, q = P.refresh_read_noise * grange, P.refresh_read_step * grange
    margin = REFRESH_READ_SIGMAS * sd + q
    gran = P.pulse_gain * P.dP
    rows, cols = state.Gp.shape
    for j in range(cols):
        flag, diff = {}, {}
        for i in range(rows):
            gp, gm = state.Gp[i, j], state.Gm[i, j]
            if not (max(gp, gm) > P.g_min + P.refresh_upper * grange - margin
                    and min(gp, gm) > P.g_min + P.refresh_lower * grange - margin):
                continue
            rp = refresh_read(P, gp, rng.normal())
            rm = refresh_read(P, gm, rng.normal())
            up_, um = (rp - P.g_min) / grange, (rm - P.g_min) / grange
            if max(up_, um) > P.refresh_upper and min(up_, um) > P.refresh_lower:
                flag[i], diff[i] = (0 if rp > rm else 1), abs(rp - rm)
        for d in range(2):  # RESET: G+ of each crossing pair, then G-
            for i in flag:
                z = rng.normal() if P.reset_std > 0.0 else 0.0
                if state.stuck[d, i, j] != OK:
                    continue
                lo, hi = state.bnd[2 * d, i, j], state.bnd[2 * d + 1, i, j]
                b = state.aux[AUX_PLANES * d + AUX_RESET, i, j] if P.reset_dtod > 0.0 else \
                    P.reset * grange
                device(state, d)[i, j] = min(max(weight_zero(P, lo, hi) + b
                                                 + P.reset_std * grange * z, lo), hi)
                state.wn[d, i, j] = 0.0
        for d in range(2):  # the write onto G+, then onto G-
            mine = [i for i in flag if flag[i] == d]
            dmax = max((diff[i] for i in mine), default=0.0)
            if not dmax > 0.0:
                continue
            k = dmax / gran
            bl = max(1, min(int(math.ceil(k)), P.bl_max))
            dval = dmax * P.bl_max / k if k > P.bl_max else dmax

            def train(p: float, bl: int = bl) -> list[bool]:
                return [rng.uniform() < min(p, 1.0) for _ in range(bl)] if p != 0.0 else \
                    [False] * bl

            column = train(math.sqrt(dval / (gran * bl)))
            for i in mine:
                row = train(diff[i] * (1.0 / math.sqrt(dval * gran * bl)))
                n = sum(a and b for a, b in zip(column, row))
                for _ in range(n):
                    z = rng.normal() if P.dw_min_std != 0.0 else 0.0
                    w = rng.normal() if P.write_noise > 0.0 else 0.0
                    if state.stuck[d, i, j] == OK:
                        pulse_device(state, d, i, j, True, z, w)
                state.counters[REFRESH_PULSES] += n
        for i in flag:
            for d in range(2):
                mark_written(state, d, i, j, device(state, d)[i, j])
            state.counters[REFRESHES] += 1
            state.counters[REFRESH_PULSES] += 2


def set_pulses(P: Any, target: float) -> int:
    """SET pulses the mean device (s = 1, no noise, nominal bounds) needs from g_min to
    ``target`` (at most 100,000)."""
    if not P.dP > 0.0:
        return 0
    g, n = P.g_min, 0
    while g < target and n < 100000:
        g2 = min(g + P.dP * step_factor(P, g, True, P.g_min, P.g_max, P.gamma_up, P.gamma_down),
                 P.g_max)
        n += 1
        if not g2 > g:
            break
        g = g2
    return n


def decay(state: State, rng: Stream) -> None:
    """One mini-batch's decay (``lifetime``): each unstuck device's hidden state moves to
    G0 + (h - G0) x its decay scale, within its bounds; with write noise every device then
    reads a fresh offset (one normal each), pair by pair, row by row, G+ before G-."""
    P = state.params
    rows, cols = state.Gp.shape
    for i in range(rows):
        for j in range(cols):
            for d in range(2):
                G = device(state, d)
                h = G[i, j] - state.wn[d, i, j] if P.write_noise > 0.0 else G[i, j]
                live = state.stuck[d, i, j] == OK
                if live:
                    lo, hi = state.bnd[2 * d, i, j], state.bnd[2 * d + 1, i, j]
                    g0 = weight_zero(P, lo, hi)
                    h = min(max(g0 + (h - g0) * state.aux[AUX_PLANES * d + AUX_DECAY, i, j],
                                lo), hi)
                    G[i, j] = h
                if P.write_noise > 0.0:
                    w = rng.normal()
                    if live:
                        G[i, j] = h + P.write_noise * P.dP * w
                        if P.write_noise_clip:
                            G[i, j] = min(max(G[i, j], P.g_min), P.g_max)
                        state.wn[d, i, j] = G[i, j] - h


# the updates and the commit ------------------------------------------------------------
def outer_update(state: State, post: np.ndarray, pre: np.ndarray, lr: float,
                 defer: bool) -> None:
    """W += lr post pre^T: into the accumulator (``defer``), or in place."""
    state.counters[OUTER_UPDATES] += 1
    if defer:
        rows, cols = state.acc.shape
        for i in range(rows):
            for j in range(cols):
                if pre[j] != 0.0:
                    state.acc[i, j] += (lr * post[i]) * pre[j]
        state.counters[ACC_WRITES] += rows * sum(q != 0.0 for q in pre)
    elif state.params.update == UPDATE_PULSED:
        pulsed_update(state, post, pre, lr)
    else:
        analog_update(state, post, pre, lr)


def pulsed_update(state: State, post: np.ndarray, pre: np.ndarray, lr: float) -> None:
    """The stochastic coincidence update (Gokmen & Vlasov 2016; write.py's docstring)."""
    P = state.params
    c = state.counters
    xmax = dmax = 0.0
    for q in pre:
        xmax = max(xmax, abs(q))
    for p in post:
        dmax = max(dmax, abs(p))
    if not (xmax > 0.0 and dmax > 0.0 and lr > 0.0):
        return
    bl = max(1, min(int(math.ceil(lr * xmax * dmax / P.dw_min)), P.bl_max))
    base = math.sqrt(lr / (P.dw_min * bl))
    A = base * math.sqrt(dmax / xmax)
    B = base * math.sqrt(xmax / dmax)
    rng = Stream(state)

    def train(p: float) -> list[bool]:  # bl slots, each fired with probability min(p, 1)
        if p == 0.0:
            return [False] * bl
        return [rng.uniform() < min(p, 1.0) for _ in range(bl)]

    columns = [train(A * abs(q)) for q in pre]
    per_pair = 1 if P.set_only or P.mapping == SINGLE else 2
    for i in range(len(post)):
        row = train(B * abs(post[i]))
        c[LINE_PULSES] += sum(row)
        for j in range(len(pre)):
            n = sum(r and s for r, s in zip(row, columns[j]))
            if n:
                c[COINCIDENCES] += n
                c[DEVICE_PULSES] += per_pair * n
                c[DEVICES_WRITTEN] += per_pair
                pulse_pair(state, i, j, n, (post[i] > 0.0) == (pre[j] > 0.0), rng)
    if P.refresh and P.refresh_write == REFRESH_OPEN:
        refresh_sweep(state, rng)
    elif P.refresh and P.refresh_write == REFRESH_AIHWKIT:
        refresh_columns(state, rng)
    if P.lifetime > 0.0:
        decay(state, rng)
    c[LINE_PULSES] += sum(sum(col) for col in columns)
    c[RNG_DRAWS] += rng.close()


def analog_update(state: State, post: np.ndarray, pre: np.ndarray, lr: float) -> None:
    """The exact change (an ideal device), stochastically rounded to the grid if any: one
    uniform per cell with both factors nonzero, row by row. A SET-only pair puts the whole
    change on G+ (raising w) or G- (lowering it), a ``single`` device on G+."""
    P = state.params
    lone = P.mapping == SINGLE
    half = P.g_per_w if P.set_only or lone else 0.5 * P.g_per_w
    pair = (P.pair_grid == PAIR_GRID and P.dG > 0.0 and not P.set_only
            and P.mapping == TWO_SIDED)
    rng = Stream(state)
    for i in range(len(post)):
        for j in range(len(pre)):
            if post[i] == 0.0 or pre[j] == 0.0:
                continue
            d = lr * post[i] * pre[j] * half
            if pair:  # whole levels of the pair's difference, stochastically rounded
                n = math.floor(2.0 * d / P.dG + rng.uniform())
                if n == 0:
                    continue
                targets = pair_split(P, math.floor((state.Gp[i, j] - state.Gm[i, j]) / P.dG
                                                   + 0.5) + n)
                for k in range(2):
                    if state.stuck[k, i, j] == OK:
                        device(state, k)[i, j] = min(max(targets[k], P.g_min), P.g_max)
                for k in range(2):
                    mark_written(state, k, i, j, device(state, k)[i, j])
                state.counters[DEVICES_WRITTEN] += 2
                continue
            if P.dG > 0.0:
                d = math.floor(d / P.dG + rng.uniform()) * P.dG
                if d == 0.0:
                    continue
            for k in ([0] if lone else [0 if d > 0.0 else 1] if P.set_only else [0, 1]):
                if state.stuck[k, i, j] == OK:
                    G = device(state, k)
                    G[i, j] = min(max(G[i, j] + d if k == 0 else G[i, j] - d, P.g_min),
                                  P.g_max)
                mark_written(state, k, i, j, device(state, k)[i, j])
                state.counters[DEVICES_WRITTEN] += 1
    if P.lifetime > 0.0:
        decay(state, rng)
    state.counters[RNG_DRAWS] += rng.close()


def commit(state: State) -> None:
    """Apply the accumulator, pair by pair, row by row: n = trunc(acc / dw_min) whole steps
    (the rest stays), sent as |n| pulses, at most ``pulse_cap`` (``commit`` pulse), or
    written by write-verify to the target they make (program; continuous: the whole acc)."""
    P = state.params
    c = state.counters
    c[COMMITS] += 1
    rng = Stream(state)
    lone = P.mapping == SINGLE
    per_pair = 1 if P.set_only or lone else 2
    # a write-verified two-sided pair on the pair's grid: one level of difference a step
    pair = (P.commit != COMMIT_PULSE and P.pair_grid == PAIR_GRID and P.dG > 0.0
            and P.mapping == TWO_SIDED)
    unit = P.dG / P.g_per_w if pair else P.dw_min
    if P.commit != COMMIT_PULSE and P.pulse_step > 0.0 and P.dG > 0.0:  # whole levels
        unit = P.dw_min / P.dP * P.dG
    rows, cols = state.acc.shape
    for i in range(rows):
        for j in range(cols):
            a = state.acc[i, j]
            if a == 0.0:
                continue
            n = 0
            if P.dG > 0.0 or P.commit == COMMIT_PULSE:
                n = int(a / unit)  # toward zero
                if n == 0:
                    continue
                state.acc[i, j] = a - n * unit
                delta = n * P.dG
            else:
                state.acc[i, j] = 0.0
                delta = a * (P.g_per_w if lone else 0.5 * P.g_per_w)
            if P.commit == COMMIT_PULSE:
                if abs(n) > P.pulse_cap:  # dropped: it would only hold the pair at its bound
                    c[PULSES_CAPPED] += abs(n) - P.pulse_cap
                    n = P.pulse_cap if n > 0 else -P.pulse_cap
                c[DEVICES_WRITTEN] += per_pair
                c[DEVICE_PULSES] += per_pair * abs(n)
                c[LINE_PULSES] += 2 * per_pair * abs(n)  # a pulse drives a row and a column
                pulse_pair(state, i, j, abs(n), n > 0, rng)
                continue
            c[DEVICES_WRITTEN] += 1 if lone else 2
            targets = [state.Gp[i, j] + delta, state.Gm[i, j] - delta]
            if P.mapping == ONE_SIDED:  # both devices retargeted from the weight they hold
                w = (state.Gp[i, j] - state.Gm[i, j]) / P.g_per_w + \
                    (n * unit if P.dG > 0.0 else a)
                w = min(max(w, -P.w_max), P.w_max)
                targets = [P.g_min + max(w, 0.0) * P.g_per_w,
                           P.g_min + max(-w, 0.0) * P.g_per_w]
            elif pair:  # both devices retargeted from the difference they hold
                targets = list(pair_split(P, math.floor((state.Gp[i, j] - state.Gm[i, j])
                                                        / P.dG + 0.5) + n))
            for d in range(2):
                if state.stuck[d, i, j] == OK:
                    device(state, d)[i, j] = program_device(
                        P, targets[d], rng, state.bnd[2 * d, i, j], state.bnd[2 * d + 1, i, j])
                    state.wn[d, i, j] = 0.0
            for d in range(1 if lone else 2):  # (a lone device's G- is its reference)
                mark_written(state, d, i, j, targets[d])
    if P.commit == COMMIT_PULSE and P.refresh and P.refresh_write == REFRESH_OPEN:
        refresh_sweep(state, rng)
    elif P.commit == COMMIT_PULSE and P.refresh and P.refresh_write == REFRESH_AIHWKIT:
        refresh_columns(state, rng)
    if P.lifetime > 0.0:
        decay(state, rng)
    c[RNG_DRAWS] += rng.close()


# construction and time -----------------------------------------------------------------
def program(state: State, W: np.ndarray) -> int:
    """Draw the per-device constants and program W (``time.xbar_program``'s draw order);
    returns the words drawn."""
    P = state.params
    rows, cols = W.shape
    rng = Stream(state)
    cells = [(i, j, d) for i in range(rows) for j in range(cols) for d in range(2)]
    for i, j, d in cells:  # stuck-at faults
        u = rng.uniform()
        state.stuck[d, i, j] = STUCK_LOW if u < P.stuck_low else (
            STUCK_HIGH if u < P.stuck_low + P.stuck_high else OK)
    for i, j, d in cells:  # pulse-step scale and up/down asymmetry
        z1, z2 = rng.normal(), rng.normal()
        if P.scale_spread == SPREAD_MULT:
            s = max(1.0 + P.dw_min_dtod * z1, 0.0)
            a = P.up_down + P.up_down_dtod * z2
            state.step[2 * d, i, j] = max(s * (1.0 + a), 0.0)
            state.step[2 * d + 1, i, j] = max(s * (1.0 - a), 0.0)
        else:  # aihwkit: gain + r up, gain - r down; up_down shrinks one direction
            gain = math.exp(P.dw_min_dtod * z1) if P.scale_spread == SPREAD_LOGNORMAL else \
                1.0 + P.dw_min_dtod * z1
            state.step[2 * d, i, j] = abs(min(P.up_down, 0.0) + gain + P.up_down_dtod * z2)
            state.step[2 * d + 1, i, j] = abs(-max(P.up_down, 0.0) + gain - P.up_down_dtod * z2)
    for i, j, d in cells:  # drift exponent
        z = rng.normal()
        state.nu[d, i, j] = max(P.drift_nu + P.drift_nu_std * z, 0.0)
        state.nu_z[d, i, j] = z
    g_c = 0.5 * (P.g_min + P.g_max)
    pair = P.pair_grid == PAIR_GRID and P.dG > 0.0 and P.mapping == TWO_SIDED
    ref = level(P, P.g_min + P.step_center * (P.g_max - P.g_min))  # a single's reference
    for i, j, d in cells:  # the weights, with programming noise
        w = W[i, j] if P.mapping == SINGLE else min(max(W[i, j], -P.w_max), P.w_max)
        if P.mapping == SINGLE:  # (clipped as a conductance, to what the device holds)
            t = ref + w * P.g_per_w if d == 0 else ref
        elif P.mapping == ONE_SIDED:
            t = P.g_min + max(w if d == 0 else -w, 0.0) * P.g_per_w
        elif pair:  # the pair's difference k dG, split around the centre level
            t = pair_split(P, math.floor(w * P.g_per_w / P.dG + 0.5))[d]
        else:
            t = g_c + w * (0.5 * P.g_per_w) if d == 0 else g_c - w * (0.5 * P.g_per_w)
        G = level(P, t)
        if P.drift_nu_g:
            state.nu[d, i, j] = nu_of(P, G, state.nu_z[d, i, j])
        G = min(max(G + rng.normal() * prog_sigma(P, G), P.g_min), P.g_max)
        G = {STUCK_LOW: P.g_min, STUCK_HIGH: P.g_max}.get(state.stuck[d, i, j], G)
        if P.mapping == SINGLE and d == 1:  # the reference: exact, never stuck
            G = ref
            state.stuck[d, i, j] = REFERENCE
        device(state, d)[i, j] = G
        state.age[d, i, j] = 0.0
        state.bnd[2 * d, i, j] = P.g_min
        state.bnd[2 * d + 1, i, j] = P.g_max
    if P.bound_dtod_up > 0.0 or P.bound_dtod_down > 0.0:  # each device's own bounds
        g0 = P.g_min + P.step_center * (P.g_max - P.g_min)
        for i, j, d in cells:
            zu, zl = rng.normal(), rng.normal()
            if P.bound_spread == BOUND_AIHWKIT:  # populate: swapped if crossed, then |.|
                lo, hi = g0 - (g0 - P.g_min) * (1.0 + P.bound_dtod_down * zl), \
                    g0 + (P.g_max - g0) * (1.0 + P.bound_dtod_up * zu)
                if lo > hi:
                    lo, hi = hi, lo
                lo, hi = g0 - abs(g0 - lo), g0 + abs(hi - g0)
            else:
                ru = max(abs(1.0 + P.bound_dtod_up * zu), 1e-3)
                rl = max(abs(1.0 + P.bound_dtod_down * zl), 1e-3)
                if P.bound_spread != BOUND_SYMMETRIC:  # inward: a bound only moves toward G0
                    ru, rl = min(ru, 1.0), min(rl, 1.0)
                lo, hi = max(g0 - (g0 - P.g_min) * rl, 0.0), g0 + (P.g_max - g0) * ru
            state.bnd[2 * d, i, j], state.bnd[2 * d + 1, i, j] = lo, hi
            if state.stuck[d, i, j] == OK:
                device(state, d)[i, j] = min(max(device(state, d)[i, j], lo), hi)
    if (P.gamma_up_dtod > 0.0 or P.gamma_down_dtod > 0.0 or has_reference(P)
            or P.lifetime > 0.0 or P.reset_dtod > 0.0):
        draw_aux(state, cells, rng)
    if P.apply_write_noise_on_set and P.write_noise > 0.0:  # the offset read on top
        for i, j, d in cells:
            z = rng.normal()
            if state.stuck[d, i, j] == OK:
                G = device(state, d)
                h = G[i, j]
                G[i, j] = h + P.write_noise * P.dP * z
                if P.write_noise_clip:
                    G[i, j] = min(max(G[i, j], P.g_min), P.g_max)
                state.wn[d, i, j] = G[i, j] - h
    return rng.close()


def draw_aux(state: State, cells: list[tuple[int, int, int]], rng: Stream) -> None:
    """Each device's aihwkit extras (``time._draw_aux``): slopes |gamma + gamma_dtod z|, the
    reference (reference_mean + reference_std z) range plus the symmetry point, the decay
    scale 1 - 1 / t, t = lifetime (1 + lifetime_dtod z)."""
    P = state.params
    grange = P.g_max - P.g_min
    g0 = P.g_min + P.step_center * grange
    for i, j, d in cells:
        k = AUX_PLANES * d
        if P.gamma_up_dtod > 0.0 or P.gamma_down_dtod > 0.0:
            zu, zd = rng.normal(), rng.normal()
            state.aux[k + AUX_GAMMA_UP, i, j] = abs(P.gamma_up + P.gamma_up_dtod * zu)
            state.aux[k + AUX_GAMMA_DOWN, i, j] = abs(P.gamma_down + P.gamma_down_dtod * zd)
        if has_reference(P):
            z = rng.normal() if P.reference_std > 0.0 else 0.0
            ref = (P.reference_mean + P.reference_std * z) * grange
            lo, hi = state.bnd[2 * d, i, j], state.bnd[2 * d + 1, i, j]
            if P.subtract_symmetry_point and hi > g0 and lo < g0:  # where s_up (1 - x / up)
                su, sd = state.step[2 * d, i, j], state.step[2 * d + 1, i, j]  # = s_down (..)
                den = su / (hi - g0) - sd / (lo - g0)
                if den != 0.0:
                    ref += (su - sd) / den
            state.aux[k + AUX_REF, i, j] = ref
        if P.lifetime > 0.0:
            t = P.lifetime * (1.0 + P.lifetime_dtod * (rng.normal() if P.lifetime_dtod > 0.0
                                                         else 0.0))
            state.aux[k + AUX_DECAY, i, j] = 1.0 - 1.0 / t if t > 1.0 else 0.0
        if P.reset_dtod > 0.0:
            state.aux[k + AUX_RESET, i, j] = (P.reset + P.reset_dtod * rng.normal()) * grange


def calibration_readout(state: State) -> float:
    """The mean |output| of one read per input line with a one-hot input (at least 1e-4)."""
    rows, cols = state.Gp.shape
    total = 0.0
    for j in range(cols):
        for v in read(state, np.eye(cols)[j], False):
            total += abs(v)
    state.counters[CALIBRATION_READS] += cols
    return max(total / (rows * cols), 1e-4)


def elapse(state: State, seconds: float) -> None:
    """Drift, accumulated 1/f read noise and compensation over ``seconds``
    (``time.xbar_elapse``)."""
    P = state.params
    fresh = P.rn1f > 0.0
    if not (seconds > 0.0 or (fresh and seconds == 0.0)):
        return
    periphery = P.drift_compensation and P.compensation_read == COMP_PERIPHERY
    cal_before = calibration_readout(state) if periphery else 0.0
    rng = Stream(state)
    t0 = P.drift_t0
    before = after = 0.0
    rows, cols = state.Gp.shape
    for i in range(rows):
        for j in range(cols):
            before += abs(state.Gp[i, j] - state.Gm[i, j])
            for d in range(2):
                a = state.age[d, i, j]
                state.age[d, i, j] = a + seconds
                if state.stuck[d, i, j] != OK:
                    continue
                G = device(state, d)[i, j]
                nu = state.nu[d, i, j]
                if fresh:  # the previous draw taken off
                    G = G - state.rn[d, i, j]
                G = max(G * ((a + seconds + t0) / (a + t0)) ** (-nu), P.g_min)
                if fresh:  # q_s of the conductance as written, the std of the drifted one
                    t = a + seconds + t0
                    g_prog = G * (t / t0) ** nu
                    q = min(P.rn1f_q0 / max((abs(g_prog) / P.g_max) ** P.rn1f_qexp, 1e-3),
                            P.rn1f_qmax)
                    t_read = P.rn1f_t_read
                    sig = P.rn1f * q * math.sqrt(math.log((t + t_read) / (2.0 * t_read)))
                    Gn = max(G + abs(G) * sig * rng.normal(), P.g_min)
                    state.rn[d, i, j] = Gn - G
                    G = Gn
                device(state, d)[i, j] = G
            after += abs(state.Gp[i, j] - state.Gm[i, j])
    state.counters[RNG_DRAWS] += rng.close()
    if periphery:
        state.alpha[0] *= cal_before / calibration_readout(state)
    elif P.drift_compensation and after > 0.0:
        state.alpha[0] *= before / after
    state.elapsed[0] += seconds
