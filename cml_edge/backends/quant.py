"""Fixed-point number formats, rounding modes and saturation (Loihi-style).

A format is a signed mantissa of ``bits`` bits (2..16) and one power-of-two exponent
``e`` per matrix: value = m * 2^e, with m in [-qmax, qmax], qmax = 2^(bits-1) - 1
(symmetric, so that negating a weight is always exact; 8 bits hold -127..127, 2 bits
are ternary -1, 0, 1). Mantissas live in the narrowest NumPy integer type that holds
them (int8 up to 8 bits, int16 up to 16).

Exponent rule (:func:`choose_exponent`): the finest exponent whose range still holds
the largest magnitude, e = min{e : max|W| <= qmax 2^e} (Lava's ``optimize_weight_bits``
for mixed-sign weights), plus ``headroom`` bits for growth; a user may fix e instead.

Rounding modes, used wherever the learning path narrows a value to fewer bits
(:func:`shift_round`):

- ``floor``: toward minus infinity (an arithmetic right shift, what Lava's shift does);
- ``nearest``: to the nearest integer, ties to even (unbiased on ties, which are
  frequent here: a one-hot factor is a power of two);
- ``stochastic``: floor + Bernoulli(fraction), one independent draw per element from
  the counter-based generator (:mod:`cml_edge.jit.rng`), so E[SR(x)] = x exactly
  (up to the generator's 2^-53 resolution). Lava shares one draw per learning epoch
  across all synapses; we do not.

Saturation (:func:`saturate`): a value beyond the format is clipped to +-qmax and
counted; it never wraps. Arrays in strict mode raise :class:`SaturationError` instead.

Activations (inputs of a read, factors of an update) are quantised per vector with
their own exponent by :func:`quantize_vector` (round to nearest, ties to even).

The affordance sigmoid as a chip computes it: :data:`SIGMOID_LUT`, 256 entries indexed
by z rounded to steps of 1/16 and clipped to [-8, 8 - 1/16], each a 16-bit unsigned
fraction g * 2^16. Its error against the exact sigmoid is at most
1/128 (input step: slope <= 1/4 times half a step) + 2^-17 (output rounding)
+ sigmoid(-8 + 1/16) (clipping), :data:`SIGMOID_LUT_MAX_ERROR`.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, types
from numba.extending import intrinsic

from cml_edge.errors import InputError
from cml_edge.jit.kernel import kernel
from cml_edge.jit.rng import uniform

ROUNDINGS = ("floor", "nearest", "stochastic")
FLOOR, NEAREST, STOCHASTIC = 0, 1, 2
MIN_BITS, MAX_BITS = 2, 16
MAX_EXPONENT = 60  # |e| above this is no sensible scale for a float64 weight


class SaturationError(InputError):
    """A value left its fixed-point format in an array's strict mode."""


# formats (Python level) -------------------------------------------------------------
def check_int(value: object, name: str, lo: int, hi: int) -> int:
    """``value`` as an int in [lo, hi], or a ValueError naming it and the allowed range."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not lo <= value <= hi:
        raise InputError(f"{name} {value!r} is not allowed (allowed: integers {lo}..{hi})")
    return int(value)


def check_bits(bits: object, name: str = "bits") -> int:
    """A mantissa width: an integer in 2..16."""
    return check_int(bits, name, MIN_BITS, MAX_BITS)


def rounding_code(name: object) -> int:
    """The integer code of a rounding mode; ValueError naming the allowed modes."""
    if name not in ROUNDINGS:
        raise InputError(f"unknown rounding {name!r} (allowed: {', '.join(ROUNDINGS)})")
    return ROUNDINGS.index(name)  # type: ignore[arg-type]


def qmax_of(bits: int) -> int:
    """The largest mantissa of a ``bits``-bit symmetric format: 2^(bits-1) - 1."""
    return (1 << (bits - 1)) - 1


def storage_dtype(bits: int) -> type[np.integer]:
    """The narrowest NumPy signed integer type that holds a ``bits``-bit value."""
    if bits <= 8:
        return np.int8
    if bits <= 16:
        return np.int16
    if bits <= 32:
        return np.int32
    return np.int64


def choose_exponent(max_abs: float, bits: int, headroom: int = 0) -> int:
    """min{e : max_abs <= qmax 2^e} + headroom; a zero matrix gets a unit range.

    qmax 2^e is the format's largest value, so the largest weight is represented to
    within half an LSB and lands in the top half of the range (headroom 0).
    """
    if not max_abs > 0:
        return 1 - bits + headroom  # qmax 2^e ~ 1
    return exponent_for(float(max_abs), qmax_of(bits)) + headroom


def quantize_matrix(W: np.ndarray, bits: int, exp: int) -> tuple[np.ndarray, int]:
    """Mantissas of W at exponent ``exp`` (nearest, ties to even) clipped to the format,
    and how many were clipped."""
    q = qmax_of(bits)
    m = np.rint(np.ldexp(np.asarray(W, dtype=np.float64), -exp))
    clipped = int(np.count_nonzero(np.abs(m) > q))
    return np.clip(m, -q, q).astype(storage_dtype(bits)), clipped


def dequantize(m: np.ndarray, exp: int) -> np.ndarray:
    """m * 2^exp as float64 (exact)."""
    return np.ldexp(m.astype(np.float64), exp)


# compiled primitives -------------------------------------------------------------------
def _bitcast(src: types.Type, dst: types.Type):
    """A compiled function that reinterprets the bits of a ``src`` value as a ``dst`` (a
    register move, no conversion)."""
    def cast(typingctx, x):
        if x != src:
            return None

        def codegen(context, builder, signature, args):
            return builder.bitcast(args[0], context.get_value_type(dst))
        return dst(src), codegen
    return intrinsic(cast)


_bits = _bitcast(types.float64, types.uint64)  # a float64's IEEE 754 bit pattern
_from_bits = _bitcast(types.uint64, types.float64)  # the float64 of a bit pattern


_MAGNITUDE = np.uint64(0x7FFF_FFFF_FFFF_FFFF)  # every bit but the sign
_INF_BITS = np.uint64(0x7FF0_0000_0000_0000)  # +inf; NaNs lie above it


@njit(cache=True, inline="always")
def pow2(n):
    """2.0^n, exactly: for -1022 <= n <= 1023 (a normal double) the bit pattern with
    exponent field n + 1023, else ``math.ldexp``. The libm calls of every read,
    quantisation and update (``scalbn``, ``ldexp``, ``frexp``) were ~5 % of an int8
    training."""
    if -1022 <= n <= 1023:
        return _from_bits(np.uint64(n + 1023) << np.uint64(52))
    return math.ldexp(1.0, n)


@njit(cache=True, inline="always")
def binary_exponent(x):
    """The exponent of ``math.frexp(x)`` (x = f 2^ex, 0.5 <= |f| < 1) for a finite x != 0:
    read from the exponent field of a normal double, from ``frexp`` for a subnormal."""
    field = np.int64((_bits(x) >> np.uint64(52)) & np.uint64(0x7FF))
    return field - 1022 if field != 0 else math.frexp(x)[1]


@kernel
def exponent_for(max_abs, qmax):
    """The finest exponent e with max_abs 2^-e <= qmax (max_abs > 0, finite)."""
    ex = binary_exponent(max_abs)  # max_abs = f 2^ex, f in [0.5, 1)
    bits = 0
    while (1 << bits) <= qmax:
        bits += 1  # qmax = 2^bits - 1, so 2^(bits-1) <= qmax < 2^bits
    e = ex - bits  # max_abs 2^-e = f 2^bits in [2^(bits-1), 2^bits)
    # a normal max_abs times 2^-e lands in [2^(bits-1), 2^bits): exact; a subnormal one
    # has -e > 1023 and takes ldexp
    if (max_abs * pow2(-e) if -e <= 1023 else math.ldexp(max_abs, -e)) > qmax:
        e += 1
    return e


@kernel
def round_half_even(v):
    """v rounded to the nearest integer, ties to even (as np.rint)."""
    return np.rint(v)


@njit(cache=True, inline="always")
def max_abs(x, n):
    """(max |x[:n]|, whether all of them are finite); 0 for n = 0.

    For non-negative float64 values, ordering the bit patterns as unsigned integers
    orders the values, so the largest pattern of |x| (the sign bit cleared) is the
    pattern of max |x|: an integer max, exact in any order, that vectorises (a
    float max with NaN-safe selects does not; 68 -> 21 ns for 256 entries, measured with a
    throwaway loop). Patterns at or above that of inf are non-finite: then a float loop
    gives the max with any NaN passed over (``a > top`` is false for it).
    """
    top = np.uint64(0)
    for i in range(n):
        b = _bits(x[i]) & _MAGNITUDE
        top = b if b > top else top
    if top < _INF_BITS:
        return _from_bits(top), True
    t = 0.0
    for i in range(n):
        a = abs(x[i])
        t = a if a > t else t
    return t, False


@njit(cache=True, inline="always")
def count_nonzero(v, n):
    """How many of v[:n] are nonzero (the cells an outer update touches are the nonzero
    row factors times the nonzero column factors, counted once instead of per cell)."""
    count = 0
    for i in range(n):
        count += v[i] != 0
    return count


@kernel
def quantize_vector(x, n, qmax, out):
    """Quantise x[:n] to mantissas out[:n] (int64) with one shared exponent, returned.

    The exponent is the finest that holds max|x| (:func:`exponent_for`); rounding to
    nearest, ties to even. An all-zero vector gets exponent 0 and zero mantissas.
    Raises ValueError on a non-finite entry.
    """
    top, finite = max_abs(x, n)
    if not finite:
        raise InputError("non-finite input to a fixed-point array")
    if top == 0.0:
        for i in range(n):
            out[i] = 0
        return 0
    e = exponent_for(top, qmax)
    if -e > 1000:  # 2^-e would overflow: scale element by element
        for i in range(n):
            out[i] = np.int64(round_half_even(math.ldexp(x[i], -e)))
        return e
    scale = pow2(-e)  # multiplying by a power of two is exact here
    for i in range(n):
        out[i] = np.int64(round_half_even(x[i] * scale))
    return e


@kernel
def shift_round(v, k, mode, key, counter):
    """v * 2^-k rounded to an integer by ``mode``; returns (value, draws used).

    v is an int64, k an integer shift (k <= 0 is an exact left shift). Stochastic
    rounding draws ``uniform(key, counter)`` only when there is a fraction to round.
    """
    if k <= 0:
        return v << (-k), 0
    if k > 62:  # |v| < 2^62: the quotient is 0 or -1 with fraction v / 2^k
        q = np.int64(0) if v >= 0 else np.int64(-1)
        if mode == FLOOR or v == 0:
            return q, 0
        if mode == NEAREST:
            return np.int64(0), 0  # |v| 2^-k < 1/2
        frac = math.ldexp(float(v), -k) - float(q)
        if uniform(key, counter) < frac:
            q += 1
        return q, 1
    q = v >> k  # floor
    r = v - (q << k)  # fraction in units of 2^-k, 0 <= r < 2^k
    if r == 0 or mode == FLOOR:
        return q, 0
    if mode == NEAREST:
        half = np.int64(1) << (k - 1)
        if r > half or (r == half and (q & 1) != 0):
            q += 1
        return q, 0
    # stochastic: up with probability r / 2^k (exact for k <= 53)
    if uniform(key, counter) * math.ldexp(1.0, k) < float(r):
        q += 1
    return q, 1


@kernel
def saturate(v, limit):
    """(v clipped to [-limit, limit], 1 if it was clipped else 0)."""
    if v > limit:
        return limit, 1
    if v < -limit:
        return -limit, 1
    return v, 0


# the affordance sigmoid as a lookup table ------------------------------------------------
SIGMOID_IN_FRAC_BITS = 4  # z in steps of 1/16
SIGMOID_INDEX_BITS = 8  # 256 entries: z in [-8, 8 - 1/16]
SIGMOID_OUT_BITS = 16  # g as an unsigned 16-bit fraction


def _sigmoid_table() -> np.ndarray:
    half = 1 << (SIGMOID_INDEX_BITS - 1)
    z = np.arange(-half, half) / float(1 << SIGMOID_IN_FRAC_BITS)
    g = np.rint((1 << SIGMOID_OUT_BITS) / (1.0 + np.exp(-z)))
    return np.clip(g, 0, (1 << SIGMOID_OUT_BITS) - 1).astype(np.int64)


SIGMOID_LUT = _sigmoid_table()
SIGMOID_LUT_MAX_ERROR = (0.25 * 0.5 / (1 << SIGMOID_IN_FRAC_BITS)
                         + 0.5 / (1 << SIGMOID_OUT_BITS)
                         + 1.0 / (1.0 + math.exp(8.0 - 1.0 / (1 << SIGMOID_IN_FRAC_BITS))))


def sigmoid_entry(z: float) -> int:
    """The :data:`SIGMOID_LUT` entry for z: z in steps of 1/16 (nearest, ties up), clipped
    to [-8, 8 - 1/16]; InputError if z is NaN. Plain Python, the devices' references'
    lookup (:func:`sigmoid_lut` is the compiled one)."""
    if z != z:
        raise InputError("non-finite input to the sigmoid lookup table")
    half = 1 << (SIGMOID_INDEX_BITS - 1)
    t = min(max(math.floor(z * (1 << SIGMOID_IN_FRAC_BITS) + 0.5), -half), half - 1)
    return int(SIGMOID_LUT[t + half])


@kernel
def sigmoid_lut(z):
    """sigmoid(z) from :data:`SIGMOID_LUT` (module docstring); ValueError if z is NaN."""
    if z != z:
        raise InputError("non-finite input to the sigmoid lookup table")
    half = 1 << (SIGMOID_INDEX_BITS - 1)
    t = math.floor(z * (1 << SIGMOID_IN_FRAC_BITS) + 0.5)
    if t < -half:
        t = -half
    elif t > half - 1:
        t = half - 1
    return math.ldexp(float(SIGMOID_LUT[int(t) + half]), -SIGMOID_OUT_BITS)


NARROW = 16
"""Integer matrices with at most this many columns are read column by column (W_q's two
inputs, or a one-hot pre), wider ones row by row."""


@njit(cache=True, inline="always")
def int_matvec(w, s, sums):
    """sums = w s in int64 (the exact integer MAC of a fixed-point or Loihi 2 read, in the
    order both devices sum); returns the number of nonzero inputs."""
    rows, cols = w.shape
    nnz = 0
    if cols <= NARROW:
        for i in range(rows):
            sums[i] = 0
        for j in range(cols):
            v = s[j]
            if v == 0:
                continue
            nnz += 1
            for i in range(rows):
                sums[i] += w[i, j] * v
    else:
        for j in range(cols):
            if s[j] != 0:
                nnz += 1
        for i in range(rows):
            total = np.int64(0)
            for j in range(cols):
                total += w[i, j] * s[j]
            sums[i] = total
    return nnz


@njit(cache=True, inline="always")
def int_rmatvec(w, s, sums):
    """sums = w^T s in int64: :func:`int_matvec` on the transpose (integer sums are exact,
    so its loop order, chosen by shape, gives the same sums); returns the nonzero inputs."""
    return int_matvec(w.T, s, sums)
