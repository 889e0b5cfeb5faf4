import numpy as np
import pytest

from cml_edge.core.cml import CML, CMLConfig
from cml_edge.core.learning import learn_step
from cml_edge.grid.arena import MOVES


def test_paper_parameter_and_flop_counts():
    cml = CML.create()
    assert cml.parameter_count() == 4608
    assert cml.parameter_count() == sum(a.shape[0] * a.shape[1] for a in cml.arrays)
    assert cml.inference_flops() == 9464
    assert (cml.W_q.shape, cml.W_k.shape, cml.W_v.shape) == ((256, 2), (8, 256), (256, 8))


def test_local_rule_step_is_eqs_1_to_3_by_hand():
    cml = CML.create(seed=5)
    W = cml.weights()
    Wq, Wk, Wv = W["W_q"], W["W_k"], W["W_v"]
    lr = 0.001
    pos, a = np.array([3, 4]), 1
    o_t, o_1 = cml.observe(pos), cml.observe(pos + MOVES[a])
    s_t, s_1 = Wq @ o_t, Wq @ o_1
    action = np.eye(8)[a]
    g = 1 / (1 + np.exp(-(Wk @ s_t)))
    s_hat = s_t + Wv @ action
    learn_step(cml, o_t, o_1, a, defer=False)
    after = cml.weights()
    np.testing.assert_allclose(after["W_k"], Wk + lr * np.outer(action - g, s_t), atol=1e-15)
    np.testing.assert_allclose(after["W_v"], Wv + lr * np.outer(s_1 - s_hat, action), atol=1e-15)
    np.testing.assert_allclose(after["W_q"], Wq + lr * np.outer(s_hat - s_1, o_1), atol=1e-15)


def test_observation_frame_is_centred_on_the_training_arena():
    cml = CML.create(CMLConfig.for_arena(30))
    np.testing.assert_allclose(cml.observe((0, 29)), [-14.5 / 30, 14.5 / 30])
    np.testing.assert_allclose(cml.observe((14.5, 14.5)), [0, 0])


def test_seeded_initialisation():
    a, b, c = CML.create(seed=1), CML.create(seed=1), CML.create(seed=2)
    assert all((a.weights()[k] == b.weights()[k]).all() for k in ("W_q", "W_k", "W_v"))
    assert not (a.weights()["W_q"] == c.weights()["W_q"]).all()


@pytest.mark.parametrize("field,value", [("n_s", 0), ("lr_q", -1.0), ("lr_k", float("nan")),
                                         ("utility", "cosine"), ("obs_scale", 0.0)])
def test_config_validation(field, value):
    with pytest.raises(ValueError, match=field if field != "utility" else "utility"):
        CMLConfig(**{field: value})
