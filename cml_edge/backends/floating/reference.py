"""The float array's arithmetic as plain loops: the readable model its kernels are held to.

Not dead code: the update rule and reads as a reader expects them (the paper's Eqs. 1-3:
W x, W^T y, W += lr post pre^T), one function per kernel of
:mod:`cml_edge.backends.floating.kernels`, without its layout-driven loops; the tests
(``tests/backends/test_references.py``) run each kernel and its function here on copies
of the same state and require the same bits, states and counters.

The bits are promised, so the order of every sum is the kernels' and is written out
here: every product and sum is formed in the weights' dtype (float64, or float32 as a
float32 chip would), and

- W x: a tall matrix (rows >= cols, stored column-major) sums each output over its
  nonzero inputs in index order; a wide one (stored row-major) in eight interleaved
  partial sums (:func:`eight_lanes`);
- W^T y: each output over the nonzero inputs in index order;
- the update adds (lr post_i) pre_j to every cell of a column whose pre_j is nonzero
  (tall) or of a row whose lr post_i is nonzero (wide): a cell outside them keeps its
  bits, a cell inside whose other factor is zero adds an exact zero.

Counters: ``macs`` are the products a read forms (the skipped zero inputs form none).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from cml_edge.backends.floating.kernels import (
    ACC_WRITES,
    BYTES_READ,
    BYTES_WRITTEN,
    CELLS_CHANGED,
    COMMITS,
    MACS,
    MATVECS,
    OUTER_UPDATES,
    RMATVECS,
    WEIGHT_READS,
    WEIGHT_WRITES,
)

SCRATCH = ("buf",)
"""The state's work space, which this model needs none of."""
State = Any  # a FloatState


def eight_lanes(w: np.ndarray, x: list[Any], zero: Any) -> Any:
    """sum_j w_j x_j as eight interleaved partial sums s_l = sum_c w_(8c+l) x_(8c+l) over
    the whole groups of eight, the inputs left over added to s_0, then
    ((s0 + s1) + (s2 + s3)) + ((s4 + s5) + (s6 + s7))."""
    s = [zero] * 8
    n = len(x)
    whole = n - n % 8
    for j in range(whole):
        s[j % 8] += w[j] * x[j]
    for j in range(whole, n):
        s[0] += w[j] * x[j]
    return ((s[0] + s[1]) + (s[2] + s[3])) + ((s[4] + s[5]) + (s[6] + s[7]))


def in_order(w: np.ndarray, x: list[Any], zero: Any) -> tuple[Any, int]:
    """(sum_j w_j x_j over the nonzero x_j in index order, how many there are)."""
    s = zero
    used = 0
    for j in range(len(x)):
        if x[j] != zero:
            s += w[j] * x[j]
            used += 1
    return s, used


def _count_read(state: State, kind: int, macs: int) -> None:
    c = state.counters
    c[kind] += 1
    c[MACS] += macs
    c[WEIGHT_READS] += macs
    c[BYTES_READ] += macs * state.W.itemsize


def matvec(state: State, x: np.ndarray) -> np.ndarray:
    """W x."""
    W = state.W
    rows, cols = W.shape
    dt = W.dtype.type
    xs = [dt(v) for v in x]
    out = np.zeros(rows)
    if rows >= cols:
        macs = 0
        for i in range(rows):
            out[i], used = in_order(W[i], xs, dt(0))
            macs += used
    else:
        for i in range(rows):
            out[i] = eight_lanes(W[i], xs, dt(0))
        macs = rows * cols
    _count_read(state, MATVECS, macs)
    return out


def rmatvec(state: State, y: np.ndarray) -> np.ndarray:
    """W^T y (the products a tall matrix forms include those of zero inputs)."""
    W = state.W
    rows, cols = W.shape
    dt = W.dtype.type
    ys = [dt(v) for v in y]
    out = np.zeros(cols)
    for j in range(cols):
        out[j] = in_order(W[:, j], ys, dt(0))[0]
    used = sum(v != 0 for v in ys)
    _count_read(state, RMATVECS, rows * cols if rows >= cols else used * cols)
    return out


def outer_update(state: State, post: np.ndarray, pre: np.ndarray, lr: float,
                 defer: bool) -> None:
    """W += lr post pre^T (Eqs. 1-3's local rule), or into the accumulator (``defer``)."""
    W = state.W
    target = state.acc if defer else W
    rows, cols = W.shape
    dt = W.dtype.type
    p = [dt(lr) * dt(v) for v in post]  # lr post_i
    q = [dt(v) for v in pre]
    changed = 0
    for i in range(rows):
        for j in range(cols):
            if (q[j] == 0) if rows >= cols else (p[i] == 0):
                continue
            old = target[i, j]
            target[i, j] = old + p[i] * q[j]
            changed += target[i, j] != old
    touched = sum(v != 0 for v in p) * sum(v != 0 for v in q)
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


def commit(state: State) -> None:
    """W += the accumulator, which is cleared (a cell of zero is not written)."""
    W, acc = state.W, state.acc
    rows, cols = W.shape
    written = changed = 0
    for i in range(rows):
        for j in range(cols):
            if acc[i, j] != 0:
                old = W[i, j]
                W[i, j] = old + acc[i, j]
                acc[i, j] = 0
                written += 1
                changed += W[i, j] != old
    c = state.counters
    c[COMMITS] += 1
    c[WEIGHT_READS] += written
    c[WEIGHT_WRITES] += written
    c[CELLS_CHANGED] += changed
    c[BYTES_READ] += (rows * cols + written) * W.itemsize
    c[BYTES_WRITTEN] += written * W.itemsize


def sigmoid(state: State, z: np.ndarray) -> np.ndarray:
    """The affordance 1 / (1 + e^-z), in float64."""
    return np.array([1.0 / (1.0 + math.exp(-v)) for v in z])
