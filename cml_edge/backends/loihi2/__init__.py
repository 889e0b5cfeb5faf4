"""The ``loihi2`` device: Loihi 2 as Intel's Lava models it bit for bit, and export to Lava."""

from cml_edge.backends.device import Backend, DeviceSpec, Reference, Report
from cml_edge.backends.dispatch import Kernels
from cml_edge.backends.loihi2 import kernels
from cml_edge.backends.loihi2.array import Loihi2Array, Loihi2State
from cml_edge.backends.loihi2.config import (
    COST,
    KNOBS,
    PRESETS,
    REFERENCE,
    Loihi2Config,
    beyond_lava,
)

DEVICE = DeviceSpec(
    array_class=Loihi2Array,
    kernels=Kernels(kernels.loihi2_matvec, kernels.loihi2_rmatvec, kernels.loihi2_outer_update,
                    kernels.loihi2_commit, kernels.loihi2_sigmoid),
    config_class=Loihi2Config,
    backends={"loihi2": Backend("Loihi 2 as Lava's bit-accurate models: 8-bit weights, "
                                "graded spikes, 24-bit neurons, the learning engine; "
                                "default --schedule step, what Lava runs (walk keeps the "
                                "engine's accumulator across a walk, which Lava cannot)")},
    presets=PRESETS,
    knobs=KNOBS,
    cost=COST,
    draws=True,  # the write-back's stochastic rounding
    report=Report(systems=("loihi2",), breakpoints=(("loihi2", ("bits",)),)),
    schedule="step",  # the one Lava runs: the engine's rule once per epoch (t_epoch 1)
    reference=Reference(REFERENCE, beyond_lava),
)

__all__ = ["DEVICE", "Loihi2Array", "Loihi2Config", "Loihi2State"]
