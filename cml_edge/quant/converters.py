"""DAC and ADC of an analog array: symmetric uniform quantisers with a bound and bits.

Conventions (the same as IBM aihwkit's ``IOParameters``, whose ``inp_res = 1/(2^7 - 2)``
and ``out_res = 1/(2^9 - 2)`` are resolutions of the full range [-bound, bound]):

- a ``bits``-bit converter has 2^(bits-1) - 1 levels on each side of zero, so its step is
  ``bound / (2^(bits-1) - 1)`` (7-bit DAC on [-1, 1]: 1/63; 9-bit ADC on [-12, 12]:
  12/255 = 0.047);
- values beyond the bound saturate at it (the ADC counts them);
- ``bits = 0`` means an ideal converter (no quantisation, no bound);
- rounding is to the nearest level, ties away from zero (deterministic: aihwkit's
  default ``inp_sto_round = out_sto_round = False``).

The DAC sees inputs already divided by max|x| (aihwkit's ABS_MAX noise management), so
its bound is 1; the ADC sees outputs in normalised units (weights in units of the
array's w_max, inputs in units of max|x|).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True)
def converter_step(bound, bits):
    """The step of a ``bits``-bit symmetric converter on [-bound, bound] (0: ideal)."""
    if bits <= 0:
        return 0.0
    return bound / (2.0 ** (bits - 1) - 1.0)


@njit(cache=True)
def quantize_symmetric(v, bound, step):
    """v clipped to [-bound, bound] and rounded to a multiple of ``step`` (step 0: v)."""
    if step <= 0.0:
        return v
    if v > bound:
        v = bound
    elif v < -bound:
        v = -bound
    q = math.floor(abs(v) / step + 0.5) * step
    return q if v >= 0.0 else -q


def quantize_array(x: np.ndarray, bound: float, bits: int) -> np.ndarray:
    """NumPy twin of :func:`quantize_symmetric` for a whole array (analysis, tests)."""
    step = converter_step(float(bound), int(bits))
    x = np.asarray(x, dtype=np.float64)
    if step == 0.0:
        return x.copy()
    v = np.clip(x, -bound, bound)
    return np.sign(v) * np.floor(np.abs(v) / step + 0.5) * step
