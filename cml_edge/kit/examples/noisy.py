# noisy.py
"""Float weights read with Gaussian noise: an analog array's reads, ideal writes."""
from dataclasses import dataclass

from cml_edge.kit import Device, Knob, normal, option


@dataclass(frozen=True)
class Noisy:
    """Each read of a weight adds noise; writes are exact."""

    sigma: float = option(0.05, lo=0.0, hi=2.0, why="a fraction of the matrix's scale")
    """The std of each read's noise, as a fraction of the largest weight programmed."""


def read(p, w, rng):
    """The weight as one read sees it: w plus a fresh normal draw."""
    return w + p.sigma * p.w_scale * normal(rng)


DEVICE = Device("noisy", Noisy, read=read,
                knobs=(Knob("sigma", "sigma", 0.0, 1.0, "low", doc="read noise"),))
