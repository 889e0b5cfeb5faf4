# ecram.py
"""A Li-ion ECRAM cell: pulsed, asymmetric and nonlinear updates, noise, and retention of
hours (figures: aihwkit 1.1.0's EcRamPresetDevice, its fit of Tang et al., IEDM 2018)."""
import math
from dataclasses import dataclass

from cml_edge.kit import Device, Knob, normal, option, uniform

W_MIN, W_MAX = -0.8276, 1.1724  # the device's range, its symmetry point at 0 (aihwkit)


@dataclass(frozen=True)
class Ecram:
    """A linear-step device (aihwkit's LinearStepDevice) with relaxation when idle."""

    dw_min: float = option(0.002, lo=1e-5, hi=0.2, why="a fraction of the device range")
    """One pulse's step at w = 0, in device units (the range W_MIN..W_MAX is 2: 1,000
    steps)."""
    gamma_up: float = option(0.1153, lo=0.0, hi=1.0, why="the step's fall toward w_max")
    """The up step is dw_min (1 - gamma_up w / W_MAX): 11.5 % smaller at the top."""
    gamma_down: float = option(0.5085, lo=0.0, hi=1.0, why="the step's fall toward w_min")
    """The down step is dw_min (1 + gamma_down w / |W_MIN|): half as large at the
    bottom; the asymmetry pulls a weight toward W_MIN under balanced updates."""
    c2c: float = option(0.3, lo=0.0, hi=2.0, why="a relative std")
    """Cycle-to-cycle noise: each pulse's step times (1 + c2c N(0, 1))."""
    d2d: float = option(0.1, lo=0.0, hi=0.5, why="a relative std")
    """Device-to-device spread: each cell's step times (1 + d2d N(0, 1)), drawn once."""
    retention_s: float = option(1.08e4, lo=1.0, hi=1e12, why="a time constant in seconds")
    """Idle weights relax toward 0 as exp(-t / retention_s): Li-ion ECRAM held its state
    for "a few hours" before phase-separated cells (Kim et al. 2022, arXiv:2210.06658);
    3 hours here."""
    headroom: float = option(2.0, lo=0.1, hi=100.0, why="a multiple of max |W|")
    """The weight of W_MAX, as a multiple of the largest weight programmed."""


def cell(p, rng):
    """This cell's step gain (device-to-device)."""
    return (1.0 + p.d2d * normal(rng),)


def write(p, w, dw, cell, rng):
    """|dw| in pulses of dw_min (rounded stochastically), each a linear step with its
    cycle-to-cycle noise, within the device's range."""
    scale = p.headroom * p.w_scale / W_MAX  # weight per device unit
    x, pulses = w / scale, abs(dw) / (scale * p.dw_min)
    n = int(math.floor(pulses)) + (uniform(rng) < pulses - math.floor(pulses))
    for _ in range(n):
        if dw > 0:
            step = cell[0] * p.dw_min * (1.0 - p.gamma_up * x / W_MAX)
        else:
            step = -cell[0] * p.dw_min * (1.0 - p.gamma_down * x / W_MIN)
        x = min(max(x + step * (1.0 + p.c2c * normal(rng)), W_MIN), W_MAX)
    return x * scale


def drift(p, w, t):
    """Relaxation toward the symmetry point while idle for t seconds."""
    return w * math.exp(-t / p.retention_s)


DEVICE = Device("ecram", Ecram, write=write, cell=cell, cell_fields=("gain",), drift=drift,
                program=lambda p, w: w, weight_bits=10,
                knobs=(Knob("c2c", "c2c", 0.0, 2.0, "low", doc="cycle-to-cycle noise"),
                       Knob("retention_s", "retention_s", 60.0, 1e8, "high", log=True,
                            doc="retention time constant")))
