"""The memristive crossbar synaptic array: differential conductance pairs on an analog array.

A weight matrix W (rows x cols) lives on rows x cols pairs of devices,
W = (G+ - G-) / g_per_w with g_per_w = (g_max - g_min) / w_max (the balanced map of
:mod:`cml_edge.backends.crossbar.conductance`). ``w_max``, the weight of a full conductance swing,
is this array's weight-to-conductance scale: the configured ``w_max_q`` / ``w_max_k`` /
``w_max_v`` for the array's index (0, 1, 2 = W_q, W_k, W_v), or, when that is 0,
``w_headroom`` x max|W| of the matrix it was programmed with. The reads, updates, noise,
drift and faults are the kernels' (:mod:`cml_edge.backends.crossbar.kernels`); the device
numbers are a
:class:`~cml_edge.backends.crossbar_config.DeviceConfig` (presets ``ideal``, ``pcm``,
``reram``).
"""

from __future__ import annotations

import argparse
import math
from typing import Any, NamedTuple

import numpy as np

from cml_edge.backends.base import SynapticArray
from cml_edge.backends.crossbar import kernels as kern
from cml_edge.backends.crossbar.config import (
    FIELD_NAMES,
    PRESETS,
    DeviceConfig,
    make_config,
    parse_setting,
)
from cml_edge.backends.dispatch import Kernels, register
from cml_edge.errors import InputError
from cml_edge.protocol import STREAM_DEVICE
from cml_edge.rng import stream_key


class CrossbarState(NamedTuple):
    Gp: np.ndarray  # (rows, cols) float64: G+ (uS), column-major
    Gm: np.ndarray  # (rows, cols) float64: G- (uS), same layout
    acc: np.ndarray  # (rows, cols) float64: digital update accumulator (weight units)
    step: np.ndarray  # (4, rows, cols) float64: pulse-step scales G+ up/down, G- up/down
    nu: np.ndarray  # (2, rows, cols) float64: drift exponents of G+, G-
    age: np.ndarray  # (2, rows, cols) float64: seconds since each device's last write
    stuck: np.ndarray  # (2, rows, cols) int8: 0 working, 1 stuck at g_min, 2 at g_max
    params: np.ndarray  # float64[N_PARAMS]: device parameters (kernels' P_* indices)
    rng: np.ndarray  # uint64[2]: stream key, draw counter
    xbuf: np.ndarray  # float64[max(rows, cols)]: scaled, converted inputs of a read
    ybuf: np.ndarray  # float64[max(rows, cols)]: analog sums of a read
    bits: np.ndarray  # int64[rows + cols]: pulse trains of the lines (bit t = slot t)
    idx: np.ndarray  # int64[max(rows, cols)]: the columns that fired
    counters: np.ndarray  # int64[N_COUNTERS]


register(CrossbarState, Kernels(kern.xbar_matvec, kern.xbar_rmatvec, kern.xbar_outer_update,
                                kern.xbar_commit, kern.xbar_sigmoid))


def _laid_out(a: np.ndarray) -> np.ndarray:
    """A column-major copy (the kernels run along columns: W x is a sum of columns)."""
    return np.array(a, dtype=np.float64, order="F", copy=True)


class CrossbarArray(SynapticArray):
    """An emulated memristive crossbar (see the module docstrings).

    Counters (for the energy ledger): ``matvecs`` / ``rmatvecs`` the forward and
    transposed analog reads; ``analog_macs`` device currents summed (driven input lines
    x output lines); ``dac_conversions`` (driven input lines) and ``adc_conversions``
    (output lines) per read; ``adc_saturations`` outputs beyond the ADC bound;
    ``outer_updates`` calls of the local rule; ``acc_writes`` digital accumulator cells
    written (per-walk schedule); ``line_pulses`` row and column pulses (coincidence
    trains, and two per serial programming pulse at commit); ``coincidences`` row-column
    coincidences of the in-place pulsed update; ``device_pulses`` pulses that reached a
    device (two per coincidence, one per device per commit pulse); ``devices_written``
    devices pulsed or programmed, once per update or commit; ``commits``; ``rng_draws``
    uniforms drawn from the array's stream.
    """

    name = "crossbar"
    State = CrossbarState
    DEFAULT_PRESET = "pcm"
    counter_names = (
        "matvecs", "rmatvecs", "analog_macs", "dac_conversions", "adc_conversions",
        "adc_saturations", "outer_updates", "acc_writes", "line_pulses", "coincidences",
        "device_pulses", "devices_written", "commits", "rng_draws",
    )
    assert len(counter_names) == kern.N_COUNTERS

    def __init__(self, state: CrossbarState, config: DeviceConfig | None = None,
                 preset: str = DEFAULT_PRESET) -> None:
        super().__init__(state)
        self.config = config if config is not None else make_config(preset)
        self.preset = preset

    # construction -----------------------------------------------------------------
    @classmethod
    def from_float(cls, W: np.ndarray, *, seed: int = 0, index: int = 0,
                   preset: str = DEFAULT_PRESET, **fields: Any) -> CrossbarArray:
        """Program W into a new crossbar with the preset and field overrides given.

        The array's random stream is ``stream_key(seed, STREAM_DEVICE + index)``; its
        per-device constants and initial programming noise are drawn from it first
        (:func:`cml_edge.backends.crossbar.kernels.xbar_program`).
        """
        config = make_config(preset, **fields)
        W = np.asarray(W, dtype=np.float64)
        if W.ndim != 2 or 0 in W.shape:
            raise InputError(f"a crossbar holds a non-empty matrix, got shape {W.shape}")
        if not np.isfinite(W).all():
            raise InputError("a crossbar cannot be programmed with NaN or infinite weights")
        w_max = config.w_max_for(index) or config.w_headroom * float(np.abs(W).max()) or 1.0
        state = _new_state(W.shape, config.to_params(w_max),
                           stream_key(int(seed), STREAM_DEVICE + int(index)))
        kern.xbar_program(state, W)
        return cls(state, config, preset)

    def options(self) -> dict[str, Any]:
        return {"preset": self.preset, **self.config.to_dict()}

    @classmethod
    def _restore(cls, state: CrossbarState, options: dict[str, Any]) -> CrossbarArray:
        options = dict(options)
        preset = options.pop("preset", cls.DEFAULT_PRESET)
        state = state._replace(Gp=_laid_out(state.Gp), Gm=_laid_out(state.Gm),
                               acc=_laid_out(state.acc))
        n = max(state.Gp.shape)
        for f, size in (("xbuf", n), ("ybuf", n), ("idx", n), ("bits", sum(state.Gp.shape)),
                        ("params", kern.N_PARAMS), ("rng", 2)):
            if getattr(state, f).shape != (size,):
                raise InputError(f"field {f!r} has shape {getattr(state, f).shape}, "
                                 f"expected ({size},)")
        for f, k in (("step", 4), ("nu", 2), ("age", 2), ("stuck", 2)):
            if getattr(state, f).shape != (k, *state.Gp.shape):
                raise InputError(f"field {f!r} has shape {getattr(state, f).shape}, "
                                 f"expected {(k, *state.Gp.shape)}")
        return cls(state, make_config(preset, **options), preset)

    # the seam extras ----------------------------------------------------------------
    def to_float(self) -> np.ndarray:
        """The weights the array holds: (G+ - G-) / g_per_w, times the drift compensation."""
        p = self.state.params
        scale = p[kern.P_W_MAX] / (p[kern.P_G_MAX] - p[kern.P_G_MIN]) * p[kern.P_ALPHA]
        return np.ascontiguousarray((self.state.Gp - self.state.Gm) * scale)

    def elapse(self, seconds: float) -> None:
        """Let ``seconds`` pass with no reads or writes: conductance drift (and, if
        configured, the global drift compensation)."""
        seconds = float(seconds)
        if not math.isfinite(seconds) or seconds < 0:
            raise InputError(f"elapsed time {seconds!r} is not allowed (allowed: seconds >= 0)")
        kern.xbar_elapse(self.state, seconds)

    @property
    def w_max(self) -> float:
        """The weight of a full conductance swing (the weight-to-conductance scale)."""
        return float(self.state.params[kern.P_W_MAX])

    @property
    def dw_min(self) -> float:
        """The nominal weight change of one coincidence (0 when continuous)."""
        return float(self.state.params[kern.P_DW_MIN])

    def conductances(self) -> tuple[np.ndarray, np.ndarray]:
        """Copies of (G+, G-) in micro-siemens."""
        return np.array(self.state.Gp), np.array(self.state.Gm)

    # command line -------------------------------------------------------------------
    @classmethod
    def add_cli_arguments(cls, group: argparse._ArgumentGroup) -> None:
        group.add_argument("--preset", default=None,
                           help=f"crossbar device preset: {', '.join(PRESETS)} "
                                f"(default {cls.DEFAULT_PRESET})")
        group.add_argument("--levels", type=int, default=None, metavar="N",
                           help="crossbar conductance levels per device (>= 2; 0 = continuous)")
        group.add_argument("--set", dest="crossbar_set", action="append", default=[],
                           metavar="FIELD=VALUE",
                           help="override a crossbar device field, repeatable; fields: "
                                + ", ".join(FIELD_NAMES))

    @classmethod
    def cli_options(cls, args: argparse.Namespace) -> dict[str, Any]:
        """The options from ``--preset``, ``--levels`` and ``--set``, validated now."""
        options: dict[str, Any] = {}
        if getattr(args, "preset", None) is not None:
            options["preset"] = args.preset
        if getattr(args, "levels", None) is not None:
            options["levels"] = args.levels
        for text in getattr(args, "crossbar_set", None) or []:
            name, value = parse_setting(text)
            options[name] = value
        overrides = {k: v for k, v in options.items() if k != "preset"}
        make_config(options.get("preset", cls.DEFAULT_PRESET), **overrides)
        return options


def _new_state(shape: tuple[int, int], params: np.ndarray, key: Any) -> CrossbarState:
    rows, cols = shape
    n = max(rows, cols)
    order = "F"
    return CrossbarState(
        Gp=np.zeros(shape, order=order), Gm=np.zeros(shape, order=order),
        acc=np.zeros(shape, order=order), step=np.ones((4, rows, cols)),
        nu=np.zeros((2, rows, cols)), age=np.zeros((2, rows, cols)),
        stuck=np.zeros((2, rows, cols), np.int8), params=params,
        rng=np.array([key, 0], dtype=np.uint64), xbuf=np.zeros(n), ybuf=np.zeros(n),
        bits=np.zeros(rows + cols, np.int64), idx=np.zeros(n, np.int64),
        counters=np.zeros(kern.N_COUNTERS, np.int64),
    )
