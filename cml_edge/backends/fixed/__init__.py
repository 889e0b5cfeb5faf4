"""The Loihi-style fixed-point device: ``int8``, ``int16`` and ``fixed`` (2..16-bit mantissas)."""

from cml_edge.backends.device import Backend, DeviceSpec, Report
from cml_edge.backends.dispatch import Kernels
from cml_edge.backends.fixed import kernels
from cml_edge.backends.fixed.array import FixedArray, FixedState
from cml_edge.backends.fixed.config import KNOBS, PRESETS, FixedConfig, cost_model

DEVICE = DeviceSpec(
    array_class=FixedArray,
    kernels=Kernels(kernels.fixed_matvec, kernels.fixed_rmatvec, kernels.fixed_outer_update,
                    kernels.fixed_commit, kernels.fixed_sigmoid),
    config_class=FixedConfig,
    backends={"int8": Backend("Loihi-style int8 weights, integer learning", preset="int8"),
              "int16": Backend("int16 weights, integer learning", preset="int16"),
              "fixed": Backend("fixed point of --bits N (2..16) bits")},
    presets=PRESETS,
    knobs=KNOBS,
    cost=cost_model,
    draws=lambda config: config.rounding == "stochastic",  # its rounding draws
    report=Report(
        systems=("int16", "int8"),
        # the precision sweep: mantissa bits, with and without stochastic rounding
        sweeps=tuple(("bits", (f"{b} bits {r}", "fixed", {"bits": b, "rounding": r}))
                     for r in ("stochastic", "nearest") for b in (16, 8, 6, 4)),
        # int8's other settings, any width
        breakpoints=(("fixed", ("bits",)),),
    ),
)

__all__ = ["DEVICE", "FixedArray", "FixedConfig", "FixedState"]
