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

import json
import math
import types
from typing import Any, NamedTuple

import numpy as np

from cml_edge.backends.base import SynapticArray, laid_out
from cml_edge.backends.crossbar.codes import AUX_PLANES, N_COUNTERS
from cml_edge.backends.crossbar.config import (
    DEFAULT_PRESET,
    NEW_FIELDS,
    CrossbarParams,
    DeviceConfig,
    crossbar_params,
    make_config,
)
from cml_edge.backends.crossbar.time import xbar_elapse, xbar_program
from cml_edge.backends.params import record_names, record_to_array
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
                              **saved_options(options)).state

    @classmethod
    def _restore(cls, state: CrossbarState, options: dict[str, Any]) -> CrossbarArray:
        options = saved_options(options)
        preset = options.pop("preset", cls.DEFAULT_PRESET)
        state = state._replace(Gp=_laid_out(state.Gp), Gm=_laid_out(state.Gm),
                               acc=laid_out(np.asarray(state.acc, dtype=np.float64)))
        sizes = {f: a.shape for f, a in _scratch(*state.Gp.shape).items()}
        for f, shape in (*sizes.items(), ("rng", (2,)), ("alpha", (1,)), ("elapsed", (1,))):
            if getattr(state, f).shape != shape:
                raise InputError(f"field {f!r} has shape {getattr(state, f).shape}, "
                                 f"expected {shape}")
        for f, k in (("step", 4), ("nu", 2), ("age", 2), ("stuck", 2), ("nu_z", 2),
                     ("bnd", 4), ("wn", 2), ("rn", 2), ("aux", 2 * AUX_PLANES)):
            if getattr(state, f).shape != (k, *state.Gp.shape):
                raise InputError(f"field {f!r} has shape {getattr(state, f).shape}, "
                                 f"expected {(k, *state.Gp.shape)}")
        config = make_config(preset, **options)
        if crossbar_params(config, state.params.w_max) != state.params:
            raise InputError("crossbar parameters do not match the saved options")
        return cls(state, config, preset)

    @classmethod
    def _upgrade(cls, d: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """A state saved before the parameter record (no ``__params__``): ``params`` was
        one float64 vector of 32 hand-numbered slots, :data:`LEGACY_PARAMS` in that order,
        with the run-time alpha and elapsed among them. They move to their state arrays;
        the record is rebuilt from the saved options and the saved w_max, and the old
        vector must equal that record's legacy view, or the file is refused."""
        if "__params__" in d or "params" not in d:
            return _upgrade_scratch(_upgrade_calibrated(d))
        old = np.asarray(d["params"])
        if old.dtype != np.float64 or old.shape != (len(LEGACY_PARAMS),):
            raise InputError(f"field 'params' has shape {old.shape}, expected "
                             f"({len(LEGACY_PARAMS)},)")
        slots = dict(zip(LEGACY_PARAMS, old.tolist()))
        options = saved_options(json.loads(str(d["__options__"])))
        preset = options.pop("preset", cls.DEFAULT_PRESET)
        record = crossbar_params(make_config(preset, **options), slots["w_max"])
        if not np.array_equal(legacy_params(record, slots["alpha"], slots["elapsed"]), old):
            raise InputError("crossbar parameters do not match the saved options")
        return _upgrade_scratch(_upgrade_calibrated(
            {**d, "params": record_to_array(record), "__params__": record_names(record),
             "alpha": np.array([slots["alpha"]]), "elapsed": np.array([slots["elapsed"]])}))

    # the seam extras ----------------------------------------------------------------
    def to_float(self) -> np.ndarray:
        """The weights the array holds: (G+ - G-) / g_per_w, times the drift compensation."""
        p = self.state.params
        scale = p.w_max / (p.g_max - p.g_min) * self.state.alpha[0]
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
    rows, cols = shape
    order = "F"
    return CrossbarState(
        Gp=np.zeros(shape, order=order), Gm=np.zeros(shape, order=order),
        acc=laid_out(np.zeros(shape)), step=np.ones((4, rows, cols)),
        nu=np.zeros((2, rows, cols)), age=np.zeros((2, rows, cols)),
        stuck=np.zeros((2, rows, cols), np.int8), params=params, alpha=np.ones(1),
        elapsed=np.zeros(1), rng=np.array([key, 0], dtype=np.uint64),
        nu_z=np.zeros((2, rows, cols)), bnd=_nominal_bounds(params, rows, cols),
        wn=np.zeros((2, rows, cols)), rn=np.zeros((2, rows, cols)),
        aux=np.zeros((2 * AUX_PLANES, rows, cols)),
        counters=np.zeros(N_COUNTERS, np.int64), **_scratch(rows, cols),
    )


def saved_options(options: dict[str, Any]) -> dict[str, Any]:
    """Saved options with every calibrated-physics field (:data:`NEW_FIELDS`) that they
    lack at its default (off): a file saved before those fields restores with the physics
    it was saved with, not with what its preset names now (``pcm`` then is
    ``pcm-symmetric`` now)."""
    options = dict(options)
    defaults = DeviceConfig()
    for name in NEW_FIELDS:
        options.setdefault(name, getattr(defaults, name))
    return options


def _upgrade_calibrated(d: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """A state saved before the calibrated-physics fields: the parameter record gains the
    new fields (from the completed options, with the saved w_max; the saved fields must
    agree), the new state arrays start at their neutral values (no bound spread, no noise
    offsets, no per-device extras) and the new counters at 0."""
    if "params" not in d or "__params__" not in d or "__options__" not in d:
        return d
    if "Gp" not in d or "counters" not in d or np.asarray(d["Gp"]).ndim != 2:
        return d  # refused by the loader
    names = json.loads(str(d["__params__"]))
    if not isinstance(names, list) or np.asarray(d["params"]).shape != (len(names),):
        raise InputError(f"field 'params' has shape {np.asarray(d['params']).shape} for "
                         f"{len(names) if isinstance(names, list) else '?'} field names")
    out = dict(d)
    if names != list(CrossbarParams._fields):
        old = dict(zip(names, np.asarray(d["params"]).tolist()))
        if "w_max" not in old or set(old) - set(CrossbarParams._fields):
            return d  # refused by the loader, naming the fields it expected
        options = saved_options(json.loads(str(d["__options__"])))
        preset = options.pop("preset", DEFAULT_PRESET)
        record = crossbar_params(make_config(preset, **options), old["w_max"])
        if any(getattr(record, k) != v for k, v in old.items()):
            raise InputError("crossbar parameters do not match the saved options")
        out.update(params=record_to_array(record), __params__=record_names(record))
    elif all(f in d for f in ("nu_z", "bnd", "wn", "rn", "aux")):
        return d  # the current layout
    else:
        record = dict(zip(names, np.asarray(d["params"]).tolist()))
        record = types.SimpleNamespace(g_min=record.get("g_min", 0.0),
                                       g_max=record.get("g_max", 1.0))
    rows, cols = np.asarray(d["Gp"]).shape
    counters = np.asarray(d["counters"])
    out.setdefault("nu_z", np.zeros((2, rows, cols)))
    out.setdefault("bnd", _nominal_bounds(record, rows, cols))
    out.setdefault("wn", np.zeros((2, rows, cols)))
    out.setdefault("rn", np.zeros((2, rows, cols)))
    out.setdefault("aux", np.zeros((2 * AUX_PLANES, rows, cols)))
    if counters.ndim == 1 and counters.shape[0] < N_COUNTERS:
        out["counters"] = np.concatenate(
            [counters, np.zeros(N_COUNTERS - counters.shape[0], counters.dtype)])
    return out


def _upgrade_scratch(d: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """A state saved before one of the work-space fields (:data:`SCRATCH`) existed gets it
    fresh: no kernel reads what such a field held."""
    if "Gp" not in d or np.asarray(d["Gp"]).ndim != 2:
        return d  # refused by the loader
    missing = {f: a for f, a in _scratch(*np.asarray(d["Gp"]).shape).items() if f not in d}
    return {**d, **missing}


def _nominal_bounds(params: Any, rows: int, cols: int) -> np.ndarray:
    b = np.empty((4, rows, cols))
    b[0::2] = params.g_min
    b[1::2] = params.g_max
    return b


# the layout before the parameter record ---------------------------------------------------
LEGACY_PARAMS = (
    "g_min", "g_max", "dG", "w_max", "g_per_w", "dw_min", "update", "commit", "bl_max",
    "dw_min_std", "bounds", "prog_noise", "prog_c0", "prog_c1", "prog_c2", "prog_gref",
    "read_noise", "out_noise", "dac_step", "adc_step", "adc_bound", "drift_t0",
    "drift_compensation", "alpha", "elapsed", "dw_min_dtod", "up_down", "up_down_dtod",
    "drift_nu", "drift_nu_std", "stuck_low", "stuck_high",
)
"""The 32 slots of the float64 ``params`` vector of files saved before the record (the old
``P_*`` indices 0..31, in order). Slot ``adc_bound`` held inf when there was no ADC."""


def legacy_params(record: Any, alpha: float, elapsed: float) -> np.ndarray:
    """The old 32-slot vector of ``record`` (:data:`LEGACY_PARAMS`)."""
    values = {**record._asdict(), "alpha": alpha, "elapsed": elapsed}
    if record.adc_bits <= 0:
        values["adc_bound"] = math.inf
    return np.array([float(values[name]) for name in LEGACY_PARAMS])


__all__ = ["LEGACY_PARAMS", "CrossbarArray", "CrossbarState", "legacy_params"]
