"""Kernels of the float reference array (float64 or float32 storage and arithmetic).

Products and sums are formed in the storage dtype, so the float32 array shows what a
float32 chip would compute. Every sum has a fixed order (no fastmath), so a kernel
gives the same bits whether called from Python or inlined into a compiled loop.

Layout by shape, so that most inner loops are element-wise along contiguous memory
(which Numba's loop vectoriser handles; it will not reorder a float reduction):

- tall matrices (rows >= cols: W_q, W_v) are stored column-major; W x is a sum of
  columns x_j W[:, j], skipping exactly-zero inputs (a one-hot action reads one
  column), and W^T y is one reduction per column;
- wide matrices (rows < cols: W_k) are stored row-major; W x is one reduction per row
  (eight interleaved partial sums, in a fixed order), and W^T y a sum of rows.

The update W += lr * post pre^T runs along the contiguous axis and skips columns
(tall) or rows (wide) whose factor is exactly zero, which keep their bits; elsewhere
a zero factor adds an exact zero, so the cell keeps its value. ``macs`` counts the
multiply-adds actually performed.

The state's ``buf`` is work space: a read's sums, an update's row (tall) or column (wide)
factors. The same arithmetic as plain loops, which the tests hold these kernels to:
:mod:`cml_edge.backends.floating.reference`.
"""

from __future__ import annotations

import math

from numba import njit

# counter indices (names in cml_edge.backends.floating.array.FloatArray.counter_names)
MATVECS, RMATVECS, MACS, WEIGHT_READS, OUTER_UPDATES, ACC_WRITES = 0, 1, 2, 3, 4, 5
WEIGHT_WRITES, CELLS_CHANGED, COMMITS, BYTES_READ, BYTES_WRITTEN = 6, 7, 8, 9, 10
N_COUNTERS = 11


@njit(cache=True, inline="always")
def _axpy_columns(W, x, buf):
    """buf[:rows] = sum_j x_j W[:, j] (zero x_j skipped); returns the columns used."""
    rows, cols = W.shape
    zero = W.dtype.type(0)
    for i in range(rows):
        buf[i] = zero
    used = 0
    for j in range(cols):
        xj = W.dtype.type(x[j])
        if xj == zero:
            continue
        used += 1
        for i in range(rows):
            buf[i] += W[i, j] * xj
    return used


@njit(cache=True, inline="always")
def _row_dots(W, x, out):
    """out[i] = W[i, :] . x, eight interleaved partial sums per row."""
    rows, cols = W.shape
    zero = W.dtype.type(0)
    for i in range(rows):
        s0 = s1 = s2 = s3 = s4 = s5 = s6 = s7 = zero
        j = 0
        while j + 8 <= cols:
            s0 += W[i, j] * W.dtype.type(x[j])
            s1 += W[i, j + 1] * W.dtype.type(x[j + 1])
            s2 += W[i, j + 2] * W.dtype.type(x[j + 2])
            s3 += W[i, j + 3] * W.dtype.type(x[j + 3])
            s4 += W[i, j + 4] * W.dtype.type(x[j + 4])
            s5 += W[i, j + 5] * W.dtype.type(x[j + 5])
            s6 += W[i, j + 6] * W.dtype.type(x[j + 6])
            s7 += W[i, j + 7] * W.dtype.type(x[j + 7])
            j += 8
        while j < cols:
            s0 += W[i, j] * W.dtype.type(x[j])
            j += 1
        out[i] = ((s0 + s1) + (s2 + s3)) + ((s4 + s5) + (s6 + s7))


@njit(cache=True, inline="always")
def _column_dots(W, y, out):
    """out[j] = W[:, j] . y, one sequential reduction per column."""
    rows, cols = W.shape
    for j in range(cols):
        s = W.dtype.type(0)
        for i in range(rows):
            s += W[i, j] * W.dtype.type(y[i])
        out[j] = s


@njit(cache=True, inline="always")
def _count_read(c, kind, macs, itemsize):
    c[kind] += 1
    c[MACS] += macs
    c[WEIGHT_READS] += macs
    c[BYTES_READ] += macs * itemsize


@njit(cache=True, inline="always")
def float_matvec(state, x, out):
    W = state.W
    rows, cols = W.shape
    if rows >= cols:
        macs = _axpy_columns(W, x, state.buf) * rows
        for i in range(rows):
            out[i] = state.buf[i]
    else:
        _row_dots(W, x, out)
        macs = rows * cols
    _count_read(state.counters, MATVECS, macs, W.itemsize)


@njit(cache=True, inline="always")
def float_rmatvec(state, y, out):
    W = state.W
    rows, cols = W.shape
    if rows >= cols:
        _column_dots(W, y, out)
        macs = rows * cols
    else:
        macs = _axpy_columns(W.T, y, state.buf) * cols  # sum of rows of W
        for j in range(cols):
            out[j] = state.buf[j]
    _count_read(state.counters, RMATVECS, macs, W.itemsize)


@njit(cache=True, inline="always")
def float_outer_update(state, post, pre, lr, defer):
    W = state.W
    target = state.acc if defer else state.W
    rows, cols = W.shape
    rate = W.dtype.type(lr)
    zero = W.dtype.type(0)
    buf = state.buf
    changed = 0
    live_rows = 0
    live_cols = 0
    if rows >= cols:  # column-major: each live column is one contiguous axpy
        for i in range(rows):
            buf[i] = rate * W.dtype.type(post[i])
            live_rows += buf[i] != zero
        for j in range(cols):
            q = W.dtype.type(pre[j])
            if q == zero:
                continue
            live_cols += 1
            for i in range(rows):
                old = target[i, j]
                new = old + buf[i] * q
                target[i, j] = new
                changed += new != old
    else:  # row-major: each live row is one contiguous axpy
        for j in range(cols):
            buf[j] = W.dtype.type(pre[j])
            live_cols += buf[j] != zero
        for i in range(rows):
            p = rate * W.dtype.type(post[i])
            if p == zero:
                continue
            live_rows += 1
            for j in range(cols):
                old = target[i, j]
                new = old + p * buf[j]
                target[i, j] = new
                changed += new != old
    touched = live_rows * live_cols
    c = state.counters
    c[OUTER_UPDATES] += 1
    c[BYTES_READ] += touched * W.itemsize
    c[BYTES_WRITTEN] += touched * W.itemsize
    if defer:
        c[ACC_WRITES] += touched
    else:
        c[WEIGHT_READS] += touched
        c[WEIGHT_WRITES] += touched
        c[CELLS_CHANGED] += changed


@njit(cache=True, inline="always")
def float_commit(state):
    W = state.W
    acc = state.acc
    rows, cols = W.shape
    zero = W.dtype.type(0)
    written = 0
    changed = 0
    for i in range(rows):
        for j in range(cols):
            a = acc[i, j]
            if a != zero:
                old = W[i, j]
                W[i, j] = old + a
                acc[i, j] = zero
                written += 1
                changed += W[i, j] != old
    c = state.counters
    c[COMMITS] += 1
    c[WEIGHT_READS] += written
    c[WEIGHT_WRITES] += written
    c[CELLS_CHANGED] += changed
    c[BYTES_READ] += (rows * cols + written) * W.itemsize
    c[BYTES_WRITTEN] += written * W.itemsize


@njit(cache=True, inline="always")
def float_sigmoid(state, z, out):
    for i in range(z.shape[0]):
        out[i] = 1.0 / (1.0 + math.exp(-z[i]))
