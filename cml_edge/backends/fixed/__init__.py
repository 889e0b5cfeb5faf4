"""The Loihi-style fixed-point device: ``int8``, ``int16`` and ``fixed`` (2..16-bit mantissas)."""

from cml_edge.backends.fixed.array import FixedArray, FixedState

__all__ = ["FixedArray", "FixedState"]
