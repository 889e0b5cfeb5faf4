"""Device configuration of the memristive crossbar array, as data, with named presets.

Every number a crossbar emulation depends on is a field of :class:`DeviceConfig`
(frozen, documented, validated); a preset is a named set of field values; every field
can be overridden (``--set field=value`` on the command line, ``--levels N``,
``--preset NAME``). The kernels cannot read a dataclass: they read
:class:`CrossbarParams`, the record derived from the config's numeric fields plus the
array's derived quantities (:func:`crossbar_params`; :mod:`cml_edge.backends.params`).

Presets and where their numbers come from (the figures are collected in
``shared/reference/crossbar.md``):

``ideal``
    no non-idealities: continuous conductance (``levels = 0``), exact analog updates
    and programming, no noise, ideal converters, no drift, no faults, w_max = 4 max|W0|
    (nothing clipped, even as the weights grow). Reproduces the float64 result (to
    rounding).
``pcm``
    IBM aihwkit's PCM models. Range 0..25 uS (``PCMLikeNoiseModel`` g_max); programming
    noise polynomial (0.26348, 1.9650, -1.1731) at 25 uS; drift nu = 0.049 +- 0.008,
    t0 = 20 s (``generate_drift_coefficients``: the clamped mean and std for
    mid-range conductances, where a balanced pair sits); pulsed device from
    ``PCMPresetDevice`` (Nandakumar et al. 2020): dw_min = 0.01 of a 0..2 range, i.e.
    201 levels, device-to-device 20 %, cycle-to-cycle 60 %, up/down spread 5 %;
    periphery from aihwkit ``IOParameters``: 7-bit DAC, 9-bit ADC with bound 12,
    output noise 0.06.
``reram``
    Sandia CrossSim ``RRAM_Milo`` (Milo et al., IRPS 2021): 50..225 uS (on/off 4.5),
    programming noise sigma = max(4.782321 - 0.009107 G, 0) uS; no drift model; pulsed
    device from aihwkit ``ReRamSBPresetDevice`` (Gong et al. 2018): dw_min = 0.002 of a
    2-wide range, i.e. 1001 levels, soft bounds, device-to-device 30 %, up/down spread
    1 %, cycle-to-cycle 3.75 (375 %: that device is very noisy per pulse); read noise
    1 % of the range per device and read (the reference's ReRAM weight noise); the same
    7-bit DAC / 9-bit ADC periphery, no output noise.

Both device presets use the per-walk accumulate-then-pulse commit and the pulsed
update, and the same weight scale (w_max_q, w_max_k automatic = max|W0|; w_max_v = 0.02,
see :class:`DeviceConfig`). Stuck devices are 0 in the presets (aihwkit keeps its
measured corrupt-device fractions, 10-13.5 % for its ReRAM arrays, off by default);
sweep them with ``--set stuck_low=...``.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

from cml_edge.backends.fields import (
    check_types,
    field_names,
    matrix_value,
    option,
    resolve,
)
from cml_edge.backends.fields import parse_setting as _parse_setting
from cml_edge.backends.params import build_record, kernel_record
from cml_edge.errors import InputError

UPDATES = ("analog", "pulsed")
COMMITS = ("program", "pulse")
BOUNDS = ("hard", "soft")
DEFAULT_PRESET = "pcm"


@dataclass(frozen=True)
class DeviceConfig:
    """The devices and periphery of one crossbar (units: micro-siemens, seconds)."""

    # conductance range and the weight-to-conductance scale ---------------------------
    g_min: float = 0.0
    """Lowest device conductance (uS)."""
    g_max: float = 25.0
    """Highest device conductance (uS)."""
    levels: int = option(0, flag="--levels", metavar="N",
                         help="crossbar conductance levels per device (>= 2; 0 = continuous)")
    """Programmable states per device, evenly spaced on [g_min, g_max]; 0 = continuous.
    One pulse moves a device by one level: dw_min = 2 w_max / (levels - 1)."""
    w_headroom: float = option(1.0, kernel=False)
    """Automatic scale: w_max = w_headroom x max|W| of the matrix programmed (aihwkit maps
    max|W| to g_max: headroom 1). Weights that later grow past w_max clip at the bounds."""
    w_max_q: float = option(0.0, per_matrix=("w_max", 0))
    """Weight of a full conductance swing for W_q (index 0); 0 = automatic (w_headroom)."""
    w_max_k: float = option(0.0, per_matrix=("w_max", 1))
    """The same for W_k (index 1)."""
    w_max_v: float = option(0.0, per_matrix=("w_max", 2))
    """The same for W_v (index 2). The CML's learned W_v is far smaller than its
    N(0, 0.1^2) init (W_v a learns W_q delta), so the device presets set 0.02: resolution
    where the learned weights live; the init is clipped at programming (the sizes
    measured, and what this does to convergence: README, "On the crossbar")."""

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
    bl_max: int = 31
    """Longest stochastic pulse train (BL <= 31, Gokmen & Vlasov 2016)."""
    dw_min_dtod: float = 0.0
    """Device-to-device spread of the pulse step (relative std, fixed per device)."""
    dw_min_std: float = 0.0
    """Cycle-to-cycle spread of the pulse step (relative std, fresh per pulse)."""
    up_down: float = 0.0
    """Mean up/down asymmetry: up steps x (1 + a), down steps x (1 - a)."""
    up_down_dtod: float = 0.0
    """Device-to-device spread of the asymmetry a (std)."""
    bounds: str = option("hard", choices=BOUNDS)
    """``hard``: a device clips at g_min / g_max; ``soft``: the step shrinks linearly to
    zero at the bound it moves toward (1 at mid-range)."""

    # programming noise ---------------------------------------------------------------
    prog_noise: float = 0.0
    """Scale of the programming-noise model (aihwkit ``prog_noise_scale``); 0 = none."""
    prog_c0: float = 0.26348
    """Programming-noise polynomial c0 (uS at g_ref); see cml_edge.backends.crossbar.conductance."""
    prog_c1: float = 1.9650
    """c1 (uS at g_ref, per unit G/g_max)."""
    prog_c2: float = -1.1731
    """c2 (uS at g_ref, per unit (G/g_max)^2)."""
    prog_gref: float = 25.0
    """The g_max the coefficients were fitted at (uS)."""

    # reads ---------------------------------------------------------------------------
    read_noise: float = 0.0
    """Conductance fluctuation of each device at each read, std relative to
    g_max - g_min (fresh on every W x and W^T y)."""
    out_noise: float = 0.0
    """Additive noise at each output before the ADC, std in normalised units
    (aihwkit ``out_noise``; fresh on every read)."""
    dac_bits: int = 0
    """DAC bits on inputs scaled by max|x| (0 = ideal)."""
    adc_bits: int = 0
    """ADC bits on outputs (0 = ideal)."""
    adc_bound: float = 12.0
    """ADC range, normalised units (aihwkit ``out_bound``)."""

    # drift ---------------------------------------------------------------------------
    drift_nu: float = 0.0
    """Mean drift exponent: G(t) = G0 ((t + t0) / t0)^-nu, t since the device's last write."""
    drift_nu_std: float = 0.0
    """Device-to-device std of nu (fixed per device, clipped at 0)."""
    drift_t0: float = 20.0
    """Drift reference time t0 (s)."""
    drift_compensation: bool = False
    """Global drift compensation: one output scale per array, from a calibration read
    (sum |G+ - G-|) before and after the drift."""

    # faults --------------------------------------------------------------------------
    stuck_low: float = 0.0
    """Fraction of devices stuck at g_min (chosen from the seed)."""
    stuck_high: float = 0.0
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
    "w_max": float,  # this array's weight of a full conductance swing
    "g_per_w": float,  # (g_max - g_min) / w_max
    "dw_min": float,  # nominal weight step of one pulse, 2 dG w_max / (g_max - g_min)
    "dac_step": float,  # input step of the DAC on [-1, 1]; 0 = ideal
    "adc_step": float,  # output step of the ADC on [-adc_bound, adc_bound]; 0 = ideal
})


def crossbar_params(config: DeviceConfig, w_max: float) -> Any:
    """The :class:`CrossbarParams` of an array of scale ``w_max`` on ``config``."""
    grange = config.g_max - config.g_min
    dG = grange / (config.levels - 1) if config.levels >= 2 else 0.0
    return build_record(
        CrossbarParams, config, dG=dG, w_max=w_max, g_per_w=grange / w_max,
        dw_min=2.0 * dG * w_max / grange, dac_step=_step(1.0, config.dac_bits),
        adc_step=_step(config.adc_bound, config.adc_bits))


def _step(bound: float, bits: int) -> float:
    return bound / (2.0 ** (bits - 1) - 1.0) if bits > 0 else 0.0


FIELD_NAMES = field_names(DeviceConfig)
_NONNEG = ("dw_min_dtod", "dw_min_std", "up_down_dtod", "prog_noise", "read_noise",
           "out_noise", "drift_nu", "drift_nu_std", "w_max_q", "w_max_k", "w_max_v")


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
    if c.levels < 2 and (c.update == "pulsed" or c.commit == "pulse"):
        raise InputError(f"crossbar levels {c.levels!r} is not allowed with update "
                         f"{c.update!r} / commit {c.commit!r} (pulses step one level: "
                         "allowed levels >= 2)")
    if not 1 <= c.bl_max <= 31:
        raise InputError(f"crossbar bl_max {c.bl_max!r} is not allowed (allowed: 1..31)")
    for name in ("dac_bits", "adc_bits"):
        v = getattr(c, name)
        if v != 0 and not 2 <= v <= 24:
            raise InputError(f"crossbar {name} {v!r} is not allowed (allowed: 0 = ideal, "
                             "or 2..24)")
    for name in ("stuck_low", "stuck_high"):
        v = getattr(c, name)
        if not 0.0 <= v <= 1.0:
            raise InputError(f"crossbar {name} {v!r} is not a fraction (allowed: 0..1)")
    if c.stuck_low + c.stuck_high > 1.0:
        raise InputError(f"crossbar stuck_low + stuck_high = {c.stuck_low + c.stuck_high!r} "
                         "exceeds 1 (allowed: a total fraction <= 1)")
    if not -1.0 < c.up_down < 1.0:
        raise InputError(f"crossbar up_down {c.up_down!r} is not allowed (allowed: -1 < a < 1)")
    for name in ("adc_bound", "drift_t0", "prog_gref", "w_headroom"):
        if getattr(c, name) <= 0:
            raise InputError(f"crossbar {name} {getattr(c, name)!r} is not allowed "
                             "(allowed: a number > 0)")


_DEVICE = dict(update="pulsed", commit="pulse", dac_bits=7, adc_bits=9, adc_bound=12.0,
               w_max_v=0.02)

PRESETS: dict[str, dict[str, Any]] = {
    "ideal": {"w_headroom": 4.0},
    "pcm": dict(_DEVICE, g_min=0.0, g_max=25.0, levels=201, dw_min_dtod=0.2, dw_min_std=0.6,
                up_down_dtod=0.05, bounds="soft", prog_noise=1.0, prog_c0=0.26348,
                prog_c1=1.9650, prog_c2=-1.1731, prog_gref=25.0, out_noise=0.06,
                drift_nu=0.049, drift_nu_std=0.008, drift_t0=20.0),
    "reram": dict(_DEVICE, g_min=50.0, g_max=225.0, levels=1001, dw_min_dtod=0.3,
                  dw_min_std=3.75, up_down_dtod=0.01, bounds="soft", prog_noise=1.0,
                  prog_c0=4.782321, prog_c1=-0.009107 * 225.0, prog_c2=0.0, prog_gref=225.0,
                  read_noise=0.01),
}


def make_config(preset: str = DEFAULT_PRESET, **overrides: Any) -> DeviceConfig:
    """The preset ``preset`` with ``overrides`` (field -> value); ValueError if unknown."""
    return resolve(DeviceConfig, PRESETS, {**overrides, "preset": preset}, "crossbar")


def parse_setting(text: str) -> tuple[str, Any]:
    """``field=value`` from ``--set``: the field name and the value in the field's type."""
    return _parse_setting(DeviceConfig, text, "crossbar")
