"""The memristive crossbar device: differential conductance pairs on an analog array."""

from cml_edge.backends.crossbar import kernels
from cml_edge.backends.crossbar.array import CrossbarArray, CrossbarState
from cml_edge.backends.crossbar.config import DEFAULT_PRESET, PRESETS, DeviceConfig
from cml_edge.backends.device import Backend, DeviceSpec
from cml_edge.backends.dispatch import Kernels

DEVICE = DeviceSpec(
    array_class=CrossbarArray,
    kernels=Kernels(kernels.xbar_matvec, kernels.xbar_rmatvec, kernels.xbar_outer_update,
                    kernels.xbar_commit, kernels.xbar_sigmoid),
    config_class=DeviceConfig,
    backends={"crossbar": Backend("memristive crossbar: --preset ideal|pcm|reram|"
                                  "pcm-symmetric|reram-symmetric, --levels, --set",
                                  preset=DEFAULT_PRESET, fixed=False)},
    presets=PRESETS,
    technology="analog",
    report=tuple((f"crossbar-{p}", "crossbar", {"preset": p}) for p in PRESETS),
)

__all__ = ["DEVICE", "CrossbarArray", "CrossbarState", "DeviceConfig"]
