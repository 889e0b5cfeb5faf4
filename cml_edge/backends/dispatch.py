"""The synaptic-array seam inside compiled code.

A compiled loop (training, planning) calls ``sa_matvec(state, x, out)`` and friends;
at compile time Numba resolves each call, by the type of ``state`` (a backend's
``NamedTuple`` class), to the ``@njit`` kernel that backend registered. The loop is
written once and never asks which array it runs on; each backend's arithmetic has one
source of truth (the kernel), which its Python-level array calls too.

Why not pass the kernels to the loop as arguments: Numba cannot cache a function
that takes dispatchers as arguments, so every process would recompile the loop.
Overloads keyed by the state type are resolved at typing time and cache normally.

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
from numba.extending import overload

# Kernels and these overloads are inlined at Numba-IR level (inline="always"): a call
# through the seam otherwise costs more than the arithmetic of a 256 x 8 read (the
# reference counting of every array in the state tuple). Numba's SSA pass emits an
# internal "pedantic" NumbaIRAssumptionWarning for inlined loops; it flags no error
# (the tests hold the inlined and the called kernels to bit equality), so it is muted.
warnings.filterwarnings("ignore", category=NumbaIRAssumptionWarning)


class Kernels(NamedTuple):
    """The four compiled kernels of one backend."""

    matvec: object
    rmatvec: object
    outer_update: object
    commit: object
    sigmoid: object


_REGISTRY: dict[type, Kernels] = {}


def register(state_class: type, kernels: Kernels) -> None:
    """Make ``kernels`` the implementation of the seam for states of ``state_class``."""
    _REGISTRY[state_class] = kernels


def kernels_for(state_class: type) -> Kernels:
    """The kernels registered for ``state_class`` (for Python-level calls)."""
    return _REGISTRY[state_class]


def _kernel(state_type, name):
    cls = getattr(state_type, "instance_class", None)
    kernels = _REGISTRY.get(cls)
    return None if kernels is None else getattr(kernels, name)


def _compiled_only(*args):
    raise TypeError("synaptic-array dispatch stubs are callable only from compiled code")


def sa_matvec(state, x, out):
    """out = W x (compiled code only)."""
    _compiled_only()


def sa_rmatvec(state, y, out):
    """out = W^T y (compiled code only)."""
    _compiled_only()


def sa_outer_update(state, post, pre, lr, defer):
    """W += lr * post pre^T, now or at commit (compiled code only)."""
    _compiled_only()


def sa_commit(state):
    """Apply the accumulated update (compiled code only)."""
    _compiled_only()


def sa_sigmoid(state, z, out):
    """out = sigmoid(z) as the device computes it (compiled code only)."""
    _compiled_only()


@overload(sa_matvec, inline="always")
def _ov_matvec(state, x, out):
    k = _kernel(state, "matvec")
    if k is not None:
        return lambda state, x, out: k(state, x, out)


@overload(sa_rmatvec, inline="always")
def _ov_rmatvec(state, y, out):
    k = _kernel(state, "rmatvec")
    if k is not None:
        return lambda state, y, out: k(state, y, out)


@overload(sa_outer_update, inline="always")
def _ov_outer_update(state, post, pre, lr, defer):
    k = _kernel(state, "outer_update")
    if k is not None:
        return lambda state, post, pre, lr, defer: k(state, post, pre, lr, defer)


@overload(sa_commit, inline="always")
def _ov_commit(state):
    k = _kernel(state, "commit")
    if k is not None:
        return lambda state: k(state)


@overload(sa_sigmoid, inline="always")
def _ov_sigmoid(state, z, out):
    k = _kernel(state, "sigmoid")
    if k is not None:
        return lambda state, z, out: k(state, z, out)
