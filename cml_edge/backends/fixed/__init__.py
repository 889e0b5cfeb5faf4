"""The Loihi-style fixed-point device: ``int8``, ``int16`` and ``fixed`` (2..16-bit mantissas)."""

from cml_edge.backends.device import Backend, DeviceSpec
from cml_edge.backends.dispatch import Kernels
from cml_edge.backends.fixed import kernels
from cml_edge.backends.fixed.array import FixedArray, FixedState
from cml_edge.backends.fixed.config import PRESETS, FixedConfig

DEVICE = DeviceSpec(
    array_class=FixedArray,
    kernels=Kernels(kernels.fixed_matvec, kernels.fixed_rmatvec, kernels.fixed_outer_update,
                    kernels.fixed_commit, kernels.fixed_sigmoid),
    config_class=FixedConfig,
    backends={"int8": Backend("Loihi-style int8 weights, integer learning", preset="int8"),
              "int16": Backend("int16 weights, integer learning", preset="int16"),
              "fixed": Backend("fixed point of --bits N (2..16) bits")},
    presets=PRESETS,
    technology=lambda config: "int8" if config.bits <= 8 else "int16",
    report=(("int16", "int16", {}), ("int8", "int8", {})),
)

__all__ = ["DEVICE", "FixedArray", "FixedConfig", "FixedState"]
