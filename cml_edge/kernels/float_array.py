"""Kernels of the float reference array (float64 or float32 storage and arithmetic).

Products and sums are formed in the storage dtype, so the float32 array shows what a
float32 chip would compute. Every sum has a fixed order (no fastmath), so a kernel
gives the same bits whether called from Python or inlined into a compiled loop:

- W x: for narrow matrices (cols <= 16) column by column into per-row accumulators,
  skipping exactly-zero inputs (an event-driven array does no work for a zero input);
  for wide ones row by row with eight interleaved partial sums;
- W^T y: row by row into per-column accumulators, skipping zero inputs;
- the update W += lr * post pre^T: for narrow matrices column by column, skipping
  columns whose pre factor is zero; for wide ones row by row, skipping rows whose post
  factor is zero. A skipped row or column keeps its bits; elsewhere a zero factor
  adds an exact zero, so the cell keeps its value.

``macs`` counts the multiply-adds actually performed.
"""

from __future__ import annotations

import math

from numba import njit

# counter indices (names in cml_edge.backends.float_array.FloatArray.counter_names)
MATVECS, RMATVECS, MACS, WEIGHT_READS, OUTER_UPDATES, ACC_WRITES = 0, 1, 2, 3, 4, 5
WEIGHT_WRITES, CELLS_CHANGED, COMMITS, BYTES_READ, BYTES_WRITTEN = 6, 7, 8, 9, 10
N_COUNTERS = 11
NARROW = 16


@njit(cache=True)
def float_matvec(state, x, out):
    W = state.W
    buf = state.buf
    rows, cols = W.shape
    zero = W.dtype.type(0)
    done = 0
    if cols <= NARROW:
        for i in range(rows):
            buf[i] = zero
        for j in range(cols):
            xj = W.dtype.type(x[j])
            if xj == zero:
                continue
            done += 1
            for i in range(rows):
                buf[i] += W[i, j] * xj
        for i in range(rows):
            out[i] = buf[i]
        done *= rows
    else:
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
        done = rows * cols
    c = state.counters
    c[MATVECS] += 1
    c[MACS] += done
    c[WEIGHT_READS] += done
    c[BYTES_READ] += done * W.itemsize


@njit(cache=True)
def float_rmatvec(state, y, out):
    W = state.W
    buf = state.buf
    rows, cols = W.shape
    zero = W.dtype.type(0)
    for j in range(cols):
        buf[j] = zero
    done = 0
    for i in range(rows):
        yi = W.dtype.type(y[i])
        if yi == zero:
            continue
        done += 1
        for j in range(cols):
            buf[j] += W[i, j] * yi
    for j in range(cols):
        out[j] = buf[j]
    done *= cols
    c = state.counters
    c[RMATVECS] += 1
    c[MACS] += done
    c[WEIGHT_READS] += done
    c[BYTES_READ] += done * W.itemsize


@njit(cache=True)
def float_outer_update(state, post, pre, lr, defer):
    W = state.W
    target = state.acc if defer else state.W
    rows, cols = W.shape
    rate = W.dtype.type(lr)
    zero = W.dtype.type(0)
    buf = state.buf
    live_rows = 0
    for i in range(rows):
        buf[i] = rate * W.dtype.type(post[i])
        if buf[i] != zero:
            live_rows += 1
    nnz_pre = 0
    changed = 0
    if cols <= NARROW:  # column by column: a one-hot pre touches one column only
        for j in range(cols):
            q = W.dtype.type(pre[j])
            if q == zero:
                continue
            nnz_pre += 1
            for i in range(rows):
                old = target[i, j]
                new = old + buf[i] * q
                target[i, j] = new
                changed += new != old
    else:
        for j in range(cols):
            if pre[j] != 0:
                nnz_pre += 1
        for i in range(rows):
            p = buf[i]
            if p == zero:
                continue
            for j in range(cols):
                old = target[i, j]
                new = old + p * W.dtype.type(pre[j])
                target[i, j] = new
                changed += new != old
    touched = live_rows * nnz_pre
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


@njit(cache=True)
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


@njit(cache=True)
def float_sigmoid(state, z, out):
    for i in range(z.shape[0]):
        out[i] = 1.0 / (1.0 + math.exp(-z[i]))
