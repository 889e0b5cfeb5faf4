"""The ``loihi2`` synaptic array: Loihi 2 as Intel's Lava models it, bit for bit.

Programming a float matrix W (:meth:`Loihi2Array.from_float`):

1. the float -> integer map (ours; Lava has none): W_int = rint(W 2^S) with S the largest
   power of two that puts W_int in Lava's standard 8-bit range of the sign mode (mixed
   [-128, 127]; ``lava.float_scale``);
2. Lava's ``optimize_weight_bits(W_int, sign_mode, loihi2=True)`` (re-implemented in
   :mod:`cml_edge.backends.loihi2.lava`) gives the mantissas, ``num_weight_bits`` and
   ``weight_exp``; the stored weights are the 8-bit, MSB-aligned values Lava's ``Dense``
   takes, ``truncate_weights(W_int << -weight_exp, sign_mode, num_weight_bits)``, i.e.
   mantissa << (8 - num_weight_bits + 1 if mixed): a generic mixed matrix becomes even
   integers in [-256, 254] (the LSB dropped), num_weight_bits 8, weight_exp -1;
3. a weight w then stands for w 2^(weight_exp - scale_exp), exactly, with
   scale_exp = S + weight_exp - (optimize_weight_bits' exponent) (equal to S unless
   ``weight_exp`` is fixed, which moves the scale with it and keeps the integers).

After learning, the weights live in Lava's 9-bit range ([-256, 255] mixed,
``clip_weights``) and reads use them at that resolution, as Lava's learning Dense does
(``PyLearningDenseModelBitApproximate`` truncates once, at its first step, and not after
learning): learned weights may be odd. Reads, the learning engine and the sigmoid table
are the kernels of :mod:`cml_edge.backends.loihi2.kernels`; the options the fields of
:class:`~cml_edge.backends.loihi2.config.Loihi2Config`. :meth:`Loihi2Array.to_lava`
gives what Lava's ``Dense`` needs to hold the same weights.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np

from cml_edge.backends.base import SynapticArray, laid_out
from cml_edge.backends.fields import matrix_value
from cml_edge.backends.loihi2 import kernels as kern
from cml_edge.backends.loihi2.config import (
    DRAWS,
    LEARNED_GAIN,
    PAYLOAD_SCALES,
    TERMS,
    TRACES,
    Loihi2Config,
    Loihi2Params,
    check_scale,
    loihi2_params,
    make_config,
)
from cml_edge.backends.loihi2.lava import (
    LAVA_SIGN_MODES,
    SIGN_MODES,
    STANDARD_RANGE,
    clip_weights,
    float_scale,
    optimize_weight_bits,
    truncate_weights,
    weight_limits,
)
from cml_edge.backends.quant import check_int
from cml_edge.errors import InputError
from cml_edge.jit.rng import stream_key
from cml_edge.protocol import STREAM_DEVICE


class Loihi2State(NamedTuple):
    w: np.ndarray  # (rows, cols) int16: 9-bit signed weights, as Lava's learning Dense holds them
    acc: np.ndarray  # (rows, cols) int32: learning accumulator, w << 7 plus the epoch's terms
    params: Loihi2Params  # formats, exponent, scale, options (config.py)
    rng: np.ndarray  # uint64[2]: stream key, next draw counter
    epoch: np.ndarray  # int64[1]: in-place updates since the learning epoch began
    xq: np.ndarray  # int64[max(rows, cols)] scratch: payloads / pre traces
    yq: np.ndarray  # int64[max(rows, cols)] scratch: post traces
    sums: np.ndarray  # int64[max(rows, cols)] scratch: dendritic sums
    tally: np.ndarray  # int64[3] scratch: an update's terms and saturations
    counters: np.ndarray  # int64[N_COUNTERS]


MATRIX_NAMES = ("W_q", "W_k", "W_v")


class Loihi2Array(SynapticArray):
    """Loihi 2 weights, graded-spike reads into 24-bit neurons, Lava's learning engine."""

    name = "loihi2"
    State = Loihi2State
    mapping = "initial"  # the float -> integer mapping it was programmed with (config.py)
    counter_names = (
        "matvecs", "rmatvecs", "macs", "weight_reads", "neuron_wraps", "outer_updates",
        "update_macs", "product_saturations", "acc_saturations", "commits", "epochs",
        "weight_writes", "cells_changed", "weight_saturations", "sign_clips",
        "program_clips", "rng_draws", "bits_read", "bits_written", "bytes_read",
        "bytes_written",
    )
    assert len(counter_names) == kern.N_COUNTERS

    # construction -----------------------------------------------------------------
    @classmethod
    def from_float(cls, W: np.ndarray, *, seed: int = 0, index: int = 0,
                   **options: Any) -> Loihi2Array:
        """Program W as the module docstring says. ``options``: the fields of
        :class:`~cml_edge.backends.loihi2.config.Loihi2Config`. Weights of the wrong sign
        for the sign mode are clipped to zero and counted (``program_clips``)."""
        config = make_config(**options)
        seed = check_int(seed, "seed", 0, 2**63 - 1)
        index = check_int(index, "index", 0, 2**16)
        W = np.asarray(W, dtype=np.float64)
        if W.ndim != 2 or W.size == 0:
            raise InputError(f"expected a non-empty matrix, got shape {W.shape}")
        if not np.isfinite(W).all():
            raise InputError("the weights to program are not all finite")
        what = MATRIX_NAMES[index] if index < len(MATRIX_NAMES) else f"matrix {index}"
        mode = config.sign_mode
        lo, hi = weight_limits(mode)
        if mode == "mixed":
            wrong = 0
        else:  # clip_weights: the weights of the wrong sign become zero
            wrong = int(np.count_nonzero(W < 0 if mode == "excitatory" else W > 0))
            W = np.maximum(W, 0.0) if mode == "excitatory" else np.minimum(W, 0.0)
        planned = 0
        fixed_scale = matrix_value(config, "scale_exp", index)
        fixed_exp = matrix_value(config, "weight_exp", index)
        if fixed_scale is None:
            S = float_scale(W, mode)
            if config.mapping == "learned":
                S += LEARNED_GAIN[min(index, len(LEARNED_GAIN) - 1)]
            W_int = np.rint(np.ldexp(W, S))
            std_lo, std_hi = STANDARD_RANGE[mode]
            outside = int(np.count_nonzero((W_int < std_lo) | (W_int > std_hi)))
            wrong += outside
            if config.mapping == "learned":  # by design: the initial weights past the range
                planned = outside  # the matrix holds after learning (counted, never refused)
            W_int = np.clip(W_int, std_lo, std_hi)
            opt = optimize_weight_bits(W_int, mode, loihi2=True)
            nb = config.num_weight_bits or max(opt.num_weight_bits, 1)
            msb = W_int.astype(np.int32) << -opt.weight_exp  # the loihi2=False weights
            w = truncate_weights(msb, mode, nb)
            exp = opt.weight_exp if fixed_exp is None else fixed_exp
            scale_exp = check_scale(S + exp - opt.weight_exp, what)
        else:
            exp = 0 if fixed_exp is None else fixed_exp
            nb = config.num_weight_bits or 8
            scale_exp = fixed_scale
            full = np.rint(np.ldexp(W, scale_exp - exp))
            wrong += int(np.count_nonzero((full < lo) | (full > hi)))
            w = truncate_weights(clip_weights(np.clip(full, -2**20, 2**20), mode), mode, nb)
        if wrong > planned and config.strict:
            raise InputError(f"{what}: {wrong - planned} weights do not fit sign mode {mode} "
                             "(strict mode)")
        params = loihi2_params(config, exp, scale_exp, nb)
        rows, cols = W.shape
        n = max(rows, cols)
        w = laid_out(w.astype(np.int16))
        counters = np.zeros(kern.N_COUNTERS, np.int64)
        counters[kern.PROGRAM_CLIPS] = wrong
        rng = np.array([stream_key(seed, STREAM_DEVICE + index), 0], dtype=np.uint64)
        state = Loihi2State(w, laid_out(w.astype(np.int32) << kern.FRAC_BITS), params, rng,
                            np.zeros(1, np.int64), np.zeros(n, np.int64),
                            np.zeros(n, np.int64), np.zeros(n, np.int64),
                            np.zeros(3, np.int64), counters)
        arr = cls(state)
        arr.mapping = config.mapping
        return arr

    def options(self) -> dict[str, Any]:
        p = self.state.params
        return {"num_message_bits": p.num_message_bits, "num_weight_bits": p.nb,
                "weight_exp": p.exp, "scale_exp": p.scale_exp,
                "sign_mode": SIGN_MODES[p.sign_mode], "t_epoch": p.t_epoch,
                "draws": DRAWS[p.draws], "payload_scale": PAYLOAD_SCALES[p.payload_scale],
                "terms": TERMS[p.terms], "traces": TRACES[p.traces], "mapping": self.mapping,
                "strict": bool(p.strict)}

    @property
    def config(self) -> Loihi2Config:
        """The config this array was built with (its exponent, scale and weight bits
        fixed)."""
        return make_config(**self.options())

    # reading the state --------------------------------------------------------------
    @property
    def exponent(self) -> int:
        """Lava's ``weight_exp`` of this matrix."""
        return int(self.state.params.exp)

    @property
    def scale_exp(self) -> int:
        """A weight w stands for w 2^(weight_exp - scale_exp)."""
        return int(self.state.params.scale_exp)

    @property
    def lsb(self) -> float:
        """The float value of a weight of 1: 2^(weight_exp - scale_exp)."""
        return 2.0 ** (self.exponent - self.scale_exp)

    @property
    def mantissa(self) -> np.ndarray:
        """The ``num_weight_bits`` mantissas ``optimize_weight_bits(..., loihi2=True)``
        gives for the weights as ``Dense`` would truncate them (``truncate_weights``, then
        >> the dropped bits; inhibitory by magnitude, as Lava)."""
        p = self.state.params
        mode = SIGN_MODES[p.sign_mode]
        return truncate_weights(self.state.w, mode, p.nb) >> p.shift  # exact: multiples

    @property
    def parameter_bytes(self) -> float:
        """Bytes of the programmed weights at ``num_weight_bits`` each."""
        return self.state.w.size * int(self.state.params.nb) / 8

    def weight_bits(self) -> int:
        """``num_weight_bits`` (learning keeps 9-bit weights; the budget counts the
        programmed width)."""
        return int(self.state.params.nb)

    def accumulator_bits(self) -> int:
        """The learning accumulator: 16 bits (Lava ``W_ACCUMULATOR_S``)."""
        return kern.ACC_BITS

    def to_float(self) -> np.ndarray:
        return np.ldexp(self.state.w.astype(np.float64), self.exponent - self.scale_exp)

    def pending_float(self) -> np.ndarray:
        """What the accumulator holds beyond the weights, in float (the epoch's terms)."""
        extra = self.state.acc.astype(np.float64) - self.state.w.astype(np.float64) * 128
        return np.ldexp(extra, self.exponent - self.scale_exp - kern.FRAC_BITS)

    def to_lava(self) -> dict[str, Any]:
        """What Lava's ``Dense`` takes to hold exactly these weights (module docstring):

        - ``weights``: the integers as ``Dense(weights=...)`` takes them (shape (out, in));
          its bit-accurate model then applies ``clip_weights`` and ``truncate_weights``;
        - ``num_weight_bits``: the array's programmed width where ``truncate_weights``
          keeps every weight at it; else the narrowest width up to 9 (mixed; 8 otherwise)
          that does: learned weights use the 9-bit range the learning engine writes, and
          in mixed mode Lava drops 8 - num_weight_bits + 1 low bits, none at 9;
        - ``weight_exp``, ``sign_mode`` (the name of Lava's ``SignMode`` member: ``MIXED``,
          ``EXCITATORY`` or ``INHIBITORY``; pass ``SignMode[name]``: ``Dense`` compares the
          member, and a bare integer makes it clip every negative weight) and
          ``num_message_bits``;
        - ``payload_l1_max``: the largest L1 norm of a read's payloads (0: no bound, the
          ``full`` payload scale);
        - ``mantissa``: the programmed width's mantissas (``optimize_weight_bits(...,
          loihi2=True)``'s form), ``scale_exp`` (a weight w is the float
          w 2^(weight_exp - scale_exp)), and ``lsb_truncated``: how many weights
          ``truncate_weights`` changes at the exported ``num_weight_bits`` (0: a ``Dense``
          built from these values holds the weights exactly).
        """
        p = self.state.params
        mode = SIGN_MODES[p.sign_mode]
        w = self.state.w.astype(np.int32)
        nb = int(p.nb)
        top = 9 if mode == "mixed" else 8
        while nb < top and (truncate_weights(w, mode, nb) != w).any():
            nb += 1
        truncated = truncate_weights(w, mode, nb)
        return {"weights": w, "weight_exp": int(p.exp), "num_weight_bits": nb,
                "sign_mode": LAVA_SIGN_MODES[mode], "num_message_bits":
                int(p.num_message_bits), "mantissa": self.mantissa.astype(np.int32),
                "scale_exp": int(p.scale_exp),
                "lsb_truncated": int(np.count_nonzero(truncated != w)),
                "payload_l1_max": int(p.l1_max) if PAYLOAD_SCALES[p.payload_scale] == "safe"
                else 0}

    # persistence ------------------------------------------------------------------
    @classmethod
    def _restore(cls, state: Loihi2State, options: dict[str, Any]) -> Loihi2Array:
        config = make_config(**options)
        ref = loihi2_params(config, int(config.weight_exp), int(config.scale_exp),
                            int(config.num_weight_bits))
        if state.params != ref:
            raise InputError("loihi2 parameters do not match the saved options")
        rows, cols = state.w.shape
        n = max(rows, cols)
        for f, shape in (("rng", (2,)), ("epoch", (1,)), ("xq", (n,)), ("yq", (n,)),
                         ("sums", (n,)), ("tally", (3,))):
            if getattr(state, f).shape != shape:
                raise InputError(f"field {f!r} has shape {getattr(state, f).shape}, "
                                 f"expected {shape}")
        p = state.params
        w = state.w.astype(np.int64)
        if w.min() < p.w_min or w.max() > p.w_max:
            raise InputError(f"weights beyond the range [{p.w_min}, {p.w_max}]")
        acc = state.acc.astype(np.int64)
        if acc.min() < kern.ACC_MIN or acc.max() > kern.ACC_MAX:
            raise InputError("learning accumulator beyond its 16-bit range")
        if not 0 <= int(state.epoch[0]) < p.t_epoch:
            raise InputError(f"epoch position {int(state.epoch[0])} is beyond t_epoch "
                             f"{p.t_epoch}")
        if (state.counters < 0).any():
            raise InputError("negative counters")
        arr = cls(state._replace(w=laid_out(state.w), acc=laid_out(state.acc)))
        arr.mapping = config.mapping if "mapping" in options else "initial"  # older files
        return arr


def lava_description(arr: Loihi2Array, name: str) -> dict[str, Any]:
    """The JSON description of one matrix for a Lava user (``cml-edge export``)."""
    d = arr.to_lava()
    rows, cols = arr.shape
    kept = ("a Dense built from these values holds every weight exactly" if not
            d["lsb_truncated"] else f"truncate_weights changes {d['lsb_truncated']} "
            "weights at this num_weight_bits")
    out = {
        "matrix": name, "shape": [rows, cols], "file": f"{name}.npz",
        "dense": {"weights": f"np.load('{name}.npz')['weights']",
                  "weight_exp": d["weight_exp"], "num_weight_bits": d["num_weight_bits"],
                  "sign_mode": d["sign_mode"], "num_message_bits": d["num_message_bits"]},
        "build": (f"Dense(weights=np.load('{name}.npz')['weights'], weight_exp="
                  f"{d['weight_exp']}, num_weight_bits={d['num_weight_bits']}, "
                  f"sign_mode=SignMode.{d['sign_mode']}, num_message_bits="
                  f"{d['num_message_bits']})  # from lava.proc.dense.process import Dense; "
                  "from lava.utils.weightutils import SignMode"),
        "scale_exp": d["scale_exp"],
        "float_weights": f"weights * 2**({d['weight_exp']} - {d['scale_exp']})",
        "read": ("x (float, length in) -> payloads s = rint(x * 2**-e) with one power-of-two "
                 "scale e per vector, the finest at which |s| <= 2**(num_message_bits - 1) - 1 "
                 "and, where payload_l1_max > 0, sum |s| <= payload_l1_max; the Dense's "
                 "a_out = (weights @ s) >> -weight_exp (weight_exp < 0; << otherwise; "
                 "an int32 dot product); the neuron's input is a_out << 6 (LIF with "
                 "du=4095; u past +-2^23 gets one 2^24 correction); W x = u * "
                 "2**(e - scale_exp - 6)"),
        "lsb_truncated": d["lsb_truncated"],
        "lsb_note": (f"Dense's bit-accurate model applies truncate_weights(weights, "
                     f"sign_mode, {d['num_weight_bits']}) at its first step: {kept}"),
    }
    if name == "W_v":
        out["transposed_read"] = ("planning reads u = W_v^T (s* - s): build a second Dense "
                                  "with weights=np.load('W_v.npz')['weights'].T and the "
                                  "same parameters")
    return out


__all__ = ["Loihi2Array", "Loihi2State", "lava_description"]
