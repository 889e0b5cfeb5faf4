"""The memristive crossbar synaptic array: differential conductance pairs on an analog array.

A weight matrix W (rows x cols) lives on rows x cols pairs of devices,
W = (G+ - G-) / g_per_w with g_per_w = (g_max - g_min) / w_max (the two-sided or
one-sided map of :mod:`cml_edge.backends.crossbar.conductance`). ``w_max``, the weight
of a full conductance swing, is this array's weight-to-conductance scale: the
configured ``w_max_q`` / ``w_max_k`` / ``w_max_v`` for the array's index (0, 1, 2 =
W_q, W_k, W_v), or, when that is 0, ``w_headroom`` x max|W| of the matrix it was
programmed with. The reads, updates, noise, drift and faults are the kernels'
(:mod:`cml_edge.backends.crossbar.kernels`, composing :mod:`~.read`, :mod:`~.write` and
:mod:`~.time`); the device numbers are a
:class:`~cml_edge.backends.crossbar.config.DeviceConfig` (presets ``ideal``, ``pcm``,
``reram``, ``pcm-symmetric``, ``reram-symmetric``), which the kernels read as the
:class:`~cml_edge.backends.crossbar.config.CrossbarParams` record.
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np

from cml_edge.backends.base import SynapticArray, laid_out
from cml_edge.backends.crossbar.codes import AUX_PLANES, N_COUNTERS
from cml_edge.backends.crossbar.conductance import swing
from cml_edge.backends.crossbar.config import (
    DEFAULT_PRESET,
    CrossbarParams,
    DeviceConfig,
    crossbar_params,
    make_config,
)
from cml_edge.backends.crossbar.time import xbar_elapse, xbar_program
from cml_edge.errors import InputError
from cml_edge.jit.gauss import BLOCK_PAD
from cml_edge.jit.rng import stream_key
from cml_edge.protocol import STREAM_DEVICE


class CrossbarState(NamedTuple):
    Gp: np.ndarray  # (rows, cols) float64: G+ (uS), column-major
    Gm: np.ndarray  # (rows, cols) float64: G- (uS), same layout
    acc: np.ndarray  # (rows, cols) float64: digital update accumulator (weight units), laid
    # out by shape (column-major if tall, row-major if wide: the update runs along it)
    step: np.ndarray  # (4, rows, cols) float64: pulse-step scales G+ up/down, G- up/down
    nu: np.ndarray  # (2, rows, cols) float64: drift exponents of G+, G-
    age: np.ndarray  # (2, rows, cols) float64: seconds since each device's last write
    stuck: np.ndarray  # (2, rows, cols) int8: 0 working, 1 stuck at g_min, 2 at g_max
    params: CrossbarParams  # the device's numbers as the kernels read them (config.py)
    alpha: np.ndarray  # float64[1]: drift-compensation factor of the outputs (1 until drift)
    elapsed: np.ndarray  # float64[1]: seconds let pass with ``elapse``
    rng: np.ndarray  # uint64[2]: stream key, draw counter
    nu_z: np.ndarray  # (2, rows, cols) float64: each device's fixed normal behind nu
    bnd: np.ndarray  # (4, rows, cols) float64: bounds lo, hi of G+, then of G- (uS)
    wn: np.ndarray  # (2, rows, cols) float64: write-noise offsets of G+, G- (uS)
    rn: np.ndarray  # (2, rows, cols) float64: accumulated read-noise draws of G+, G- (uS)
    aux: np.ndarray  # (2 AUX_PLANES, rows, cols) float64: per device (G+, then G-) its
    # linear-step slopes up and down, reference (uS), decay scale and reset bias (uS)
    # (codes.AUX_*; read only where the config draws them: gamma_*_dtod, reference_*,
    # lifetime, reset_dtod)
    # work space (saved with the state, but no kernel reads what a call left: SCRATCH) ----
    xbuf: np.ndarray  # float64[max(rows, cols)]: a read's inputs, scaled and converted
    ybuf: np.ndarray  # float64[max(rows, cols)]: a read's analog sums
    bits: np.ndarray  # int64[rows + cols]: an update's pulse trains, one word per line (bit
    # t = slot t), rows first
    idx: np.ndarray  # int64[max(rows, cols)]: an update's columns that fired
    sbuf: np.ndarray  # float64[rows + cols]: calibration reads' inputs and outputs
    vbuf: np.ndarray  # float64[max(rows, cols)]: per-output variance of a PCM_READ read
    driven: np.ndarray  # int64[words(max(rows, cols))]: bit masks of a read's nonzero inputs
    zbuf: np.ndarray  # float64[max(rows, cols) + BLOCK_PAD]: a read's noise normals
    rejected: np.ndarray  # int64[words(len(zbuf))]: masks of the words the sampler's fast
    # path rejects (cml_edge.jit.gauss.normals)
    counters: np.ndarray  # int64[N_COUNTERS]


SCRATCH = ("xbuf", "ybuf", "bits", "idx", "sbuf", "vbuf", "driven", "zbuf", "rejected")
"""The state's work space: no kernel reads what an earlier call left there."""


def _scratch(rows: int, cols: int) -> dict[str, np.ndarray]:
    """Fresh work space of a (rows, cols) array (:data:`SCRATCH`)."""
    n = max(rows, cols)
    return {"xbuf": np.zeros(n), "ybuf": np.zeros(n), "bits": np.zeros(rows + cols, np.int64),
            "idx": np.zeros(n, np.int64), "sbuf": np.zeros(rows + cols), "vbuf": np.zeros(n),
            "driven": np.zeros(_words(n), np.int64), "zbuf": np.zeros(n + BLOCK_PAD),
            "rejected": np.zeros(_words(n + BLOCK_PAD), np.int64)}


def _words(bits: int) -> int:
    """The int64 words that hold ``bits`` bits."""
    return (bits + 63) // 64


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
    uniforms drawn from the array's stream. Counted only where the config enables them
    (and listed by ``counters`` only then, so that earlier results keep their keys):
    ``refreshes`` and ``refresh_pulses`` (``refresh``), ``calibration_reads`` (one per
    one-hot read of a periphery drift compensation), ``bm_rereads`` (bound management).
    """

    name = "crossbar"
    State = CrossbarState
    DEFAULT_PRESET = DEFAULT_PRESET
    counter_names = (
        "matvecs", "rmatvecs", "analog_macs", "dac_conversions", "adc_conversions",
        "adc_saturations", "outer_updates", "acc_writes", "line_pulses", "coincidences",
        "device_pulses", "devices_written", "commits", "rng_draws", "refreshes",
        "refresh_pulses", "calibration_reads", "bm_rereads", "pulses_capped",
    )
    assert len(counter_names) == N_COUNTERS

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
        (:func:`cml_edge.backends.crossbar.time.xbar_program`).
        """
        config = make_config(preset, **fields)
        W = np.asarray(W, dtype=np.float64)
        if W.ndim != 2 or 0 in W.shape:
            raise InputError(f"a crossbar holds a non-empty matrix, got shape {W.shape}")
        if not np.isfinite(W).all():
            raise InputError("a crossbar cannot be programmed with NaN or infinite weights")
        w_max = config.w_max_for(index) or config.w_headroom * float(np.abs(W).max()) or 1.0
        state = _new_state(W.shape, crossbar_params(config, w_max),
                           stream_key(int(seed), STREAM_DEVICE + int(index)))
        xbar_program(_without_acc(state), W)
        return cls(state, config, preset)

    def options(self) -> dict[str, Any]:
        return {"preset": self.preset, **self.config.to_dict()}

    @property
    def counters(self) -> dict[str, int]:
        """The counters, without those of effects the config leaves off (class docstring)."""
        c = self.config
        off = set()
        if not c.refresh:
            off |= {"refreshes", "refresh_pulses"}
        if not (c.drift_compensation and c.compensation_read == "periphery"):
            off.add("calibration_reads")
        if not c.bound_management:
            off.add("bm_rereads")
        return {k: int(v) for k, v in zip(self.counter_names, self.state.counters)
                if k not in off}

    @classmethod
    def _template(cls, options: dict[str, Any], counters_shape: tuple[int, ...]) -> Any:
        return cls.from_float(np.zeros((1, 1)), seed=0, index=0,
                              **options).state

    @classmethod
    def _restore(cls, state: CrossbarState, options: dict[str, Any]) -> CrossbarArray:
        options = dict(options)
        preset = options.pop("preset", cls.DEFAULT_PRESET)
        state = state._replace(Gp=_laid_out(state.Gp), Gm=_laid_out(state.Gm),
                               acc=laid_out(np.asarray(state.acc, dtype=np.float64)))
        shapes = {f: a.shape for f, a in new_fields(state.params, *state.Gp.shape).items()}
        for f, shape in (*shapes.items(), ("rng", (2,))):
            if getattr(state, f).shape != shape:
                raise InputError(f"field {f!r} has shape {getattr(state, f).shape}, "
                                 f"expected {shape}")
        config = make_config(preset, **options)
        if crossbar_params(config, state.params.w_max) != state.params:
            raise InputError("crossbar parameters do not match the saved options")
        return cls(state, config, preset)

    # the seam extras ----------------------------------------------------------------
    def to_float(self) -> np.ndarray:
        """The weights the array holds: (G+ - G-) / g_per_w, times the drift compensation."""
        p = self.state.params
        scale = swing(p)[0] / (p.g_max - p.g_min) * self.state.alpha[0]
        return np.ascontiguousarray((self.state.Gp - self.state.Gm) * scale)

    def elapse(self, seconds: float) -> None:
        """Let ``seconds`` pass with no reads or writes: conductance drift (and, if
        configured, the global drift compensation)."""
        seconds = float(seconds)
        if not math.isfinite(seconds) or seconds < 0:
            raise InputError(f"elapsed time {seconds!r} is not allowed (allowed: seconds >= 0)")
        xbar_elapse(_without_acc(self.state), seconds)

    @property
    def w_max(self) -> float:
        """The weight of a full conductance swing (the weight-to-conductance scale)."""
        return float(self.state.params.w_max)

    @property
    def dw_min(self) -> float:
        """The nominal weight change of one coincidence (0 when continuous)."""
        return float(self.state.params.dw_min)

    def conductances(self) -> tuple[np.ndarray, np.ndarray]:
        """Copies of (G+, G-) in micro-siemens."""
        return np.array(self.state.Gp), np.array(self.state.Gm)


_NO_ACC = np.zeros((0, 0))


def _without_acc(state: CrossbarState) -> CrossbarState:
    """``state`` with an empty accumulator, sharing every other array: for programming and
    drift, which never read it. The accumulator's layout follows the matrix's shape (row-major
    if wide), so the full state is two Numba types; without it, one, and these kernels
    compile once."""
    return state._replace(acc=_NO_ACC)


def _new_state(shape: tuple[int, int], params: Any, key: Any) -> CrossbarState:
    return CrossbarState(params=params, rng=np.array([key, 0], dtype=np.uint64),
                         **new_fields(params, *shape))


def new_fields(params: Any, rows: int, cols: int) -> dict[str, np.ndarray]:
    """Every array of a fresh (rows, cols) state but ``rng``: devices at 0 with unit steps,
    no drift, age, faults, noise offsets or per-device extras, the nominal bounds, a
    drift factor of 1, counters at 0 and fresh work space."""
    shape = (rows, cols)
    return dict(
        Gp=np.zeros(shape, order="F"), Gm=np.zeros(shape, order="F"),
        acc=laid_out(np.zeros(shape)), step=np.ones((4, rows, cols)),
        nu=np.zeros((2, rows, cols)), age=np.zeros((2, rows, cols)),
        stuck=np.zeros((2, rows, cols), np.int8), alpha=np.ones(1), elapsed=np.zeros(1),
        nu_z=np.zeros((2, rows, cols)), bnd=_nominal_bounds(params, rows, cols),
        wn=np.zeros((2, rows, cols)), rn=np.zeros((2, rows, cols)),
        aux=np.zeros((2 * AUX_PLANES, rows, cols)),
        counters=np.zeros(N_COUNTERS, np.int64), **_scratch(rows, cols),
    )


def _nominal_bounds(params: Any, rows: int, cols: int) -> np.ndarray:
    b = np.empty((4, rows, cols))
    b[0::2] = params.g_min
    b[1::2] = params.g_max
    return b


__all__ = ["CrossbarArray", "CrossbarState", "new_fields"]
