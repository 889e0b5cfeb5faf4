"""The memristive crossbar device: differential conductance pairs on an analog array."""

from cml_edge.backends.crossbar.array import CrossbarArray, CrossbarState

__all__ = ["CrossbarArray", "CrossbarState"]
