"""What a seed promises across machines: every bit on one, and across machines integers
exactly and floats within :data:`REL` and :data:`ABS`.

On one machine (its CPU model, NumPy with its OpenBLAS, Numba) a seed fixes every bit of
every result, on every compute path and device (docs/architecture.md, "Randomness"). On
another CPU two things may change a float's last bits:

- OpenBLAS picks its matrix kernels by CPU (AVX2 or AVX-512, their unrolling), and with
  them the order of a product's sums. NumPy's products and norms call it, and so do
  Numba's matrix products: the float64 path's factored training and planning, which train
  every device's float64 twin, and the fidelity metrics' norms and exact reads.
- Numba compiles for the host CPU (its vector width; LLVM fuses no multiply-add without
  fast-math flags, which the package never sets, and every sum has a fixed order).

Measured: with ``OPENBLAS_CORETYPE=Sandybridge`` (AVX kernels instead of Haswell's) on an
AMD Zen 3, the float64 protocol's weight errors, at the float64 rounding floor (~1e-17),
moved by up to 2.5e-18, and a crossbar's read SNR in its 16th digit; every decision,
success and count stayed the same (tests/grid/test_protocol.py's goldens). So a result
computed on another machine matches when its integers, strings and nulls are equal and
each float is within ``REL`` of the other or within ``ABS`` of it (:func:`differences`).
A decision near a tie could in principle flip on another machine; none has.
"""

from __future__ import annotations

import math
from typing import Any

REL = 1e-9
"""Relative tolerance of a float across machines (a product's reordered sums move a
float64 by a few units in its 16th digit)."""
ABS = 1e-12
"""Absolute tolerance of a float across machines, for figures at the rounding floor
(a float64 twin's weight error of ~1e-17)."""


def close(a: float, b: float) -> bool:
    """Whether two floats match across machines."""
    if math.isnan(a) or math.isnan(b):
        return math.isnan(a) and math.isnan(b)
    return a == b or abs(a - b) <= REL * abs(b) + ABS


def differences(got: Any, want: Any, path: str = "") -> list[str]:
    """Where ``got`` and ``want`` (JSON-like trees) do not match across machines: the
    same keys in the same order, the same list lengths, integers, strings, booleans and
    nulls equal, floats :func:`close`. Empty: they match."""
    if isinstance(want, dict):
        if not isinstance(got, dict) or list(got) != list(want):
            return [f"{path or '.'}: keys {list(got) if isinstance(got, dict) else got!r} "
                    f"where {list(want)} are expected"]
        return [d for k in want for d in differences(got[k], want[k], f"{path}.{k}")]
    if isinstance(want, list):
        if not isinstance(got, list) or len(got) != len(want):
            return [f"{path}: {got!r} where a list of {len(want)} is expected"]
        return [d for i, (g, w) in enumerate(zip(got, want))
                for d in differences(g, w, f"{path}[{i}]")]
    if isinstance(want, float) and isinstance(got, float) and not isinstance(got, bool):
        return [] if close(got, want) else [f"{path}: {got!r} where {want!r} is expected"]
    if type(got) is not type(want) or got != want:
        return [f"{path}: {got!r} where {want!r} is expected"]
    return []
