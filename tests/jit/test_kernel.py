"""The kernel decorator (cml_edge.jit.kernel): compiled without reference counts, and refused
at compile time when it would need them."""

import numpy as np
import pytest
from numba.core.errors import TypingError

from cml_edge.backends.crossbar import read as crossbar_read
from cml_edge.backends.crossbar import write as crossbar_write
from cml_edge.backends.fixed import kernels as fixed
from cml_edge.backends.loihi2 import kernels as loihi2
from cml_edge.grid.planning import plan_loop
from cml_edge.grid.training import train_loop
from cml_edge.jit.kernel import allocates, kernel
from cml_edge.robot import planning as robot_planning
from cml_edge.robot import training as robot_training


def test_a_kernel_computes_in_place():
    @kernel
    def scaled_sum(x, out, k):
        total = 0.0
        for i in range(x.shape[0]):
            out[i] = k * x[i]
            total += out[i]
        return total, x.shape[0]

    x = np.arange(4.0)
    out = np.zeros(4)
    assert scaled_sum(x, out, 2.0) == (12.0, 4)
    assert out.tolist() == [0.0, 2.0, 4.0, 6.0]


def test_a_kernel_that_returns_an_array_is_refused():
    @kernel
    def passthrough(x):
        return x

    @kernel
    def in_a_tuple(x):
        return 1.0, x

    for f in (passthrough, in_a_tuple):
        with pytest.raises(TypeError, match="returns an array"):
            f(np.zeros(3))


def test_a_kernel_that_allocates_is_refused():
    @kernel
    def fresh(n):
        a = np.zeros(n)
        return a.sum()

    with pytest.raises(TypingError):
        fresh(3)


@pytest.mark.parametrize("dispatcher", [
    train_loop, plan_loop, robot_training.train_loop, robot_planning.plan_loop,
    crossbar_read._read, crossbar_write.commit_accumulated, crossbar_write.pulsed_update,
    fixed._read, fixed._outer_update, fixed.fixed_commit, loihi2.loihi2_outer_update,
])
def test_the_hot_loops_and_device_kernels_are_kernels(dispatcher):
    assert dispatcher.targetoptions["_nrt"] is False


def test_a_kernel_calls_what_allocates_through_allocates():
    @allocates
    def gram(W, out):
        out[:] = W.T @ W

    @kernel
    def walk(W, out, n):
        total = 0.0
        for _ in range(n):
            gram(W, out)
            total += out[0, 0]
        return total

    W = np.arange(6.0).reshape(3, 2)
    out = np.zeros((2, 2))
    assert walk(W, out, 2) == 2 * 20.0
    assert out.tolist() == (W.T @ W).tolist()
