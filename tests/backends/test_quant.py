"""Number formats, rounding and saturation of the fixed-point array (cml_edge.backends.quant).

Golden values are worked out by hand in the comments; the statistical test of
stochastic rounding allows 4.5 standard errors (a false alarm about once in 150,000).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numba import njit

from cml_edge.backends.fixed.kernels import lr_mantissa
from cml_edge.backends.quant import (
    FLOOR,
    NEAREST,
    SIGMOID_LUT,
    SIGMOID_LUT_MAX_ERROR,
    STOCHASTIC,
    binary_exponent,
    check_bits,
    choose_exponent,
    exponent_for,
    max_abs,
    pow2,
    qmax_of,
    quantize_matrix,
    quantize_vector,
    rounding_code,
    saturate,
    shift_round,
    sigmoid_lut,
    storage_dtype,
)
from cml_edge.jit.rng import stream_key
from cml_edge.protocol import STREAM_DEVICE

KEY = stream_key(7, STREAM_DEVICE)
FAST = settings(max_examples=60, deadline=None)


# formats ---------------------------------------------------------------------------
def test_format_golden():
    assert [qmax_of(b) for b in (2, 4, 8, 16)] == [1, 7, 127, 32767]
    assert storage_dtype(2) is np.int8 and storage_dtype(8) is np.int8
    assert storage_dtype(9) is np.int16 and storage_dtype(16) is np.int16
    assert storage_dtype(17) is np.int32


def test_exponent_golden():
    # 127 x 2^-7 = 0.992 holds 0.5 and 127/128; 127 x 2^-8 = 0.496 does not hold 0.5
    assert exponent_for(0.5, 127) == -7
    assert exponent_for(127 / 128, 127) == -7
    assert exponent_for(127.5 / 128, 127) == -6  # just above the top of 2^-7's range
    assert exponent_for(2.0 ** -20, 127) == -26  # 2^-20 = 64 x 2^-26
    assert exponent_for(1.0, 1) == 0  # ternary: 1 x 2^0
    assert exponent_for(1.5, 1) == 1  # 1.5 x 2^-1 = 0.75 <= 1 < 1.5
    assert choose_exponent(0.5, 8) == -7
    assert choose_exponent(0.5, 8, headroom=2) == -5
    assert choose_exponent(0.0, 8) == -7  # a zero matrix: qmax 2^e ~ 1


@given(st.floats(1e-30, 1e30), st.integers(2, 16))
@FAST
def test_exponent_is_the_finest_that_holds(x, bits):
    q = qmax_of(bits)
    e = exponent_for(x, q)
    assert x * 2.0 ** -e <= q
    assert x * 2.0 ** -(e - 1) > q


def test_quantize_matrix_golden():
    lsb = 2.0 ** -8
    W = np.array([[127 * lsb, -127 * lsb, 128 * lsb, -200 * lsb,
                   0.5 * lsb, 1.5 * lsb, 2.5 * lsb, -0.5 * lsb]])
    m, clipped = quantize_matrix(W, 8, -8)
    assert m.dtype == np.int8
    # clip edges: 128 and -200 saturate to +-127; ties go to even: .5 -> 0, 1.5 -> 2, 2.5 -> 2
    assert m.tolist() == [[127, -127, 127, -127, 0, 2, 2, 0]]
    assert clipped == 2


def test_quantize_vector_golden():
    out = np.zeros(3, np.int64)
    assert quantize_vector(np.array([1.0, 0.0, -0.25]), 3, 127, out) == -6  # 1 = 64 x 2^-6
    assert out.tolist() == [64, 0, -16]
    assert quantize_vector(np.zeros(3), 3, 127, out) == 0 and out.tolist() == [0, 0, 0]
    with pytest.raises(ValueError, match="non-finite"):
        quantize_vector(np.array([1.0, np.nan]), 2, 127, out)


@given(st.lists(st.floats(-1e6, 1e6, allow_subnormal=False), min_size=1, max_size=40),
       st.integers(2, 16))
@FAST
def test_quantize_vector_within_half_lsb(xs, bits):
    x = np.array(xs)
    out = np.zeros(len(x), np.int64)
    e = quantize_vector(x, len(x), qmax_of(bits), out)
    assert np.abs(out).max() <= qmax_of(bits)
    assert np.all(np.abs(np.ldexp(out.astype(float), e) - x) <= np.ldexp(0.5, e))


@njit
def _max_abs(x, n):
    return max_abs(x, n)


@given(st.lists(st.floats(allow_nan=True, allow_infinity=True), max_size=40))
@FAST
def test_max_abs_is_the_float_max(xs):
    """The integer max over bit patterns is max |x| over the non-NaN entries,
    bit for bit, and flags any non-finite entry; subnormals, -0.0, inf and NaN included."""
    x = np.array(xs, dtype=np.float64)
    top, finite = _max_abs(x, len(x))
    a = np.abs(x[~np.isnan(x)])
    expected = a.max() if a.size else 0.0
    assert finite == bool(np.isfinite(x).all())
    assert top == expected and not math.copysign(1.0, top) < 0  # +0.0, never -0.0
    if len(x) > 1:  # only a prefix is read
        assert _max_abs(x, 1)[0] == (0.0 if np.isnan(x[0]) else abs(x[0]))


@njit
def _pow2_and_exponent(ns, xs, p, ex):
    for i in range(ns.shape[0]):
        p[i] = pow2(ns[i])
    for i in range(xs.shape[0]):
        ex[i] = binary_exponent(xs[i])


def test_pow2_and_binary_exponent_match_libm():
    """The bit-pattern shortcuts equal ldexp(1, n) for every n from below the
    subnormals to past overflow, and frexp's exponent for normal, subnormal and negative x."""
    ns = np.arange(-1100, 1101)
    rng = np.random.default_rng(5)
    xs = np.concatenate([rng.normal(0, 1, 300) * 10.0 ** rng.uniform(-300, 300, 300),
                         [5e-324, -5e-324, 2.2e-308, 2.2250738585072014e-308,
                          1.7976931348623157e308, -1.0, 0.5, 1.0, 3.0]])
    xs = xs[xs != 0]
    p = np.zeros(len(ns))
    ex = np.zeros(len(xs), np.int64)
    _pow2_and_exponent(ns, xs, p, ex)
    with np.errstate(over="ignore"):
        assert np.array_equal(p, np.ldexp(1.0, ns))  # inf past the largest double
    assert ex.tolist() == [math.frexp(float(x))[1] for x in xs]


def test_bad_format_values():
    for bad in (1, 17, 0, -3, 8.0, True, "8"):
        with pytest.raises(ValueError, match="allowed: integers 2..16"):
            check_bits(bad)
    with pytest.raises(ValueError, match="unknown rounding 'up'.*floor, nearest, stochastic"):
        rounding_code("up")


# rounding ------------------------------------------------------------------------------
@pytest.mark.parametrize(("v", "k", "mode", "expected"), [
    (5, 1, FLOOR, 2), (5, 1, NEAREST, 2),  # 2.5 -> 2 (tie to even)
    (7, 1, FLOOR, 3), (7, 1, NEAREST, 4),  # 3.5 -> 4 (tie to even)
    (-5, 1, FLOOR, -3), (-5, 1, NEAREST, -2),  # -2.5 -> -3 (floor), -2 (even)
    (6, 2, NEAREST, 2), (-6, 2, NEAREST, -2),  # +-1.5 -> +-2
    (5, 2, NEAREST, 1), (-5, 2, NEAREST, -1),  # +-1.25 -> +-1
    (3, 2, NEAREST, 1), (-3, 2, FLOOR, -1),  # 0.75 -> 1; -0.75 -> -1
    (1, 2, NEAREST, 0), (1, 2, FLOOR, 0),  # 0.25 -> 0
    (3, 0, STOCHASTIC, 3), (3, -2, FLOOR, 12),  # no fraction: exact, even stochastic
    (2 ** 40, 40, STOCHASTIC, 1), (-(2 ** 40), 40, NEAREST, -1),  # +-2^k / 2^k exactly
    (2 ** 40 - 1, 40, FLOOR, 0), (-(2 ** 40) + 1, 40, FLOOR, -1),
])
def test_shift_round_golden(v, k, mode, expected):
    got, drew = shift_round(np.int64(v), k, mode, KEY, 0)
    assert got == expected
    assert drew == 0 or mode == STOCHASTIC


@given(st.integers(-(2 ** 40), 2 ** 40), st.integers(1, 40))
@FAST
def test_floor_and_nearest_bounds(v, k):
    x = v / 2.0 ** k
    f, _ = shift_round(np.int64(v), k, FLOOR, KEY, 0)
    n, _ = shift_round(np.int64(v), k, NEAREST, KEY, 0)
    assert f <= x < f + 1
    assert abs(n - x) <= 0.5
    s, drew = shift_round(np.int64(v), k, STOCHASTIC, KEY, 3)
    assert s in (math.floor(x), math.ceil(x))
    assert drew == (0 if x == math.floor(x) else 1)


@given(st.integers(-(2 ** 20), 2 ** 20), st.integers(1, 24), st.integers(0, 2 ** 40))
@settings(max_examples=25, deadline=None)
def test_stochastic_rounding_is_unbiased(v, k, start):
    """E[SR(x)] = x: the mean of 20,000 independent roundings, within 4.5 standard errors."""
    n = 20_000
    draws = np.array([shift_round(np.int64(v), k, STOCHASTIC, KEY, start + i)[0]
                      for i in range(n)], dtype=np.float64)
    x = v / 2.0 ** k
    p = x - math.floor(x)
    se = math.sqrt(p * (1 - p) / n)
    assert abs(draws.mean() - x) <= 4.5 * se + 1e-12
    assert set(np.unique(draws)) <= {math.floor(x), math.ceil(x)}


def test_stochastic_rounding_is_reproducible_and_keyed():
    a = [shift_round(np.int64(3), 2, STOCHASTIC, KEY, i)[0] for i in range(200)]
    b = [shift_round(np.int64(3), 2, STOCHASTIC, KEY, i)[0] for i in range(200)]
    c = [shift_round(np.int64(3), 2, STOCHASTIC, stream_key(8, STREAM_DEVICE), i)[0]
         for i in range(200)]
    assert a == b and a != c


# saturation ------------------------------------------------------------------------------
def test_saturate_golden():
    assert saturate(127, 127) == (127, 0)
    assert saturate(128, 127) == (127, 1)
    assert saturate(-128, 127) == (-127, 1)  # clip, never wrap to +127 or stay at -128
    assert saturate(-127, 127) == (-127, 0)
    assert saturate(2 ** 40, 1) == (1, 1)


# learning rate -------------------------------------------------------------------------
def test_lr_mantissa_golden():
    assert lr_mantissa(0.001, 4) == (8, -13)  # 0.512 x 2^-9: 8.19 -> 8, 8 x 2^-13
    assert lr_mantissa(0.001, 8) == (131, -17)  # 131.07 -> 131
    assert lr_mantissa(1.0, 4) == (8, -3)
    assert lr_mantissa(-0.75, 4) == (-12, -4)
    assert lr_mantissa(0.0, 4) == (0, 0)
    assert lr_mantissa(0.96875, 4) == (8, -3)  # 15.5 -> 16 (even): renormalised to 8 x 2^-3
    with pytest.raises(ValueError, match="non-finite"):
        lr_mantissa(math.nan, 4)


# sigmoid lookup table ------------------------------------------------------------------
def test_sigmoid_lut_golden():
    assert len(SIGMOID_LUT) == 256
    assert sigmoid_lut(0.0) == 0.5  # 32768 / 65536
    assert sigmoid_lut(1 / 32) == sigmoid_lut(1 / 16)  # ties round up: index 1
    assert sigmoid_lut(-1 / 64) == 0.5  # rounds to index 0
    top = round(65536 / (1 + math.exp(-7.9375))) / 65536
    assert sigmoid_lut(1e300) == sigmoid_lut(7.9375) == top
    assert sigmoid_lut(-1e300) == sigmoid_lut(-8.0) == round(65536 / (1 + math.exp(8))) / 65536
    assert sigmoid_lut(math.inf) == sigmoid_lut(8.0)
    with pytest.raises(ValueError, match="non-finite"):
        sigmoid_lut(math.nan)


@given(st.floats(-50, 50))
@FAST
def test_sigmoid_lut_error_bound(z):
    assert abs(sigmoid_lut(z) - 1 / (1 + math.exp(-z))) <= SIGMOID_LUT_MAX_ERROR
    assert SIGMOID_LUT_MAX_ERROR < 0.0083
