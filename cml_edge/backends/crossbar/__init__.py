"""The memristive crossbar device: differential conductance pairs on an analog array."""

from cml_edge.backends.crossbar import kernels
from cml_edge.backends.crossbar.array import CrossbarArray, CrossbarState
from cml_edge.backends.crossbar.config import (
    ANALOG,
    DEFAULT_PRESET,
    KNOBS,
    PRESETS,
    DeviceConfig,
    draws,
)
from cml_edge.backends.device import Backend, DeviceSpec, Report, Tolerance
from cml_edge.backends.dispatch import Kernels

REPORT_KNOBS = ("read_noise", "prog_noise", "levels", "drift_time", "stuck", "adc_bits")
"""The break points of the report on the calibrated presets (``drift_time``: the idle time,
a knob of every device)."""

DEVICE = DeviceSpec(
    array_class=CrossbarArray,
    kernels=Kernels(kernels.xbar_matvec, kernels.xbar_rmatvec, kernels.xbar_outer_update,
                    kernels.xbar_commit, kernels.xbar_sigmoid),
    config_class=DeviceConfig,
    backends={"crossbar": Backend("memristive crossbar: --preset ideal|pcm|reram|"
                                  "pcm-symmetric|reram-symmetric, --levels, --set",
                                  preset=DEFAULT_PRESET, fixed=False)},
    presets=PRESETS,
    knobs=KNOBS,
    cost=ANALOG,
    draws=draws,
    report=Report(
        systems=("crossbar",),  # every preset
        sweeps=(*[("levels", (f"pcm {n} levels", "crossbar", {"preset": "pcm", "levels": n}))
                  for n in (4, 16, 64, 256)],
                *[("read noise", (f"pcm read_noise {x:g}", "crossbar",
                                  {"preset": "pcm", "read_noise": x}))
                  for x in (0.05, 0.2, 0.5, 1.0)]),
        # the calibrated presets on every knob; ideal on those that make it non-ideal
        breakpoints=(("crossbar:pcm", REPORT_KNOBS), ("crossbar:reram", REPORT_KNOBS),
                     ("crossbar:ideal", ("read_noise", "levels", "stuck", "adc_bits"))),
    ),
    # where the physics departs from the default (0.8, 0.6..1.4), as measured
    tolerance={
        "pcm": Tolerance(0.8, (2.0, 3.5), why="the SET-only PCM's exponential steps near "
                         "g_min, where one-sided weights sit, are larger than the controller's "
                         "full-range calibration assumes: its weights move 2.6-2.9x as far as "
                         "the rule asks (correlation 0.89-0.93)"),
        "reram": Tolerance(0.4, (0.3, 1.0), why="the ReRAM's write noise (56 dG per pulse) "
                           "and additive cycle-to-cycle noise (3.75 dG) decorrelate a burst "
                           "(correlation 0.55-0.70, projection 0.53-0.72)"),
    },
)

__all__ = ["DEVICE", "CrossbarArray", "CrossbarState", "DeviceConfig"]
