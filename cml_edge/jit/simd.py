"""Explicit vector arithmetic for the few sums LLVM will not vectorise.

A read of a short, wide matrix stored column-major (the crossbar's W_k: 8 outputs, 256
inputs) is W x = sum_j x_j W[:, j], each output a chain of additions in column order.
The eight outputs of a column are eight independent lanes, contiguous in memory, but
Numba's LLVM vectorises only innermost loops (an inner loop of 8 falls to its scalar
remainder) and runs without the straight-line (SLP) vectoriser, so the read ran as
scalar code: 0.59 us for 8 x 256 in a throwaway loop on this machine. :func:`band_sums`
writes the lanes as one LLVM vector: 0.18 us.

Each lane performs exactly the scalar code's operations, in the same order (a subtraction,
a multiplication, an addition; IEEE 754, no fused multiply-add, no reassociation), so the
results are the same bits; ``tests/backends/test_references.py`` holds the reads that use
them to the plain loops of ``cml_edge/backends/crossbar/reference.py``.

Bit masks (SWAR: SIMD within a register) mark the nonzero entries of a vector, 64 to an
int64 word (:func:`nonzero_masks`), so that a sparse read visits only its driven lines and
a pulse train is one word (:func:`popcount` counts its pulses).
"""

from __future__ import annotations

import numpy as np
from llvmlite import ir
from numba import njit, types
from numba.core import cgutils
from numba.extending import intrinsic

from cml_edge.jit.kernel import kernel

_F64 = ir.DoubleType()
_I32 = ir.IntType(32)


@intrinsic
def band_sums(typingctx, Gp, Gm, x, out, i0, lanes):
    """out[i0 + l] = sum_j (Gp[i0 + l, j] - Gm[i0 + l, j]) x[j] for l < ``lanes`` (a
    literal: 1, 2, 4 or 8), summed in column order from 0.0 over the columns whose x[j]
    is not 0 (a NaN input is summed, as ``x[j] != 0.0`` says). The caller checks what the
    types cannot say: the rows of ``Gp`` and ``Gm`` are contiguous (``strides[0]`` 8 bytes:
    column-major) and rows i0 .. i0 + lanes - 1 exist; ``x`` and ``out`` are contiguous."""
    if not isinstance(lanes, types.IntegerLiteral) or lanes.literal_value not in (1, 2, 4, 8):
        return None
    if not all(isinstance(a, types.Array) and a.dtype == types.float64 and a.ndim == 2
               for a in (Gp, Gm)):
        return None
    if not all(isinstance(a, types.Array) and a.dtype == types.float64 and a.ndim == 1
               and a.layout == "C" for a in (x, out)):
        return None
    n = lanes.literal_value
    vec = ir.VectorType(_F64, n)

    def codegen(context, builder, signature, args):
        gp, gm, xa, oa = (context.make_array(t)(context, builder, a)
                          for t, a in zip(signature.args[:4], args[:4]))
        first = args[4]
        byte_ptr = ir.IntType(8).as_pointer()
        cols = builder.extract_value(gp.shape, 1)
        step_p = builder.extract_value(gp.strides, 1)  # bytes from one column to the next
        step_m = builder.extract_value(gm.strides, 1)
        top_p = builder.bitcast(builder.gep(gp.data, [first]), byte_ptr)
        top_m = builder.bitcast(builder.gep(gm.data, [first]), byte_ptr)
        acc = cgutils.alloca_once_value(builder, ir.Constant(vec, [0.0] * n))
        with cgutils.for_range(builder, cols) as loop:
            j = loop.index
            xj = builder.load(builder.gep(xa.data, [j]))
            with builder.if_then(builder.fcmp_unordered("!=", xj, ir.Constant(_F64, 0.0))):
                diff = builder.fsub(_lanes_at(builder, top_p, j, step_p, vec),
                                    _lanes_at(builder, top_m, j, step_m, vec))
                term = builder.fmul(diff, _splat(builder, xj, vec))
                builder.store(builder.fadd(builder.load(acc), term), acc)
        dest = builder.bitcast(builder.gep(oa.data, [first]), vec.as_pointer())
        builder.store(builder.load(acc), dest, align=8)
        return context.get_dummy_value()

    return types.none(Gp, Gm, x, out, i0, lanes), codegen


@intrinsic
def lane_sums(typingctx, Gp, Gm, y, o, rows):
    """The eight partial sums of column o of (Gp - Gm) against y over its first ``rows``
    rows (a multiple of 8): lane l is sum_c (Gp[8c + l, o] - Gm[8c + l, o]) y[8c + l] in
    order of c from 0.0, the eight interleaved sums of a transposed read (the same
    operations and order as eight scalar accumulators). Returned as a tuple of 8 floats;
    the caller checks that the columns are contiguous (``strides[0]`` 8 bytes) and adds
    the remaining rows and the lanes in its own order."""
    if not all(isinstance(a, types.Array) and a.dtype == types.float64 and a.ndim == 2
               for a in (Gp, Gm)):
        return None
    if not (isinstance(y, types.Array) and y.dtype == types.float64 and y.ndim == 1
            and y.layout == "C"):
        return None
    vec = ir.VectorType(_F64, 8)
    result = types.UniTuple(types.float64, 8)

    def codegen(context, builder, signature, args):
        gp, gm, ya = (context.make_array(t)(context, builder, a)
                      for t, a in zip(signature.args[:3], args[:3]))
        col, n = args[3], args[4]
        byte_ptr = ir.IntType(8).as_pointer()
        top_p = builder.gep(builder.bitcast(gp.data, byte_ptr),
                            [builder.mul(col, builder.extract_value(gp.strides, 1))])
        top_m = builder.gep(builder.bitcast(gm.data, byte_ptr),
                            [builder.mul(col, builder.extract_value(gm.strides, 1))])
        top_y = builder.bitcast(ya.data, byte_ptr)
        acc = cgutils.alloca_once_value(builder, ir.Constant(vec, [0.0] * 8))
        eight = ir.Constant(n.type, 8)
        with cgutils.for_range(builder, builder.udiv(n, eight)) as loop:
            chunk = builder.mul(loop.index, ir.Constant(n.type, 64))  # bytes
            diff = builder.fsub(_lanes_at(builder, top_p, chunk, None, vec),
                                _lanes_at(builder, top_m, chunk, None, vec))
            term = builder.fmul(diff, _lanes_at(builder, top_y, chunk, None, vec))
            builder.store(builder.fadd(builder.load(acc), term), acc)
        total = builder.load(acc)
        lanes = [builder.extract_element(total, ir.Constant(_I32, k)) for k in range(8)]
        return context.make_tuple(builder, result, lanes)

    return result(Gp, Gm, y, o, rows), codegen


def _lanes_at(builder, top, j, step, vec):
    """The vector at byte offset j * step (j if ``step`` is None) from ``top``."""
    offset = j if step is None else builder.mul(j, step)
    return builder.load(builder.bitcast(builder.gep(top, [offset]), vec.as_pointer()),
                        align=8)


def _splat(builder, value, vec):
    """``value`` in every lane of a vector of type ``vec``."""
    one = builder.insert_element(ir.Constant(vec, ir.Undefined), value, ir.Constant(_I32, 0))
    return builder.shuffle_vector(one, ir.Constant(vec, ir.Undefined),
                                  ir.Constant(ir.VectorType(_I32, vec.count), [0] * vec.count))


@kernel
def popcount(v):
    """The set bits of a 64-bit word (int64 or uint64; the SWAR sum, which LLVM compiles
    to one instruction)."""
    v = np.uint64(v)
    v = v - ((v >> np.uint64(1)) & np.uint64(0x5555555555555555))
    v = (v & np.uint64(0x3333333333333333)) + ((v >> np.uint64(2)) & np.uint64(0x3333333333333333))
    v = (v + (v >> np.uint64(4))) & np.uint64(0x0F0F0F0F0F0F0F0F)
    return np.int64((v * np.uint64(0x0101010101010101)) >> np.uint64(56))


@njit(cache=True, inline="always")
def nonzero_masks(v, n, masks):
    """Bit j % 64 of masks[j // 64] set where v[j] != 0 (NaN included), for j < n; returns
    how many are. ``masks`` (int64, holding the bits of uint64 words) needs (n + 63) // 64
    entries. Each word is built in a pass that vectorises."""
    count = 0
    for b in range((n + 63) >> 6):
        mk = np.uint64(0)
        for u in range(min(n - (b << 6), 64)):
            mk |= np.uint64(v[(b << 6) + u] != 0.0) << np.uint64(u)
        masks[b] = np.int64(mk)
        count += popcount(mk)
    return count
