"""Device configuration of the memristive crossbar array, as data, with named presets.

Every number a crossbar emulation depends on is a field of :class:`DeviceConfig`
(frozen, documented, validated); a preset is a named set of field values; every field
can be overridden (``--set field=value`` on the command line, ``--levels N``,
``--preset NAME``). The kernels cannot read a dataclass: they read
:class:`CrossbarParams`, the record derived from the config's numeric fields plus the
array's derived quantities (:func:`crossbar_params`; :mod:`cml_edge.backends.params`).

Presets and where their numbers come from (each figure with its public source: IBM
aihwkit, Sandia CrossSim and the papers they implement):

``ideal``
    no non-idealities: continuous conductance (``levels = 0``), exact analog updates
    and programming, no noise, ideal converters, no drift, no faults, w_max = 4 max|W0|
    (nothing clipped, even as the weights grow). Reproduces the float64 result (to
    rounding).
``pcm``
    IBM aihwkit's statistical PCM model (HEAD 4545f11; ``inference/noise/pcm.py``
    ``PCMLikeNoiseModel``, ``presets/devices.py`` ``PCMPresetDevice``,
    ``presets/compounds.py`` ``PCMPresetUnitCell``, ``parameters/io.py``
    ``IOParameters``, ``inference/compensation/drift.py``), one number per source:

    - range 0..25 uS (``SinglePairConductanceConverter`` g_max / g_min), one-sided
      mapping (the same converter; also CrossSim's default ``ONE_SIDED``);
    - programming noise polynomial (0.26348, 1.9650, -1.1731) uS at 25 uS
      (``PCMLikeNoiseModel.prog_coeff``);
    - drift: t0 = 20 s; nu from the target conductance, mean clip(-0.0155 ln g +
      0.0244, 0.049, 0.1), std clip(-0.0125 ln g - 0.0059, 0.008, 0.045), folded
      (``generate_drift_coefficients``);
    - accumulated 1/f read noise q_s = min(0.0088 / g^0.65, 0.2), t_read = 250 ns, scale 1
      (``apply_drift_noise_to_conductance``);
    - SET-only pairs with refresh at 0.75 / 0.25 of the range (``OneSidedUnitCell``,
      ``PCMPresetUnitCell``: refresh_every 1, default thresholds), open loop: every pair
      read after every update with the refresh read's out_noise 0.06 of the 0..2 range
      (``refresh_read_noise`` 0.03), the read difference rewritten by one pulse-train
      pair, no verify (``OneSidedRPUDevice::refreshWeights``);
    - ExpStep pulses (``PCMPresetDevice``, Nandakumar et al. 2020): dw_min 0.01 of a
      0..2 range (dG = 0.125 uS, ``levels`` 201), a = -1, b = 0 (``step_center`` 0),
      A_up = -27.235, A_down = -2.235, gamma 2.5 / 2.5, dw_min_dtod 0.2, up_down_dtod
      0.05, w_max_dtod 0.1 (``bound_dtod_up``, spread both ways: ``bound_spread``
      symmetric), w_min_dtod 0, dw_min_std 0.6 with dw_min_std_add 0.042 and slope 0.108
      (``c2c`` complex, add 0.042 / 2 of the range), Gaussian, so a SET pulse may lower G
      (``set_noise`` gauss; ``rpu_expstep_device.cpp`` ``update_once_complex_noise``);
      steps 3.2 / 0.40 / 0.16 uS at 0.5 / 12.5 / 24 uS; 56 pulses from 0 to 22.5 uS;
    - the controller counts a pulse as the mean step over that sweep (``pulse_gain`` 3.2,
      :data:`PCM_PULSE_GAIN`);
    - periphery from ``IOParameters`` defaults: 7-bit DAC (inp_res 1/126), 9-bit ADC
      (out_res 1/510) with bound 12, out_noise 0.06, bound management ITERATIVE (5 passes
      at most); w_noise 0 (``InferenceRPUConfig``: no per-read weight noise);
    - global drift compensation on, read through the periphery
      (``InferenceRPUConfig.drift_compensation = GlobalDriftCompensation()``).
``reram``
    Sandia CrossSim ``RRAM_Milo`` (Milo et al., IRPS 2021): 50..225 uS (on/off 4.5),
    programming noise sigma = max(4.782321 - 0.009107 G, 0) uS; no drift model; one-sided
    mapping (CrossSim's default); pulsed device from aihwkit ``ReRamSBPresetDevice``
    (Gong et al. 2018): soft bounds at w_max 1.25 / w_min -0.75 (``step_center`` 0.375:
    asymmetric), dw_min = 0.002 of the 2-wide range (``levels`` 1001), bound spread
    w_max_dtod 0.3 / 1.25 = 0.24, w_min_dtod 0.3 / 0.75 = 0.4 both ways (``bound_spread``
    symmetric; ``PulsedRPUDevice::populate``), dw_min_dtod 0.3,
    up_down_dtod 0.01, additive cycle-to-cycle noise 3.75 dw_min (``mult_noise`` False),
    write noise 56 dw_min, unclipped (``write_noise_clip`` off;
    ``rpu_softbounds_reference_device.cpp``); read noise 1 % of the range per device and read (the
    reference's ReRAM weight noise); 7-bit DAC / 9-bit ADC, bound 12, bound management
    ITERATIVE, no output noise.
``pcm-symmetric``, ``reram-symmetric``
    The ``pcm`` and ``reram`` presets of earlier releases, unchanged, so that earlier
    results stay reproducible bit for bit: two-sided pairs, bidirectional steps that
    shrink linearly to both ends of the range (``bounds`` soft), nu = 0.049 +- 0.008 at
    every conductance, no accumulated read noise, no refresh. Their ``levels`` read
    aihwkit's dw_min as 201 (PCM) and 1001 (ReRAM) evenly spaced levels.

``aihwkit:NAME``
    Each of aihwkit 1.1.0's eleven presets (its ten preset devices and
    ``PCMPresetUnitCell``) with aihwkit's own parameters, read from the committed snapshot
    ``cml_edge/data/aihwkit_presets.json`` and mapped onto these fields, aihwkit's
    behaviours switched on where it differs (``bound_spread``, ``scale_spread``,
    ``pulse_step``, ``reference_*``, ``lifetime``, ``refresh_write`` aihwkit...):
    :mod:`cml_edge.backends.crossbar.aihwkit.presets`.

The device presets use the per-walk accumulate-then-pulse commit and the pulsed update,
and the same weight scale (w_max_q, w_max_k automatic = max|W0|; w_max_v = 0.02,
see :class:`DeviceConfig`). Stuck devices are 0 in the presets (aihwkit keeps its
measured corrupt-device fractions, 10-13.5 % for its ReRAM arrays, off by default);
sweep them with ``--set stuck_low=...``.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any

from cml_edge.backends.base import MAX_IDLE_S
from cml_edge.backends.device import CostModel, Knob
from cml_edge.backends.fields import (
    check_ranges,
    check_types,
    matrix_value,
    option,
    resolve,
)
from cml_edge.backends.params import build_record, kernel_record
from cml_edge.errors import InputError

UPDATES = ("analog", "pulsed")
COMMITS = ("program", "pulse")
BOUNDS = ("hard", "soft")
MAPPINGS = ("two-sided", "one-sided", "single")
STEP_MODELS = ("bounds", "linear", "soft", "exp", "pow")
C2C_MODELS = ("mult", "add", "complex")
COMPENSATION_READS = ("ideal", "periphery")
BOUND_SPREADS = ("inward", "symmetric", "aihwkit")
SCALE_SPREADS = ("mult", "add", "lognormal")
SET_NOISES = ("lognormal", "gauss")
REFRESH_WRITES = ("verify", "open-loop", "aihwkit")
PAIR_GRIDS = ("device", "pair")
DEFAULT_PRESET = "pcm"

# the reasons of the fields' ranges (fields.option): from the physics or the arithmetic
G_US = "a conductance in uS, up to 10 mS (a 100-ohm device is a short)"
LEVELS = ("0 = continuous, else 2..4096: the most levels shown in one analog device is 2048 "
          "(Rao et al., Nature 2023)")
W_MAX = ("weight units; 0 = automatic, else >= 1e-3 (the CML's learned weights are ~1e-3 "
         "and more: a smaller swing clips them all)")
EXP_Z = "z = 2 a (u - c) + b within +-30 and gamma <= 20 keep e^(gamma z) finite"
BITS = "bits a converter resolves, 24 at most (none resolves more); 0 = ideal"
NU = "a drift exponent (PCM measures 0.005..0.1)"
FRACTION = "a fraction of the conductance range"
REL_STD = "a relative std"
W_MAX_MIN = 1e-3


@dataclass(frozen=True)
class DeviceConfig:
    """The devices and periphery of one crossbar (units: micro-siemens, seconds)."""

    # conductance range and the weight-to-conductance scale ---------------------------
    g_min: float = option(0.0, lo=0.0, hi=10000, why=G_US)
    """Lowest device conductance (uS)."""
    g_max: float = option(25.0, lo=0.001, hi=10000, why=G_US)
    """Highest device conductance (uS)."""
    levels: int = option(0, flag="--levels", metavar="N",
                         help="crossbar conductance levels per device (>= 2; 0 = continuous)",
                         lo=0, hi=4096, why=LEVELS)
    """Programmable states per device, evenly spaced on [g_min, g_max]; 0 = continuous.
    One pulse moves a device by one level: dw_min = 2 w_max / (levels - 1) (or by
    ``pulse_step`` on a continuous conductance)."""
    w_headroom: float = option(1.0, kernel=False,
                               lo=0.01, hi=100.0, why="a multiple of the matrix's max|W|")
    """Automatic scale: w_max = w_headroom x max|W| of the matrix programmed (aihwkit maps
    max|W| to g_max: headroom 1). Weights that later grow past w_max clip at the bounds."""
    w_max_q: float = option(0.0, per_matrix=("w_max", 0),
                            lo=0.0, hi=100.0, why=W_MAX)
    """Weight of a full conductance swing for W_q (index 0); 0 = automatic (w_headroom)."""
    w_max_k: float = option(0.0, per_matrix=("w_max", 1),
                            lo=0.0, hi=100.0, why=W_MAX)
    """The same for W_k (index 1)."""
    w_max_v: float = option(0.0, per_matrix=("w_max", 2),
                            lo=0.0, hi=100.0, why=W_MAX)
    """The same for W_v (index 2). The CML's learned W_v is far smaller than its
    N(0, 0.1^2) init (W_v a learns W_q delta), so the device presets set 0.02: resolution
    where the learned weights live; the init is clipped at programming (the sizes
    measured, and what this does to convergence: docs/devices/crossbar.md)."""

    # the in-situ update --------------------------------------------------------------
    update: str = option("analog", choices=UPDATES)
    """In-place update (``defer`` False): ``pulsed`` stochastic coincidences
    (Gokmen & Vlasov 2016) or ``analog`` (the exact change; with a grid, stochastically
    rounded to it: an ideal device)."""
    commit: str = option("program", choices=COMMITS)
    """Per-walk schedule (``defer`` True): the update is summed in a digital accumulator
    and, at commit, ``pulse``: n = trunc(acc / dw_min) pulses sent to each pair, the
    remainder kept in the accumulator (mixed precision, Nandakumar et al. 2020); or
    ``program``: write-verify of each pair whose target moved (by n levels, or by acc
    exactly when continuous) with fresh programming noise."""
    bl_max: int = option(31, lo=1, hi=31,
                         why="stochastic pulse trains of at most 31 (Gokmen & Vlasov 2016)")
    """Longest stochastic pulse train (BL <= 31, Gokmen & Vlasov 2016)."""
    dw_min_dtod: float = option(0.0, lo=0.0, hi=1.0, why="a relative std (aihwkit ReRAM 0.3)")
    """Device-to-device spread of the pulse step (relative std, fixed per device)."""
    dw_min_std: float = option(0.0, lo=0.0, hi=10.0,
                               why="a relative std of a step (ReRAM's measured 3.75)")
    """Cycle-to-cycle spread of the pulse step (relative std, fresh per pulse)."""
    up_down: float = option(0.0, lo=-0.999, hi=0.999,
                            why="up steps x (1 + a), down steps x (1 - a): |a| < 1")
    """Mean up/down asymmetry: up steps x (1 + a), down steps x (1 - a)."""
    up_down_dtod: float = option(0.0, lo=0.0, hi=1.0, why="a std of the asymmetry a")
    """Device-to-device spread of the asymmetry a (std)."""
    bounds: str = option("hard", choices=BOUNDS)
    """``hard``: a device clips at g_min / g_max; ``soft``: the step shrinks linearly to
    zero at the bound it moves toward (1 at mid-range)."""

    pair_grid: str = option("device", choices=PAIR_GRIDS)
    """What ``levels`` quantise on a ``two-sided`` pair written exactly (programming, a
    ``program`` commit, an ``analog`` update; a pulse always moves each device one step):
    ``device`` (earlier releases): each device on its own grid, G+ = g_c + w g_per_w / 2
    and G- = g_c - w g_per_w / 2 snapped separately and moved n levels each, so the
    weight moves in steps of 2 dG / g_per_w, and with an even number of levels (g_c
    between two levels) it holds only odd multiples of dG / g_per_w: never 0, and a
    weight below one level reads as +-dG / g_per_w; ``pair``: the pair's difference
    k dG, k an integer (2 levels - 1 weights, 0 among them whatever the parity), split
    around the level c nearest g_c: G+ = c + (k - floor(k / 2)) dG, G- = c - floor(k / 2)
    dG. A commit then moves k by whole levels, n = trunc(acc g_per_w / dG), an analog
    update by floor(lr post pre g_per_w / dG + u), each retargeting both devices from
    the difference they hold. The resolution a pair has, not half of it, and a grid
    whose weights do not depend on the parity of ``levels``."""

    # programming noise ---------------------------------------------------------------
    prog_noise: float = option(0.0, lo=0.0, hi=100.0,
                               why="a scale of the measured model (1 = as measured)")
    """Scale of the programming-noise model (aihwkit ``prog_noise_scale``); 0 = none."""
    prog_c0: float = option(0.26348, lo=-1000.0, hi=1000.0, why="polynomial coefficients in uS")
    """Programming-noise polynomial c0 (uS at g_ref); see cml_edge.backends.crossbar.conductance."""
    prog_c1: float = option(1.9650, lo=-1000.0, hi=1000.0, why="polynomial coefficients in uS")
    """c1 (uS at g_ref, per unit G/g_max)."""
    prog_c2: float = option(-1.1731, lo=-1000.0, hi=1000.0, why="polynomial coefficients in uS")
    """c2 (uS at g_ref, per unit (G/g_max)^2)."""
    prog_gref: float = option(25.0, lo=0.001, hi=10000, why=G_US)
    """The g_max the coefficients were fitted at (uS)."""

    # reads ---------------------------------------------------------------------------
    read_noise: float = option(0.0, lo=0.0, hi=1.0,
                               why="a std as a fraction of the conductance range")
    """Conductance fluctuation of each device at each read, std relative to
    g_max - g_min (fresh on every W x and W^T y)."""
    out_noise: float = option(0.0, lo=0.0, hi=10.0,
                              why="a std in normalised output units (the ADC's bound is 12)")
    """Additive noise at each output before the ADC, std in normalised units
    (aihwkit ``out_noise``; fresh on every read)."""
    dac_bits: int = option(0, lo=2, hi=24, off=0, why=BITS)
    """DAC bits on inputs scaled by max|x| (0 = ideal)."""
    adc_bits: int = option(0, lo=2, hi=24, off=0, why=BITS)
    """ADC bits on outputs (0 = ideal)."""
    adc_bound: float = option(12.0, lo=0.001, hi=1000.0, why="normalised output units (aihwkit 12)")
    """ADC range, normalised units (aihwkit ``out_bound``)."""

    # drift ---------------------------------------------------------------------------
    drift_nu: float = option(0.0, lo=0.0, hi=1.0, why="a drift exponent (PCM measures 0.005..0.1)")
    """Mean drift exponent: G(t) = G0 ((t + t0) / t0)^-nu, t since the device's last write."""
    drift_nu_std: float = option(0.0, lo=0.0, hi=1.0, why="a drift exponent's std")
    """Device-to-device std of nu (fixed per device, clipped at 0)."""
    drift_t0: float = option(20.0, lo=1e-06, hi=MAX_IDLE_S,
                             why="seconds, within the longest idle time (MAX_IDLE_S)")
    """Drift reference time t0 (s)."""
    drift_compensation: bool = False
    """Global drift compensation: one output scale per array, from a calibration read
    (sum |G+ - G-|) before and after the drift."""

    # calibrated device physics. Every field below is off at its default, so
    # a config that does not name it behaves, draw for draw, as before these fields
    # existed; a model file saved before them restores with these defaults, whatever
    # its preset says now (cml_edge/core/legacy.py). ----------------------------------
    mapping: str = option("two-sided", choices=MAPPINGS)
    """Weight to conductance map of a pair (both in [g_min, g_max]). ``two-sided`` (earlier
    releases; CrossSim ``TWO_SIDED``): both devices at the centre for w = 0, moving
    apart by w g_per_w / 2 each. ``one-sided`` (aihwkit ``SinglePairConductanceConverter``,
    CrossSim's default ``ONE_SIDED``): G+ = g_min + max(w, 0) g_per_w, G- = g_min +
    max(-w, 0) g_per_w: one device idles at g_min, where it drifts least in absolute
    terms. Both have g_per_w = (g_max - g_min) / w_max. ``single``: one device per
    weight (aihwkit's ``SingleRPUConfig`` tile), G = R + w g_per_w with g_per_w =
    (g_max - g_min) / (2 w_max), read against a reference R fixed at the level nearest
    the weight zero G0 = g_min + step_center (g_max - g_min) (a reference column
    written once: no noise, drift or fault of its own); a pulse moves the one device up
    or down, so the weight step dw_min is a two-sided pair's and the weights span
    -2 step_center w_max .. 2 (1 - step_center) w_max (-w_max .. w_max at the default
    centre; programming clips a weight to that range, not to +-w_max). Not with
    ``set_only`` or ``refresh`` (they need a partner device)."""
    set_only: bool = False
    """SET-only devices (PCM: crystallisation is gradual, RESET is abrupt; aihwkit
    ``OneSidedUnitCell``): each pulse only potentiates, the weight decreases by
    potentiating the partner (G-). One pulse moves one device, so the nominal weight
    step is dG / g_per_w (half a two-sided pair's)."""
    refresh: bool = False
    """Refresh of saturated pairs (aihwkit ``OneSidedUnitCell.refresh``): after a pair
    is pulsed, if its larger device is above ``refresh_upper`` of the range and its
    smaller above ``refresh_lower``, both are RESET and the pair's difference is
    write-verified onto the device that was larger (programming noise). Counted:
    ``refreshes`` and ``refresh_pulses`` (two RESETs plus the SET pulses of the mean
    device from g_min to the target)."""
    refresh_upper: float = option(0.75, lo=0.001, hi=0.999, why=FRACTION)
    """Refresh threshold of the larger device, fraction of the range (aihwkit 0.75)."""
    refresh_lower: float = option(0.25, lo=0.001, hi=0.999, why=FRACTION)
    """Refresh threshold of the smaller device, fraction of the range (aihwkit 0.25)."""
    pulse_gain: float = option(1.0, lo=0.01, hi=100.0, why="a pulse's mean step in units of dG")
    """The conductance change per pulse the update controller assumes, in units of dG
    (it sets dw_min, the weight a pulse is counted as). 1 = the level spacing (earlier
    releases). A device whose real steps differ from dG (``step_model``) is calibrated
    by setting this to its mean step over the range: (0.9 range / pulses to 90 %) / dG,
    as ``cml-edge device characterize`` measures it."""
    step_model: str = option("bounds", choices=STEP_MODELS)
    """Response of a device to one pulse of nominal size s dG (s its up or down scale):
    ``bounds`` (earlier releases): constant (``bounds`` hard) or shrinking linearly to
    the range's ends, 2 (g_max - G) / range up (``bounds`` soft); ``linear`` (aihwkit
    ``LinearStep``): 1 - gamma_up (G - G0) / (hi - G0) up, 1 - gamma_down (G - G0) /
    (lo - G0) down; ``soft`` (``SoftBounds``): the same with gamma 1, so the step is zero
    at each of the device's bounds lo / hi, and asymmetric when G0 (``step_center``)
    is not mid-range; ``exp`` (``ExpStep``): u = (G - lo) / (hi - lo), z = 2 exp_a
    (u - step_center) + exp_b, max(1 - exp_a_up e^(exp_gamma_up z), 0) up and
    max(1 - exp_a_down e^(-exp_gamma_down z), 0) down; ``pow`` (``PowStep``):
    ((hi - G) / (hi - lo))^pow_gamma up, ((G - lo) / (hi - lo))^pow_gamma down.
    lo / hi are the device's own bounds (``bound_dtod_*``), G0 its weight zero
    (``bound_spread``)."""
    step_center: float = option(0.5, lo=0.0, hi=0.999, why=FRACTION)
    """Where the device's weight zero G0 sits in its range (fraction): aihwkit's
    -w_min / (w_max - w_min): 0.5 symmetric, 0.375 for ReRAM (w in -0.75..1.25), 0 for
    PCM (w in 0..2)."""
    gamma_up: float = option(1.0, lo=0.0, hi=100.0, why="a slope of the step against G")
    """``linear`` step: slope of the up step against G (aihwkit ``gamma_up``)."""
    gamma_down: float = option(1.0, lo=0.0, hi=100.0, why="a slope of the step against G")
    """``linear`` step: slope of the down step (aihwkit ``gamma_down``)."""
    exp_a: float = option(0.244, lo=-10.0, hi=10.0, why=EXP_Z)
    """``exp`` step: a (aihwkit ``ExpStepDevice`` default 0.244)."""
    exp_b: float = option(0.2425, lo=-10.0, hi=10.0, why=EXP_Z)
    """``exp`` step: b (default 0.2425)."""
    exp_a_up: float = option(0.00081, lo=-1000.0, hi=1000.0,
                             why="a step prefactor (aihwkit PCM -27.235)")
    """``exp`` step: A_up (default 0.00081)."""
    exp_a_down: float = option(0.36833, lo=-1000.0, hi=1000.0,
                               why="a step prefactor (aihwkit PCM -2.235)")
    """``exp`` step: A_down (default 0.36833)."""
    exp_gamma_up: float = option(12.44625, lo=0.0, hi=20.0, why=EXP_Z)
    """``exp`` step: gamma_up (default 12.44625)."""
    exp_gamma_down: float = option(12.78785, lo=0.0, hi=20.0, why=EXP_Z)
    """``exp`` step: gamma_down (default 12.78785)."""
    pow_gamma: float = option(1.0, lo=0.001, hi=10.0, why="an exponent of the step's shape")
    """``pow`` step: the exponent (aihwkit ``PowStepDevice`` pow_gamma 1.0)."""
    c2c: str = option("mult", choices=C2C_MODELS)
    """Cycle-to-cycle noise of a step (std ``dw_min_std``, z fresh per pulse):
    ``mult`` (earlier releases, aihwkit ``mult_noise``): step x (1 + dw_min_std z);
    ``add`` (``SoftBoundsReference`` default): s dG (factor + dw_min_std z), the same
    spread wherever the device is; ``complex`` (``ExpStep`` with dw_min_std_add/slope):
    step + dw_min_std (|step| + c2c_add (g_max - g_min) + c2c_slope |G - G0|) z. A SET
    pulse of a ``set_only`` device never lowers G: its step is log-normal with the same
    mean and std (aihwkit's Gaussian lets a SET pulse lower G)."""
    c2c_add: float = option(0.0, lo=0.0, hi=1.0, why=FRACTION)
    """``complex`` c2c: constant term, fraction of the range (aihwkit dw_min_std_add
    0.042 of a 2-wide range: 0.021)."""
    c2c_slope: float = option(0.0, lo=0.0, hi=10.0, why="a std per unit |G - G0| (aihwkit 0.108)")
    """``complex`` c2c: term proportional to |G - G0| (aihwkit dw_min_std_slope 0.108)."""
    write_noise: float = option(0.0, lo=0.0, hi=1000.0, why="a std in units of dG (ReRAM 56)")
    """Write noise (aihwkit ``write_noise_std``), std in units of a pulse's step dG (or
    ``pulse_step``): a pulsed device reads as its hidden state plus N(0, (write_noise
    dG)^2), redrawn at each pulse (the hidden state is what the pulses move)."""
    bound_dtod_up: float = option(0.0, lo=0.0, hi=1.0, why=REL_STD)
    """Device-to-device spread of the upper bound: hi = G0 + (g_max - G0)(1 + d z),
    relative std (aihwkit ``w_max_dtod``), clipped to [G0, g_max]; drawn per device
    after the programming noise."""
    bound_dtod_down: float = option(0.0, lo=0.0, hi=1.0, why=REL_STD)
    """The same for the lower bound lo = G0 - (G0 - g_min)(1 + d z) (``w_min_dtod``)."""
    bound_spread: str = option("inward", choices=BOUND_SPREADS)
    """How ``bound_dtod_*`` spread the bounds: ``inward`` (earlier releases) clips
    |1 + d z| to [1e-3, 1], so a device's bounds only move toward G0 and its range only
    shrinks; ``symmetric`` (aihwkit ``PulsedRPUDevice::populate``: w_max (1 + w_max_dtod
    z), made positive by ``enforce_consistency``) keeps |1 + d z| >= 1e-3 unclipped above,
    so half the devices reach past g_min / g_max (pulses may take them there; a lower
    bound stays >= 0 uS), around the nominal weight zero G0 = g_min + step_center
    (g_max - g_min), which stays every device's zero (``inward``: G0 = lo + step_center
    (hi - lo) of the device's own bounds). The spread of the bounds with that of the
    scales (``dw_min_dtod``, ``up_down_dtod``) spreads the soft-bounds slopes
    s / (hi - G0) as aihwkit's does. ``aihwkit``: ``PulsedRPUDevice::populate`` itself,
    for a device whose weights are not conductances: hi = G0 + |u|, lo = G0 - |l| with
    u = (g_max - G0)(1 + d z), l = (G0 - g_min)(1 + d z), the two swapped first where
    G0 - l > G0 + u (``enforce_consistency``), no floor at 1e-3 of the range nor at
    0 uS."""
    scale_spread: str = option("mult", choices=SCALE_SPREADS)
    """How ``dw_min_dtod`` and ``up_down_dtod`` spread a device's up and down step scales
    (two normals z1, z2 per device either way): ``mult`` (earlier releases): s = max(1 +
    dw_min_dtod z1, 0), a = up_down + up_down_dtod z2, up max(s (1 + a), 0), down
    max(s (1 - a), 0); ``add`` (aihwkit ``PulsedRPUDevice::populate`` with
    ``enforce_consistency``): gain = 1 + dw_min_dtod z1, r = up_down_dtod z2, up |gain + r
    + min(up_down, 0)|, down |gain - r - max(up_down, 0)| (aihwkit's ``up_down`` shrinks
    one direction only); ``lognormal`` (aihwkit ``dw_min_dtod_log_normal``): the same with
    gain = exp(dw_min_dtod z1)."""
    pulse_step: float = option(0.0, lo=0.0, hi=1.0, why=FRACTION)
    """One pulse's nominal conductance step, a fraction of g_max - g_min (aihwkit
    ``dw_min`` / (``w_max`` - ``w_min``)); 0 = one level, 1 / (levels - 1) (earlier
    releases). Set, a pulse moves a device by this step whether or not it divides the
    range (``ReRamArrayHfO2PresetDevice``: 0.2311, 4.3 steps; ``IdealizedPresetDevice``:
    1e-4, 10,000 steps), and ``levels`` only grid what is written exactly (programming,
    write-verify): with ``levels`` 0, as aihwkit's ``set_weights``, nothing is."""
    gamma_up_dtod: float = option(0.0, lo=0.0, hi=10.0, why="a std of the slope gamma_up")
    """``linear`` step: device-to-device spread of ``gamma_up``, each device's own
    |gamma_up + gamma_up_dtod z| (aihwkit ``LinearStepDevice.gamma_up_dtod``, the slope
    forced positive as its ``allow_increasing`` False does); drawn per device at
    programming."""
    gamma_down_dtod: float = option(0.0, lo=0.0, hi=10.0, why="a std of the slope gamma_down")
    """The same for ``gamma_down`` (aihwkit ``gamma_down_dtod``)."""
    mean_bound_reference: bool = False
    """``linear`` step: the slope is referred to the nominal bounds, 1 - gamma (G - G0) /
    (g_max - G0) up and 1 - gamma (G - G0) / (g_min - G0) down, whatever the device's own
    bounds (aihwkit ``LinearStepDevice.mean_bound_reference``); off (earlier releases):
    to the device's own bounds hi / lo."""
    reference_mean: float = option(0.0, lo=-1.0, hi=1.0, why=FRACTION)
    """A reference device subtracted from each device (aihwkit
    ``SoftBoundsReferenceDevice``): a pulse moves the device's internal state G + ref,
    clipped to its bounds, and the device reads G; ref = (reference_mean +
    reference_std z) (g_max - g_min), z fixed per device (aihwkit ``reference_mean``, in
    weight units: divided by w_max - w_min here)."""
    reference_std: float = option(0.0, lo=0.0, hi=1.0, why=FRACTION)
    """The reference's device-to-device std, a fraction of the range (aihwkit
    ``reference_std``)."""
    subtract_symmetry_point: bool = False
    """The reference also holds the device's symmetry point, where its up and down steps
    are equal: ref += (s_up - s_down) / (s_up / (hi - G0) - s_down / (lo - G0)) for a
    device whose bounds straddle G0 (aihwkit ``subtract_symmetry_point``, soft bounds)."""
    lifetime: float = option(0.0, lo=0.0, hi=1e12, why="mini-batches (aihwkit 1e6)")
    """Decay (aihwkit ``lifetime``, in mini-batches): after every in-place update and
    every commit (one mini-batch), each device's hidden state moves toward its weight zero,
    h <- G0 + (h - G0) (1 - 1 / t), t = lifetime (1 + lifetime_dtod z) fixed per device
    (0 decay scale where t <= 1), clipped to its bounds, and a device with write noise
    reads a fresh offset (aihwkit ``decayWeights``, then ``applyUpdateWriteNoise``);
    0 = none."""
    lifetime_dtod: float = option(0.0, lo=0.0, hi=10.0, why=REL_STD)
    """Device-to-device spread of ``lifetime`` (aihwkit ``lifetime_dtod``)."""
    apply_write_noise_on_set: bool = False
    """Programming draws the write-noise offset too (aihwkit ``apply_write_noise_on_set``):
    a device holds its target and reads it plus N(0, (write_noise dG)^2) until its next
    pulse; off (earlier releases): it reads its target."""
    write_noise_clip: bool = True
    """Whether a device read through its write-noise offset is clipped to [g_min, g_max]
    (earlier releases) or not (aihwkit: w_apparent = w + write_noise_std dw_min z,
    unclipped; the hidden state stays within the device's bounds either way)."""
    set_noise: str = option("lognormal", choices=SET_NOISES)
    """Cycle-to-cycle noise of a SET pulse of a ``set_only`` device (``step_model`` other
    than ``bounds``): ``lognormal`` (earlier releases): log-normal with the model's mean
    and std, so a SET pulse never lowers G; ``gauss`` (aihwkit ``ExpStepRPUDevice``
    ``update_once_complex_noise``): step + sd z, so where sd exceeds the step (PCM above
    ~10 uS) a SET pulse lowers G about as often as it raises it."""
    refresh_write: str = option("verify", choices=REFRESH_WRITES)
    """How ``refresh`` rewrites a saturated pair: ``verify`` (earlier releases): checked
    after each pair is pulsed, on its true conductances; both devices RESET and the
    difference write-verified onto the larger (programming noise); ``open-loop`` (aihwkit
    ``OneSidedRPUDevice::refreshWeights`` with ``refresh_every`` 1): after every update
    and every commit, each pair of the array is read (each device G + N(0,
    (refresh_read_noise (g_max - g_min))^2)), and where the reads cross the thresholds
    both devices are RESET to g_min and the read difference D is written onto the device
    that read larger by one stochastic pulse train pair, as aihwkit's refresh update
    does for a pair alone in its column: BL = min(ceil(D / dG), bl_max) slots, each train
    firing with probability min(sqrt(D / (dG BL)), 1), one pulse per coincidence, no
    verify, without aihwkit's reset bias (0.01 +- 0.02 of w_max). ``aihwkit``
    (``refreshWeights`` itself): after every update and every commit, column by column,
    each device read as G0 plus its read G - G0 + N(0, (refresh_read_noise (g_max -
    g_min))^2) rounded to ``refresh_read_step``; the column's pairs whose reads cross the
    thresholds have their G+ devices RESET, then their G- devices (:attr:`reset`); then
    the read differences D_i where G+ read larger are written onto G+ by one pulsed
    update of the column, then those where G- did onto G-: aihwkit's update management
    at its weight granularity g = pulse_gain dP (``refresh_update``: BL = min(ceil(k),
    bl_max), k = max D / g, one column train of probability sqrt(D' / (g BL)) and per pair
    a row train of probability D_i / sqrt(D' g BL), D' = max D min(1, bl_max / k)), one
    SET pulse per coincidence, no verify."""
    refresh_read_noise: float = option(0.0, lo=0.0, hi=1.0, why=FRACTION)
    """``open-loop`` and ``aihwkit`` refresh: std of the read of each device, fraction of
    the range (aihwkit ``refresh_forward`` out_noise: 0.06 of a 0..2 device is 0.03)."""
    refresh_read_step: float = option(0.0, lo=0.0, hi=1.0, why=FRACTION)
    """``aihwkit`` refresh: the refresh read's ADC step, a fraction of the range (aihwkit
    ``refresh_forward`` out_res 2 out_bound / (w_max - w_min): 1/510 x 40 / 2 = 0.039 for
    ``PCMPresetUnitCell``); 0 = exact."""
    reset: float = option(0.0, lo=-1.0, hi=1.0, why=FRACTION)
    """``aihwkit`` refresh: a RESET leaves a device at G0 + b + reset_std (g_max - g_min)
    z (z fresh), clipped to its bounds; b = (reset + reset_dtod z') (g_max - g_min) its
    reset bias, z' fixed per device (aihwkit ``PulsedDevice.reset``, ``reset_dtod``,
    ``reset_std``, in weight units there: divided by w_max - w_min here)."""
    reset_dtod: float = option(0.0, lo=0.0, hi=1.0, why=FRACTION)
    """The reset bias's device-to-device std (aihwkit ``reset_dtod``)."""
    reset_std: float = option(0.0, lo=0.0, hi=1.0, why=FRACTION)
    """A RESET's cycle-to-cycle std (aihwkit ``reset_std``)."""
    read_noise_pcm: float = option(0.0, lo=0.0, hi=1.0, why="a std per unit of the weighted input")
    """Per-read weight noise of the PCM_READ form (aihwkit ``w_noise`` with
    ``w_noise_type=PCMRead``): each normalised output gets N(0, read_noise_pcm^2
    sum_j |w_ij| x_j^2), |w_ij| = |G+ - G-| / range, fresh on every read."""
    rn1f: float = option(0.0, lo=0.0, hi=100.0,
                         why="a scale of the measured model (1 = as measured)")
    """Scale of the accumulated 1/f read noise (aihwkit ``PCMLikeNoiseModel``
    read_noise_scale); 0 = off. When time is let pass (``elapse``, including 0 s), each
    device gets one persistent draw, on its drifted conductance G:
    N(0, (rn1f q_s(G_p) G sqrt(ln((t + t0 + t_read) / (2 t_read))))^2), q_s(G_p) =
    min(rn1f_q0 / max((G_p / g_max)^rn1f_qexp, 1e-3), rn1f_qmax), G_p the conductance as
    programmed (aihwkit: q_s of g_prog), t its age; the draw replaces the
    previous one and every read until the next ``elapse`` sees it (aihwkit draws it once
    per ``drift_weights(t)``). Devices written since the last ``elapse`` start clean."""
    rn1f_q0: float = option(0.0088, lo=0.0, hi=1.0, why=REL_STD)
    """q_s numerator (aihwkit 0.0088)."""
    rn1f_qexp: float = option(0.65, lo=0.0, hi=10.0, why="an exponent")
    """q_s exponent (aihwkit 0.65)."""
    rn1f_qmax: float = option(0.2, lo=0.0, hi=1.0, why=REL_STD)
    """q_s cap (aihwkit 0.2)."""
    rn1f_t_read: float = option(250e-9, lo=1e-12, hi=1.0, why="seconds: a read pulse's width")
    """Read pulse width t_read (s; aihwkit 250 ns)."""
    drift_nu_g: bool = False
    """Conductance-dependent drift exponent (aihwkit ``generate_drift_coefficients``):
    nu = |mu(g) + sd(g) z|, mu = clip(nu_a ln g + nu_b, nu_lo, nu_hi), sd = clip(nu_sa
    ln g + nu_sb, nu_slo, nu_shi), g = max(G / g_max, 1e-7), z the device's fixed normal;
    G is the conductance the device was last written to (read at the first ``elapse``
    after the write). Off: nu = max(drift_nu + drift_nu_std z, 0)."""
    nu_a: float = option(-0.0155, lo=-1.0, hi=1.0, why=NU)
    """Slope of mu(ln g) (aihwkit -0.0155)."""
    nu_b: float = option(0.0244, lo=-1.0, hi=1.0, why=NU)
    """Intercept of mu (0.0244)."""
    nu_lo: float = option(0.049, lo=0.0, hi=1.0, why=NU)
    """mu's lower clip (0.049)."""
    nu_hi: float = option(0.1, lo=0.0, hi=1.0, why=NU)
    """mu's upper clip (0.1)."""
    nu_sa: float = option(-0.0125, lo=-1.0, hi=1.0, why=NU)
    """Slope of sd(ln g) (-0.0125)."""
    nu_sb: float = option(-0.0059, lo=-1.0, hi=1.0, why=NU)
    """Intercept of sd (-0.0059)."""
    nu_slo: float = option(0.008, lo=0.0, hi=1.0, why=NU)
    """sd's lower clip (0.008)."""
    nu_shi: float = option(0.045, lo=0.0, hi=1.0, why=NU)
    """sd's upper clip (0.045)."""
    compensation_read: str = option("ideal", choices=COMPENSATION_READS)
    """How drift compensation reads the array: ``ideal`` (earlier releases) sum |G+ - G-|
    noise-free; ``periphery`` (aihwkit ``GlobalDriftCompensation``): the mean |output|
    of one read per input line (one-hot inputs) through the DAC, noise and ADC, before
    and after the idle time. Counted as ``calibration_reads`` (their MACs in
    ``analog_macs``)."""
    bound_management: bool = False
    """Bound management (aihwkit ``BoundManagementType.ITERATIVE``, forward and transposed
    reads): a read with an output at the ADC bound is repeated with the input halved,
    up to ``bm_passes`` passes in all, each with fresh noise; the last is kept.
    Counted as ``bm_rereads`` (their MACs and conversions in the usual counters)."""
    bm_passes: int = option(5, lo=1, hi=16, why="halvings of the input: 16 passes reach 2^-15")
    """Most passes of a managed read: aihwkit's limit max_bm_res / inp_res = 0.25 / (2 /
    126) admits reductions 1, 2, 4, 8, 16: 5 passes."""

    # faults --------------------------------------------------------------------------
    stuck_low: float = option(0.0, lo=0.0, hi=1.0, why="a fraction of the devices")
    """Fraction of devices stuck at g_min (chosen from the seed)."""
    stuck_high: float = option(0.0, lo=0.0, hi=1.0, why="a fraction of the devices")
    """Fraction of devices stuck at g_max."""

    def __post_init__(self) -> None:
        _validate(self)

    # derived -------------------------------------------------------------------------
    def w_max_for(self, index: int) -> float:
        """The configured w_max of array ``index`` (0: auto)."""
        return matrix_value(self, "w_max", index, default=0.0)

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


# the kernels' parameter record: the numeric fields, then what an array derives --------
CrossbarParams = kernel_record(DeviceConfig, "CrossbarParams", __name__, derived={
    "dG": float,  # level spacing (g_max - g_min) / (levels - 1); 0 when continuous
    "dP": float,  # a pulse's nominal step: pulse_step (g_max - g_min), else dG
    "w_max": float,  # this array's weight of a full conductance swing
    "g_per_w": float,  # (g_max - g_min) / w_max
    "dw_min": float,  # nominal weight step of one pulse, 2 dP w_max / (g_max - g_min)
    "pulse_cap": int,  # most pulses a commit sends a pair (PULSE_CAP_SWEEPS (levels - 1))
    "dac_step": float,  # input step of the DAC on [-1, 1]; 0 = ideal
    "adc_step": float,  # output step of the ADC on [-adc_bound, adc_bound]; 0 = ideal
})


PULSE_CAP_SWEEPS = 4
"""A ``pulse`` commit sends a pair at most this many sweeps of its device's range,
``PULSE_CAP_SWEEPS (levels - 1)`` pulses: a linear device crosses its range in levels - 1
pulses and a soft-bounds one comes within e^-8 of its bound in four sweeps, so more would
only hold a device at its bound. The rest is dropped and counted (``pulses_capped``); it
also bounds a commit's work whatever ``pulse_gain`` and ``levels`` ask."""


REFRESH_READ_SIGMAS = 8.0
"""An ``open-loop`` refresh reads only the pairs whose larger device lies above the upper
threshold and smaller above the lower one less this many read-noise stds (both exact
without read noise): a pair further away would cross with probability below 1e-15 per
read, and most pairs of a one-sided array (one device idle at g_min) are that far."""


def crossbar_params(config: DeviceConfig, w_max: float) -> Any:
    """The :class:`CrossbarParams` of an array of scale ``w_max`` on ``config``."""
    grange = config.g_max - config.g_min
    dG = grange / (config.levels - 1) if config.levels >= 2 else 0.0
    dP = config.pulse_step * grange if config.pulse_step > 0 else dG
    steps = math.ceil(1.0 / config.pulse_step) if config.pulse_step > 0 else config.levels - 1
    # a pulse moves both devices of a two-sided pair (2 dP of G+ - G-), one of a SET-only
    # pair; the controller counts it as pulse_gain times that (1: exactly 2.0, as before).
    # A single device's full swing is 2 w_max: one pulse of dP is the pair's weight step
    devices = 1.0 if config.set_only else 2.0
    swing = 2.0 * w_max if config.mapping == "single" else w_max
    return build_record(
        CrossbarParams, config, dG=dG, dP=dP, w_max=w_max, g_per_w=grange / swing,
        dw_min=(devices * config.pulse_gain) * dP * w_max / grange,
        pulse_cap=PULSE_CAP_SWEEPS * max(steps, 0),
        dac_step=_step(1.0, config.dac_bits), adc_step=_step(config.adc_bound, config.adc_bits))


def _step(bound: float, bits: int) -> float:
    return bound / (2.0 ** (bits - 1) - 1.0) if bits > 0 else 0.0


_NONNEG = ("dw_min_dtod", "dw_min_std", "up_down_dtod", "prog_noise", "read_noise",
           "out_noise", "drift_nu", "drift_nu_std", "w_max_q", "w_max_k", "w_max_v",
           "c2c_add", "c2c_slope", "write_noise", "bound_dtod_up", "bound_dtod_down",
           "read_noise_pcm", "rn1f", "rn1f_q0", "rn1f_qmax", "gamma_up", "gamma_down",
           "nu_lo", "nu_hi", "nu_slo", "nu_shi", "refresh_read_noise", "pulse_step",
           "gamma_up_dtod", "gamma_down_dtod", "reference_std", "lifetime", "lifetime_dtod",
           "refresh_read_step", "reset_dtod", "reset_std")
NEW_FIELDS = ("mapping", "set_only", "refresh", "refresh_upper", "refresh_lower",
              "pulse_gain", "step_model", "step_center", "gamma_up", "gamma_down", "exp_a",
              "exp_b", "exp_a_up", "exp_a_down", "exp_gamma_up", "exp_gamma_down",
              "pow_gamma", "c2c", "c2c_add", "c2c_slope", "write_noise", "bound_dtod_up",
              "bound_dtod_down", "read_noise_pcm", "rn1f", "rn1f_q0", "rn1f_qexp",
              "rn1f_qmax", "rn1f_t_read", "drift_nu_g", "nu_a", "nu_b", "nu_lo", "nu_hi",
              "nu_sa", "nu_sb", "nu_slo", "nu_shi", "compensation_read", "bound_management",
              "bm_passes", "pair_grid", "bound_spread", "write_noise_clip", "set_noise",
              "refresh_write", "refresh_read_noise", "scale_spread", "pulse_step",
              "gamma_up_dtod", "gamma_down_dtod", "mean_bound_reference", "reference_mean",
              "reference_std", "subtract_symmetry_point", "lifetime", "lifetime_dtod",
              "apply_write_noise_on_set", "refresh_read_step", "reset", "reset_dtod",
              "reset_std")
"""The calibrated-physics fields, added after the first releases. A model file saved before
them has none in its options: it restores with their defaults (every one off), not with
its preset's present values (:mod:`cml_edge.core.legacy`)."""


def _validate(c: DeviceConfig) -> None:
    check_types(c, "crossbar ")
    for name in _NONNEG:
        if getattr(c, name) < 0:
            raise InputError(f"crossbar {name} {getattr(c, name)!r} is negative "
                             "(allowed: a finite number >= 0)")
    if c.g_min < 0 or c.g_min >= c.g_max:
        raise InputError(f"crossbar g_min {c.g_min!r} / g_max {c.g_max!r} are not allowed "
                         "(allowed: 0 <= g_min < g_max, micro-siemens)")
    if c.levels < 0 or c.levels == 1:
        raise InputError(f"crossbar levels {c.levels!r} is not allowed (allowed: an integer "
                         ">= 2, or 0 for a continuous conductance)")
    if c.levels < 2 and c.pulse_step == 0 and (c.update == "pulsed" or c.commit == "pulse"):
        raise InputError(f"crossbar levels {c.levels!r} is not allowed with update "
                         f"{c.update!r} / commit {c.commit!r} (pulses step one level: "
                         "allowed levels >= 2, or pulse_step > 0)")
    if not 1 <= c.bl_max <= 31:
        raise InputError(f"crossbar bl_max {c.bl_max!r} is not allowed (allowed: 1..31)")
    for name in ("stuck_low", "stuck_high"):
        v = getattr(c, name)
        if not 0.0 <= v <= 1.0:
            raise InputError(f"crossbar {name} {v!r} is not a fraction (allowed: 0..1)")
    if c.stuck_low + c.stuck_high > 1.0:
        raise InputError(f"crossbar stuck_low + stuck_high = {c.stuck_low + c.stuck_high!r} "
                         "exceeds 1 (allowed: a total fraction <= 1)")
    if not -1.0 < c.up_down < 1.0:
        raise InputError(f"crossbar up_down {c.up_down!r} is not allowed (allowed: -1 < a < 1)")
    for name in ("refresh_upper", "refresh_lower"):
        if not 0.0 < getattr(c, name) < 1.0:
            raise InputError(f"crossbar {name} {getattr(c, name)!r} is not allowed "
                             "(allowed: a fraction of the range, 0 < f < 1)")
    lo, hi = (0.0, 1.0) if c.step_model in ("soft", "linear") else (-1.0, 2.0)
    if not (0.0 <= c.step_center < 1.0 and lo < c.step_center < hi):
        what = "0 < c < 1" if c.step_model in ("soft", "linear") else "0 <= c < 1"
        raise InputError(f"crossbar step_center {c.step_center!r} is not allowed with "
                         f"step_model {c.step_model!r} (allowed: a fraction {what})")
    if c.mapping == "single" and (c.set_only or c.refresh):
        raise InputError(f"crossbar mapping 'single' is not allowed with "
                         f"{'set_only' if c.set_only else 'refresh'} (a SET-only device and "
                         "a refresh need the partner device of a pair; allowed: set_only "
                         "false and refresh false, or mapping two-sided / one-sided)")
    if not 1 <= c.bm_passes <= 16:
        raise InputError(f"crossbar bm_passes {c.bm_passes!r} is not allowed (allowed: 1..16)")
    for name in ("adc_bound", "drift_t0", "prog_gref", "w_headroom", "pulse_gain",
                 "pow_gamma", "rn1f_t_read"):
        if getattr(c, name) <= 0:
            raise InputError(f"crossbar {name} {getattr(c, name)!r} is not allowed "
                             "(allowed: a number > 0)")
    check_ranges(c, "crossbar ")
    for name in ("w_max_q", "w_max_k", "w_max_v"):
        if 0 < getattr(c, name) < W_MAX_MIN:
            raise InputError(f"crossbar {name} {getattr(c, name)!r} is outside its range "
                             f"0 or {W_MAX_MIN:g}..100 ({W_MAX})")


PCM_PULSE_GAIN = 3.2
"""The pcm preset's controller calibration (``pulse_gain``): the mean SET step of its
mean device (nominal bounds) from g_min to 90 % of the range, in units of dG: 56 pulses
take it from 0 to 22.5 uS (``kernels.set_pulses``), 22.5 / 56 / 0.125 = 3.2. With the
device-to-device spread of the upper bound, ``cml-edge device characterize`` counts more
(docs/devices/crossbar.md)."""

_DEVICE = dict(update="pulsed", commit="pulse", dac_bits=7, adc_bits=9, adc_bound=12.0,
               w_max_v=0.02)

_PCM_SYMMETRIC = dict(
    _DEVICE, g_min=0.0, g_max=25.0, levels=201, dw_min_dtod=0.2, dw_min_std=0.6,
    up_down_dtod=0.05, bounds="soft", prog_noise=1.0, prog_c0=0.26348, prog_c1=1.9650,
    prog_c2=-1.1731, prog_gref=25.0, out_noise=0.06, drift_nu=0.049, drift_nu_std=0.008,
    drift_t0=20.0)
_RERAM_SYMMETRIC = dict(
    _DEVICE, g_min=50.0, g_max=225.0, levels=1001, dw_min_dtod=0.3, dw_min_std=3.75,
    up_down_dtod=0.01, bounds="soft", prog_noise=1.0, prog_c0=4.782321,
    prog_c1=-0.009107 * 225.0, prog_c2=0.0, prog_gref=225.0, read_noise=0.01)

class _Presets(dict):
    """The named presets, and ``aihwkit:NAME``: one of IBM aihwkit 1.1.0's preset devices
    and unit cells, its parameters read from the committed snapshot and mapped onto the
    fields (:mod:`cml_edge.backends.crossbar.aihwkit.presets`; unmodelled parameters
    refused)."""

    def __contains__(self, name: object) -> bool:
        return super().__contains__(name) or _is_aihwkit(name)

    def __missing__(self, name: str) -> dict[str, Any]:
        if not _is_aihwkit(name):
            raise KeyError(name)
        from cml_edge.backends.crossbar.aihwkit.presets import preset_fields

        return preset_fields(name)


def _is_aihwkit(name: object) -> bool:
    return isinstance(name, str) and name.startswith("aihwkit:")


PRESETS: dict[str, dict[str, Any]] = _Presets({
    "ideal": {"w_headroom": 4.0, "pair_grid": "pair"},
    # the full statistical PCM model (module docstring)
    "pcm": dict(
        _DEVICE, g_min=0.0, g_max=25.0, levels=201, mapping="one-sided", set_only=True,
        refresh=True, refresh_upper=0.75, refresh_lower=0.25, refresh_write="open-loop",
        refresh_read_noise=0.03, pulse_gain=PCM_PULSE_GAIN, set_noise="gauss",
        bound_spread="symmetric",
        step_model="exp", step_center=0.0, exp_a=-1.0, exp_b=0.0, exp_a_up=-27.235,
        exp_a_down=-2.235, exp_gamma_up=2.5, exp_gamma_down=2.5, dw_min_dtod=0.2,
        up_down_dtod=0.05, bound_dtod_up=0.1, bound_dtod_down=0.0, dw_min_std=0.6,
        c2c="complex", c2c_add=0.021, c2c_slope=0.108, prog_noise=1.0, prog_c0=0.26348,
        prog_c1=1.9650, prog_c2=-1.1731, prog_gref=25.0, out_noise=0.06, drift_nu=0.049,
        drift_nu_std=0.008, drift_t0=20.0, drift_nu_g=True, rn1f=1.0,
        drift_compensation=True, compensation_read="periphery", bound_management=True),
    # asymmetric soft-bounds ReRAM (module docstring)
    "reram": dict(
        _DEVICE, g_min=50.0, g_max=225.0, levels=1001, mapping="one-sided",
        step_model="soft", step_center=0.375, bound_dtod_up=0.24, bound_dtod_down=0.4,
        bound_spread="symmetric", write_noise_clip=False,
        dw_min_dtod=0.3, up_down_dtod=0.01, dw_min_std=3.75, c2c="add", write_noise=56.0,
        prog_noise=1.0, prog_c0=4.782321, prog_c1=-0.009107 * 225.0, prog_c2=0.0,
        prog_gref=225.0, read_noise=0.01, bound_management=True),
    # the pcm and reram presets of earlier releases, bit for bit
    "pcm-symmetric": _PCM_SYMMETRIC,
    "reram-symmetric": _RERAM_SYMMETRIC,
})


def make_config(preset: str = DEFAULT_PRESET, **overrides: Any) -> DeviceConfig:
    """The preset ``preset`` with ``overrides`` (field -> value); ValueError if unknown."""
    return resolve(DeviceConfig, PRESETS, {**overrides, "preset": preset}, "crossbar")


KNOBS = (
    Knob("read_noise", "read_noise", 0.0, 0.5, "low",
         doc="crossbar read_noise: conductance fluctuation per read, std relative to the "
             "conductance range"),
    Knob("prog_noise", "prog_noise", 0.0, 20.0, "low",
         doc="crossbar prog_noise: scale of the programming-noise model (aihwkit "
             "prog_noise_scale)"),
    Knob("levels", "levels", 2, 1001, "high", integer=True, log=True,
         doc="crossbar conductance levels per device"),
    Knob("stuck", "stuck", 0.0, 0.5, "low", parts=("stuck_low", "stuck_high"),
         doc="crossbar fraction of stuck devices, half at g_min (stuck_low) and half at "
             "g_max (stuck_high)"),
    Knob("adc_bits", "adc_bits", 2, 14, "high", integer=True,
         doc="crossbar ADC bits on the outputs"),
)
"""What a break point can sweep on the crossbar (``cml-edge scenario breakpoint --knob``;
the idle ``drift_time`` applies to every device)."""

RANDOM_FIELDS = ("stuck_low", "stuck_high", "dw_min_dtod", "up_down_dtod", "bound_dtod_up",
                 "bound_dtod_down", "drift_nu_std", "prog_noise", "dw_min_std", "write_noise",
                 "read_noise", "out_noise", "read_noise_pcm", "rn1f", "c2c_add", "c2c_slope",
                 "refresh_read_noise", "gamma_up_dtod", "gamma_down_dtod", "reference_std",
                 "lifetime_dtod", "reset_dtod", "reset_std")
"""The fields whose devices draw from the array's stream when nonzero: manufacture
(stuck devices, device-to-device spreads, drift exponents, programming noise) and
cycle to cycle (pulse, write and read noise)."""


def draws(config: DeviceConfig) -> bool:
    """Whether an array of ``config`` draws from its device stream (so chips differ): a
    random field is on, updates are pulsed (stochastic coincidences) or rounded to a grid
    of levels, or the drift exponent depends on the conductance (its spread)."""
    return (any(getattr(config, name) != 0 for name in RANDOM_FIELDS)
            or config.update == "pulsed" or config.levels >= 2 or config.drift_nu_g)


ANALOG = CostModel("analog", "analog_mac", ("analog_macs",), pulse="write_pulse",
                   pulse_counters=("device_pulses", "refresh_pulses"))
"""The crossbar's cost model (cml_edge.costs.ledger.COSTS): analog MACs, whose figure
includes the DAC and ADC conversions (the MACs of drift compensation's calibration reads
and of bound management's re-reads are counted in ``analog_macs``), and one write pulse
per device pulse (the RESET and SET pulses of pair refreshes are ``refresh_pulses``); no
SRAM traffic."""
