"""Conductance levels on the noise-free preset: a pair's grid, and success that follows the
number of levels (what ``--levels`` costs must be the device's resolution, not rounding)."""

from __future__ import annotations

import numpy as np
import pytest

from cml_edge.backends import make_array
from cml_edge.grid.evaluation import Protocol, run_protocol


@pytest.mark.parametrize("levels", [16, 17, 256])
def test_a_pair_holds_every_whole_level_of_difference_and_zero(levels):
    """pair_grid pair: the weights of a two-sided pair are k dG / g_per_w, 0 included,
    whatever the parity of ``levels``; the device grid of earlier releases turns a weight
    below half a level into +-dG / g_per_w when ``levels`` is even."""
    dG = 25.0 / (levels - 1)
    step = dG / 25.0  # one level of difference in weight units (w_max 1: g_per_w 25)
    W = np.array([[0.0, 0.2 * step, -0.2 * step, 0.8 * step, 3.4 * step, -2.6 * step]])
    pair = make_array("crossbar", W, seed=0, index=0, preset="ideal", levels=levels,
                      w_max_q=1.0)
    np.testing.assert_allclose(pair.to_float() / step, [[0, 0, 0, 1, 3, -3]], atol=1e-9)
    device = make_array("crossbar", W, seed=0, index=0, preset="ideal", levels=levels,
                        w_max_q=1.0, pair_grid="device")
    if levels % 2 == 0:
        np.testing.assert_allclose(device.to_float()[0, 1:3] / step, [1, -1], atol=1e-9)
    # a commit moves the difference by whole levels (the rest stays in the accumulator)
    pair.state.acc[:] = 1.5 * step
    pair.commit()
    np.testing.assert_allclose(pair.to_float() / step, [[1, 1, 1, 2, 4, -2]], atol=1e-9)
    np.testing.assert_allclose(pair.state.acc, 0.5 * step, atol=1e-12)


def test_success_does_not_fall_with_more_levels_on_the_noise_free_preset():
    """``cml-edge emulate --backend crossbar --preset ideal --levels L`` at a small size:
    success non-decreasing in L (it fell from 1.00 at 97 levels to 0.70 at 256 when each
    device was rounded on its own grid)."""
    success = []
    for levels in (16, 45, 97, 144, 256):
        r = run_protocol(Protocol(backend="crossbar", seeds=(0, 1), trials=50,
                                  backend_options={"preset": "ideal", "levels": levels},
                                  fidelity=False))
        success.append(r["success_rate"])
    assert success == sorted(success), success
    assert success[-1] == 1.0
