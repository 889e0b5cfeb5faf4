import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from cml_edge.backends import array_from_state_dict, backend_spec, make_array

SHAPES = [(256, 2), (8, 256), (256, 8), (3, 5)]
finite = st.floats(-1e3, 1e3, allow_nan=False, width=64)


@pytest.mark.parametrize("shape", SHAPES)
@pytest.mark.parametrize("backend", ["float", "float32"])
def test_reads_match_numpy(shape, backend):
    rng = np.random.default_rng(1)
    W = rng.normal(size=shape)
    arr = make_array(backend, W, seed=0, index=0)
    x, y = rng.normal(size=shape[1]), rng.normal(size=shape[0])
    tol = 1e-12 if backend == "float" else 1e-4
    Wd = W.astype(np.float32).astype(np.float64) if backend == "float32" else W
    np.testing.assert_allclose(arr.matvec(x), Wd @ x, rtol=tol, atol=tol)
    np.testing.assert_allclose(arr.rmatvec(y), Wd.T @ y, rtol=tol, atol=tol)
    assert arr.counters["matvecs"] == 1 and arr.counters["rmatvecs"] == 1


@pytest.mark.parametrize("shape", SHAPES)
def test_outer_update_is_the_hand_computed_outer_product(shape):
    rng = np.random.default_rng(2)
    W = rng.normal(size=shape)
    post, pre, lr = rng.normal(size=shape[0]), rng.normal(size=shape[1]), 0.001
    now = make_array("float", W, seed=0, index=0)
    now.outer_update(post, pre, lr, defer=False)
    assert (now.to_float() == W + np.outer(lr * post, pre)).all()
    later = make_array("float", W, seed=0, index=0)
    later.outer_update(post, pre, lr, defer=True)
    later.outer_update(post, pre, lr, defer=True)
    assert (later.to_float() == W).all()  # nothing applied before commit
    later.commit()
    dw = np.outer(lr * post, pre)
    assert (later.to_float() == W + (dw + dw)).all()
    assert later.counters["commits"] == 1 and later.counters["acc_writes"] == 2 * W.size


@settings(max_examples=40, deadline=None)
@given(st.sampled_from(SHAPES), st.data())
def test_zero_factors_leave_rows_and_columns_alone(shape, data):
    W = data.draw(arrays(np.float64, shape, elements=finite))
    post = data.draw(arrays(np.float64, shape[0], elements=finite))
    pre = data.draw(arrays(np.float64, shape[1], elements=finite))
    zero_rows = data.draw(arrays(bool, shape[0]))
    zero_cols = data.draw(arrays(bool, shape[1]))
    post[zero_rows] = 0.0
    pre[zero_cols] = 0.0
    arr = make_array("float", W, seed=0, index=0)
    buffer = arr.state.W
    arr.outer_update(post, pre, 0.01, defer=False)
    after = arr.to_float()
    assert arr.state.W is buffer and arr.state.W.dtype == np.float64  # in place
    assert (after[zero_rows] == W[zero_rows]).all()
    assert (after[:, zero_cols] == W[:, zero_cols]).all()


def test_zero_learning_rate_changes_nothing():
    W = np.random.default_rng(3).normal(size=(8, 256))
    arr = make_array("float", W, seed=0, index=0)
    arr.outer_update(np.ones(8), np.ones(256), 0.0, defer=False)
    assert (arr.to_float() == W).all() and arr.counters["cells_changed"] == 0


@pytest.mark.parametrize("backend", ["float", "float32"])
def test_state_dict_round_trip(backend):
    W = np.random.default_rng(4).normal(size=(256, 8))
    arr = make_array(backend, W, seed=0, index=0)
    arr.outer_update(np.ones(256), np.arange(8.0), 0.1, defer=True)
    arr.matvec(np.ones(8))
    back = array_from_state_dict(arr.state_dict())
    for a, b in zip(arr.state, back.state):
        assert a.dtype == b.dtype and (a == b).all()
    assert back.counters == arr.counters
    assert back.state.W.flags["F_CONTIGUOUS"] == arr.state.W.flags["F_CONTIGUOUS"]


def test_foreign_state_rejected():
    d = make_array("float", np.ones((2, 2)), seed=0, index=0).state_dict()
    with pytest.raises(ValueError, match="unknown array kind"):
        array_from_state_dict({**d, "__backend__": np.array("quantum")})
    d.pop("acc")
    with pytest.raises(ValueError, match="lacks acc"):
        array_from_state_dict(d)


def test_unknown_backend_names_the_allowed():
    with pytest.raises(ValueError, match="unknown backend 'gpu'; allowed: .*float"):
        backend_spec("gpu")
