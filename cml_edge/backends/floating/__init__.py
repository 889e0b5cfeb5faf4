"""The float reference device: weights and arithmetic in float64 (``float``) or float32."""

from cml_edge.backends.floating.array import FloatArray, FloatState

__all__ = ["FloatArray", "FloatState"]
