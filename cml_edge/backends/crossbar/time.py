"""The crossbar over time: programming at construction, drift, accumulated 1/f read
noise, drift compensation.

Each device keeps the time since its last write (``state.age``), its drift exponent nu
(``state.nu``, from its fixed normal ``state.nu_z``) and its accumulated read-noise draw
(``state.rn``); every write restarts its clock (:func:`mark_written`). ``elapse(t)`` drifts
every unstuck device, G <- G ((a + t + t0) / (a + t0))^-nu (the power law
G0 ((t + t0) / t0)^-nu since its last write), and, with ``rn1f``, replaces its
accumulated read noise by a fresh persistent draw; drift compensation rescales the
outputs by the ratio of a calibration read before and after (``state.alpha[0]``).
The device model and the sources of its numbers: :mod:`cml_edge.backends.crossbar.config`.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from cml_edge.backends.crossbar.codes import (
    AUX_DECAY,
    AUX_GAMMA_DOWN,
    AUX_GAMMA_UP,
    AUX_PLANES,
    AUX_REF,
    AUX_RESET,
    BOUND_AIHWKIT,
    BOUND_SYMMETRIC,
    CALIBRATION_READS,
    COMP_PERIPHERY,
    OK,
    ONE_SIDED,
    PAIR_GRID,
    REFERENCE,
    RNG_DRAWS,
    SINGLE,
    SPREAD_LOGNORMAL,
    SPREAD_MULT,
    STUCK_HIGH,
    STUCK_LOW,
    TWO_SIDED,
)
from cml_edge.backends.crossbar.conductance import (
    pair_targets,
    prog_sigma,
    reference_level,
    snap_to_level,
)
from cml_edge.backends.crossbar.read import read
from cml_edge.jit.gauss import normal_at
from cml_edge.jit.kernel import kernel
from cml_edge.jit.rng import uniform

_ONE = np.uint64(1)


@kernel
def nu_of(g, z, P):
    """The drift exponent of a device written to g with fixed normal z (``drift_nu_g``)."""
    lg = math.log(max(abs(g / P.g_max), 1e-7))
    mu = min(max(P.nu_a * lg + P.nu_b, P.nu_lo), P.nu_hi)
    sd = min(max(P.nu_sa * lg + P.nu_sb, P.nu_slo), P.nu_shi)
    return abs(mu + sd * z)


@njit(cache=True, inline="always")
def mark_written(age, rn, nu, nu_z, P, d, i, j, g):
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
    upper and lower bound (``bound_spread``; a lower bound >= 0 uS unless ``aihwkit``),
    which clip it. Then, only where configured, per device the aihwkit extras
    (:func:`_draw_aux`) and, with ``apply_write_noise_on_set``, one normal per device for
    its write-noise offset. With the ``single`` mapping G- is the fixed reference
    (stuck code ``REFERENCE``): its draws are made, and it holds the reference exactly.
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
                if P.scale_spread == SPREAD_MULT:
                    s = max(1.0 + P.dw_min_dtod * z1, 0.0)
                    a = P.up_down + P.up_down_dtod * z2
                    state.step[2 * d, i, j] = max(s * (1.0 + a), 0.0)
                    state.step[2 * d + 1, i, j] = max(s * (1.0 - a), 0.0)
                else:  # aihwkit: gain + r up, gain - r down, up_down shrinking one of them
                    gain = math.exp(P.dw_min_dtod * z1) if P.scale_spread == SPREAD_LOGNORMAL \
                        else 1.0 + P.dw_min_dtod * z1
                    r = P.up_down_dtod * z2
                    state.step[2 * d, i, j] = abs(min(P.up_down, 0.0) + gain + r)
                    state.step[2 * d + 1, i, j] = abs(-max(P.up_down, 0.0) + gain - r)
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
    single = P.mapping == SINGLE
    pair = P.pair_grid == PAIR_GRID and P.dG > 0.0 and P.mapping == TWO_SIDED
    ref = reference_level(P)
    for i in range(rows):
        for j in range(cols):
            w = W[i, j] if single else min(max(W[i, j], -w_max), w_max)  # (a single
            # device holds what its range holds: clipped as a conductance below)
            tp = tm = 0.0
            if pair:  # the pair's difference on the grid, split around the centre
                tp, tm = pair_targets(math.floor(w * P.g_per_w / P.dG + 0.5), g_min, g_max,
                                      P.dG)
            for d in range(2):
                if single:  # the device about the reference, and the reference
                    t = ref + w * P.g_per_w if d == 0 else ref
                elif one_sided:
                    t = g_min + max(w if d == 0 else -w, 0.0) * P.g_per_w
                elif pair:
                    t = tp if d == 0 else tm
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
                if single and d == 1:  # the reference: exact, never stuck (its draws made)
                    G = ref
                    state.stuck[d, i, j] = REFERENCE
                elif code == STUCK_LOW:
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
                    if P.bound_spread == BOUND_AIHWKIT:
                        b_lo, b_hi = aihwkit_bounds(g0, zu, zl, P)
                    else:
                        ru = max(abs(1.0 + P.bound_dtod_up * zu), 1e-3)
                        rl = max(abs(1.0 + P.bound_dtod_down * zl), 1e-3)
                        if P.bound_spread != BOUND_SYMMETRIC:  # only inward
                            ru = min(ru, 1.0)
                            rl = min(rl, 1.0)
                        b_lo = max(g0 - (g0 - g_min) * rl, 0.0)
                        b_hi = g0 + (g_max - g0) * ru
                    state.bnd[2 * d, i, j] = b_lo
                    state.bnd[2 * d + 1, i, j] = b_hi
                    if state.stuck[d, i, j] != OK:
                        continue
                    if d == 0:
                        Gp[i, j] = min(max(Gp[i, j], b_lo), b_hi)
                    else:
                        Gm[i, j] = min(max(Gm[i, j], b_lo), b_hi)
    if has_aux(P):
        ctr = _draw_aux(state.step, state.bnd, state.aux, P, key, ctr)
    if P.apply_write_noise_on_set and P.write_noise > 0.0:
        for i in range(rows):
            for j in range(cols):
                for d in range(2):
                    z, ctr = normal_at(key, ctr)
                    if state.stuck[d, i, j] != OK:
                        continue
                    h = Gp[i, j] if d == 0 else Gm[i, j]
                    G = h + P.write_noise * P.dP * z
                    if P.write_noise_clip:
                        G = min(max(G, g_min), g_max)
                    state.wn[d, i, j] = G - h
                    if d == 0:
                        Gp[i, j] = G
                    else:
                        Gm[i, j] = G
    state.rng[1] = ctr
    return np.int64(ctr - start)


@njit(cache=True, inline="always")
def aihwkit_bounds(g0, zu, zl, P):
    """A device's bounds (lo, hi) as aihwkit's ``PulsedRPUDevice::populate`` draws them
    (``bound_spread`` aihwkit): u = (g_max - G0)(1 + bound_dtod_up zu) and
    l = (G0 - g_min)(1 + bound_dtod_down zl) from G0, swapped where G0 - l > G0 + u, then
    hi = G0 + |u|, lo = G0 - |l| (``enforce_consistency``)."""
    u = (P.g_max - g0) * (1.0 + P.bound_dtod_up * zu)
    lo = g0 - (g0 - P.g_min) * (1.0 + P.bound_dtod_down * zl)
    hi = g0 + u
    if lo > hi:
        lo, hi = hi, lo
    return g0 - abs(g0 - lo), g0 + abs(hi - g0)


@njit(cache=True, inline="always")
def has_aux(P):
    """Whether the config draws per-device extras into ``aux``: spread linear-step slopes,
    a reference, decay, or a spread reset bias."""
    return (P.gamma_up_dtod > 0.0 or P.gamma_down_dtod > 0.0 or has_reference(P)
            or P.lifetime > 0.0 or P.reset_dtod > 0.0)


@njit(cache=True, inline="always")
def has_reference(P):
    """Whether each device has a reference subtracted (aihwkit ``SoftBoundsReference``)."""
    return P.reference_mean != 0.0 or P.reference_std > 0.0 or P.subtract_symmetry_point != 0


@kernel
def _draw_aux(step, bnd, aux, P, key, ctr):
    """Each device's aihwkit extras, device by device, row by row, G+ before G- (a normal
    only where its spread is nonzero): slopes |gamma + gamma_dtod z| up then down
    (``LinearStepRPUDevice::populate``); the reference (reference_mean + reference_std z)
    range, plus the symmetry point (``SoftBoundsReferenceRPUDevice::populate``); the
    decay scale 1 - 1 / t, t = lifetime (1 + lifetime_dtod z) (0 where t <= 1); the reset
    bias (reset + reset_dtod z) range (``PulsedRPUDevice::populate``)."""
    rows, cols = step.shape[1], step.shape[2]
    grange = P.g_max - P.g_min
    g0 = P.g_min + P.step_center * grange
    for i in range(rows):
        for j in range(cols):
            for d in range(2):
                k = AUX_PLANES * d
                if P.gamma_up_dtod > 0.0 or P.gamma_down_dtod > 0.0:
                    zu, ctr = normal_at(key, ctr)
                    zd, ctr = normal_at(key, ctr)
                    aux[k + AUX_GAMMA_UP, i, j] = abs(P.gamma_up + P.gamma_up_dtod * zu)
                    aux[k + AUX_GAMMA_DOWN, i, j] = abs(P.gamma_down + P.gamma_down_dtod * zd)
                if has_reference(P):
                    z = 0.0
                    if P.reference_std > 0.0:
                        z, ctr = normal_at(key, ctr)
                    ref = (P.reference_mean + P.reference_std * z) * grange
                    lo = bnd[2 * d, i, j]
                    hi = bnd[2 * d + 1, i, j]
                    if P.subtract_symmetry_point and hi > g0 and lo < g0:
                        su = step[2 * d, i, j]
                        sd = step[2 * d + 1, i, j]
                        den = su / (hi - g0) - sd / (lo - g0)
                        if den != 0.0:
                            ref += (su - sd) / den
                    aux[k + AUX_REF, i, j] = ref
                if P.lifetime > 0.0:
                    z = 0.0
                    if P.lifetime_dtod > 0.0:
                        z, ctr = normal_at(key, ctr)
                    t = P.lifetime * (1.0 + P.lifetime_dtod * z)
                    aux[k + AUX_DECAY, i, j] = 1.0 - 1.0 / t if t > 1.0 else 0.0
                if P.reset_dtod > 0.0:
                    z, ctr = normal_at(key, ctr)
                    aux[k + AUX_RESET, i, j] = (P.reset + P.reset_dtod * z) * grange
    return ctr


@kernel
def _calibration_readout(state):
    """The drift-compensation readout through the periphery (aihwkit
    ``GlobalDriftCompensation``): one read per input line with a one-hot input, the mean
    |output| over all of them (at least 1e-4). Its inputs and outputs live in
    ``state.sbuf``."""
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
