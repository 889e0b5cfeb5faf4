# ternary.py
"""A ternary-weight accelerator: every weight is -a, 0 or +a."""
import math
from dataclasses import dataclass

from cml_edge.kit import Device, Tolerance, option, uniform


@dataclass(frozen=True)
class Ternary:
    """Weights in {-a, 0, +a}; an update is rounded onto them stochastically."""

    level: float = option(0.5, lo=0.01, hi=4.0, why="a fraction of the matrix's scale")
    """a, as a fraction of the largest weight programmed into the matrix (p.w_scale)."""


def write(p, w, dw, rng):
    """w + dw rounded to a neighbouring level, up with the probability of the rest: the
    levels are right on average, and a small update still moves a weight sometimes."""
    a = p.level * p.w_scale
    t = min(max((w + dw) / a, -1.0), 1.0)
    low = math.floor(t)
    return a * (low + (uniform(rng) < t - low))


DEVICE = Device(
    "ternary", Ternary, write=write, weight_bits=2,
    tolerance=Tolerance(0.3, (0.4, 1.6), why="stochastic rounding onto three levels is "
                        "right only on average: a 20-update burst correlates 0.36-0.59 with "
                        "the rule and projects 0.54-1.30 of it (5 chip seeds)"))
