"""The synaptic-array seam as five routed functions, for compiled and Python code alike.

A device registers its ``@njit`` kernels for its state class (:func:`register`); a
compiled loop (training, planning) calls ``sa_matvec(state, x, out)`` and friends, and
Numba resolves each call, while typing the loop, to the kernel registered for the type
of ``state`` (:func:`cml_edge.jit.routing.routed`). The loop is written once and never asks
which array it runs on; each device's arithmetic has one source of truth, its kernels,
which its Python-level array methods call through the same functions.

Kernel signatures (all outputs written in place, nothing returned):

- ``matvec(state, x, out)``: out = W x (x, out float64);
- ``rmatvec(state, y, out)``: out = W^T y, the transposed read of the same weights;
- ``outer_update(state, post, pre, lr, defer)``: W += lr * post pre^T, applied now
  (``defer`` False) or accumulated until ``commit`` (``defer`` True);
- ``commit(state)``: apply what was accumulated and clear it;
- ``sigmoid(state, z, out)``: out = sigmoid(z), the affordance nonlinearity as the
  device's neurons compute it (exact in float, a lookup table on an integer chip).
"""

from __future__ import annotations

import warnings
from typing import NamedTuple

from numba.core.errors import NumbaIRAssumptionWarning

from cml_edge.jit.routing import routed

# Kernels are inlined at Numba-IR level (inline="always"): a call through the seam
# otherwise costs more than the arithmetic of a 256 x 8 read (the call, and, in a loop
# compiled with reference counting, the counts of every array in the state tuple; the
# training and planning loops are kernels, :mod:`cml_edge.jit.kernel`, and pay none). Numba's
# SSA pass emits an internal "pedantic"
# NumbaIRAssumptionWarning for inlined loops; it flags no error (the tests hold the
# inlined and the called kernels to bit equality), so it is muted.
warnings.filterwarnings("ignore", category=NumbaIRAssumptionWarning)


class Kernels(NamedTuple):
    """The five compiled kernels of one device."""

    matvec: object
    rmatvec: object
    outer_update: object
    commit: object
    sigmoid: object


@routed
def sa_matvec(state, x, out):
    """out = W x."""


@routed
def sa_rmatvec(state, y, out):
    """out = W^T y, read from the same stored weights."""


@routed
def sa_outer_update(state, post, pre, lr, defer):
    """W += lr * post pre^T, now or at commit."""


@routed
def sa_commit(state):
    """Apply the accumulated update."""


@routed
def sa_sigmoid(state, z, out):
    """out = sigmoid(z) as the device computes it."""


SEAM = Kernels(sa_matvec, sa_rmatvec, sa_outer_update, sa_commit, sa_sigmoid)


def register(state_class: type, kernels: Kernels) -> None:
    """Make ``kernels`` the implementation of the seam for states of ``state_class``."""
    for function, kernel in zip(SEAM, kernels):
        function.register(state_class, kernel)


def is_registered(state_class: type) -> bool:
    """Whether the seam has kernels for states of ``state_class``."""
    return state_class in sa_matvec.implementations


def unregister(state_class: type) -> None:
    """Remove the seam's kernels for ``state_class`` (a device taken out of the registry;
    loops compiled for it before keep their copy)."""
    for function in SEAM:
        function.implementations.pop(state_class, None)
