"""The float reference device: weights and arithmetic in float64 (``float``) or float32."""

from cml_edge.backends.device import Backend, DeviceSpec, Report
from cml_edge.backends.dispatch import Kernels
from cml_edge.backends.floating import kernels
from cml_edge.backends.floating.array import FloatArray, FloatState
from cml_edge.backends.floating.config import PRESETS, FloatConfig, cost_model

DEVICE = DeviceSpec(
    array_class=FloatArray,
    kernels=Kernels(kernels.float_matvec, kernels.float_rmatvec, kernels.float_outer_update,
                    kernels.float_commit, kernels.float_sigmoid),
    config_class=FloatConfig,
    backends={"float": Backend("float64 reference", preset="float"),
              "float32": Backend("float32 weights and arithmetic", preset="float32")},
    presets=PRESETS,
    cost=cost_model,
    report=Report(systems=(("float64", "float", {}), "float32")),
)

__all__ = ["DEVICE", "FloatArray", "FloatConfig", "FloatState"]
