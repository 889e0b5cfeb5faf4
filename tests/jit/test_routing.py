"""Functions routed by the type of their first argument (cml_edge.jit.routing): resolved and
inlined at compile time, called from Python by type, and never compiled apart from their
callers."""

from typing import NamedTuple

import numpy as np
import pytest
from numba import njit
from numba.core import event

from cml_edge.jit.routing import _INLINED, routed


class Doubler(NamedTuple):
    k: np.ndarray


class Adder(NamedTuple):
    k: np.ndarray


@routed
def apply(plug, x, flag):
    """A documented signature, no body."""


@njit(inline="always")
def _double(plug, x, flag):
    return plug.k[0] * x * 2.0 if flag else -1.0


@njit(inline="always")
def _add(plug, x, flag):
    return plug.k[0] + x + (1.0 if flag else 0.0)


apply.register(Doubler, _double)
apply.register(Adder, _add)


@njit
def _caller(plug, x):
    return apply(plug, x, True) + apply(plug, x, False)


class _Compiles(event.Listener):
    def __init__(self):
        self.names = []

    def on_start(self, ev):
        func = ev.data["dispatcher"].py_func
        self.names.append((func.__name__, getattr(func, _INLINED, False)))

    def on_end(self, ev):
        pass


def test_a_routed_function_picks_its_implementation_by_type():
    d, a = Doubler(np.array([3.0])), Adder(np.array([3.0]))
    assert _caller(d, 2.0) == 3.0 * 2.0 * 2.0 - 1.0
    assert _caller(a, 2.0) == (3.0 + 2.0 + 1.0) + (3.0 + 2.0)
    assert apply(d, 2.0, True) == 12.0 and apply(a, 2.0, False) == 5.0  # from Python
    with pytest.raises(TypeError, match="apply: no implementation for tuple"):
        apply((1,), 2.0, True)


def test_a_routed_implementation_compiles_only_inside_its_caller():
    compiles = _Compiles()

    @njit
    def caller(plug, x):
        return apply(plug, x, True)

    with event.install_listener("numba:compile", compiles):
        assert caller(Doubler(np.array([0.5])), 4.0) == 4.0
    assert ("caller", False) in compiles.names
    assert not [name for name, inlined in compiles.names if inlined]  # none apart
