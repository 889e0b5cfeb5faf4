"""The seam kernels of the memristive crossbar array: noisy analog reads, pulsed in-situ
updates.

One source of truth: :class:`cml_edge.backends.crossbar.array.CrossbarArray` calls these
kernels from Python, and the compiled training and planning loops call the same ones
through the seam (:mod:`cml_edge.backends.dispatch`). Each composes the physics of one
path of the device:

- :mod:`~cml_edge.backends.crossbar.read`: DAC, analog multiply-accumulate, read noise,
  ADC, bound management (``xbar_matvec``, ``xbar_rmatvec``);
- :mod:`~cml_edge.backends.crossbar.write`: pulses, step models, cycle-to-cycle and write
  noise, refresh, write-verify (``xbar_outer_update``, ``xbar_commit``);
- :mod:`~cml_edge.backends.crossbar.time`: programming at construction, drift, 1/f read
  noise, drift compensation (the array's ``from_float`` and ``elapse``).

The kernels read the device's numbers from ``state.params``, the
:class:`~cml_edge.backends.crossbar.config.CrossbarParams` record of its config and scale
(``P.g_min``, ``P.dw_min``...), and keep what they change over time in state arrays: the
drift-compensation factor ``state.alpha[0]`` and the idle time ``state.elapsed[0]``.
Randomness: one counter-based stream per array, ``uniform(rng[0], c)`` from
:mod:`cml_edge.jit.rng` at the counter c = ``rng[1]``, advanced by one per word drawn;
normals from :mod:`cml_edge.jit.gauss`. The same arithmetic as plain loops, which the
tests hold these kernels to: :mod:`cml_edge.backends.crossbar.reference`.
"""

from __future__ import annotations

import math

from numba import njit

from cml_edge.backends.crossbar.codes import (
    COMMITS,
    MATVECS,
    OUTER_UPDATES,
    RMATVECS,
    UPDATE_PULSED,
)
from cml_edge.backends.crossbar.read import read
from cml_edge.backends.crossbar.write import (
    accumulate,
    analog_update,
    commit_accumulated,
    pulsed_update,
)


@njit(cache=True, inline="always")
def xbar_matvec(state, x, out):
    """out = W x: a forward read (:mod:`~cml_edge.backends.crossbar.read`)."""
    read(state, x, out, False, MATVECS)


@njit(cache=True, inline="always")
def xbar_rmatvec(state, y, out):
    """out = W^T y: a transposed read of the same conductances."""
    read(state, y, out, True, RMATVECS)


@njit(cache=True, inline="always")
def xbar_outer_update(state, post, pre, lr, defer):
    """W += lr post pre^T: into the digital accumulator (``defer``), or in place by
    coincident pulses (``update`` pulsed) or exactly (analog)."""
    state.counters[OUTER_UPDATES] += 1
    if defer:
        accumulate(state.acc, state.counters, post, pre, lr)
    elif state.params.update == UPDATE_PULSED:
        pulsed_update(state, post, pre, lr)
    else:
        analog_update(state, post, pre, lr)


@njit(cache=True, inline="always")
def xbar_commit(state):
    """Apply the accumulated update: pulses or write-verify, by ``commit`` mode."""
    state.counters[COMMITS] += 1
    commit_accumulated(state)


@njit(cache=True, inline="always")
def xbar_sigmoid(state, z, out):
    """The affordance nonlinearity: a digital peripheral function, computed exactly."""
    for i in range(z.shape[0]):
        out[i] = 1.0 / (1.0 + math.exp(-z[i]))
