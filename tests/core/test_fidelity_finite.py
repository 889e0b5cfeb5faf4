"""No NaN in any output: the weights checked after each phase, strict JSON, figures that do
not apply written as null by the code that computes them, never a NaN hidden."""

import json
import math

import numpy as np
import pytest

from cml_edge.core.cml import CML, CMLConfig
from cml_edge.core.fidelity import seed_stats, weight_error
from cml_edge.core.finite import (
    NonFiniteError,
    check_finite,
    check_weights,
    dumps,
    first_non_finite,
)
from cml_edge.grid import training
from cml_edge.grid.arena import GridArena
from cml_edge.grid.seed_run import SeedRun, evaluate_seed


def _cml(backend="float", **options):
    return CML.create(CMLConfig.for_arena(6), backend, 0, **options)


def test_dumps_is_strict_json_and_names_the_first_non_finite_number():
    assert dumps({"a": [1.0, None], "b": 2}) == json.dumps({"a": [1.0, None], "b": 2})
    assert json.loads(dumps({"x": np.float64(0.5)}, indent=1)) == {"x": 0.5}
    for bad in (math.nan, math.inf, -math.inf):
        with pytest.raises(NonFiniteError, match=r"crossbar metric per_seed\[1\]\.read_snr\.W_q"):
            dumps({"backend": "crossbar", "per_seed": [{}, {"read_snr": {"W_q": bad}}]})
    with pytest.raises(NonFiniteError, match=r"metric e\[2\] is nan after evaluation"):
        check_finite({"e": np.array([0.0, 1.0, np.nan])}, "evaluation")
    assert first_non_finite({"a": [1, "x", None, {"b": (2.0,)}]}) is None


@pytest.mark.parametrize("value,kind", [(np.nan, "NaN"), (np.inf, "infinity")])
def test_check_weights_names_the_device_the_phase_and_the_matrix(value, kind):
    cml = _cml()
    check_weights(cml, "training", 3)
    cml.W_k.state.W[1, 2] = value
    with pytest.raises(NonFiniteError, match=f"^run failed: float produced {kind} in W_k of "
                                             "seed 3 after training"):
        check_weights(cml, "training", 3)


def test_training_that_ends_in_nan_fails(monkeypatch):
    """A training whose weights end NaN raises; the check reads the arrays after the loop."""
    def poison(learner, *args):
        learner.W_v.state.W[0, 0] = np.nan

    monkeypatch.setattr(training, "make_learner", lambda cml, *args: cml)
    monkeypatch.setattr(training, "train_loop", poison)
    cml = _cml()
    with pytest.raises(NonFiniteError, match="in W_v of seed 0 after training"):
        training.train(cml, GridArena.empty(6), training.TrainConfig(2, 10), 0)


def test_drift_that_ends_in_nan_fails_before_planning(monkeypatch):
    cml = _cml()
    monkeypatch.setattr(type(cml.W_q), "elapse", lambda self, s: self.state.W.fill(np.inf))
    run = SeedRun(5, cml, "direct", np.zeros(1), [], [], [], {}, {}, [0.0], [0.0])
    with pytest.raises(NonFiniteError, match="infinity in W_q of seed 5 after drift"):
        evaluate_seed(run, [], idle_s=1.0)


def test_weight_error_of_a_zero_twin_is_not_applicable():
    dev, twin = _cml(), _cml()
    for a in twin.arrays:
        a.state.W[:] = 0.0
    err = weight_error(dev, twin)
    assert err["W_q"] is None and err["matrix_mean"] is None
    assert weight_error(twin, twin)["W_k"] == 0.0
    json.loads(dumps(err))


@pytest.mark.filterwarnings("ignore:invalid value")
def test_seed_stats_never_hide_a_nan():
    assert seed_stats([1.0, None])["min"] == 1.0
    assert math.isnan(seed_stats([1.0, math.nan])["mean"])
    assert math.isnan(seed_stats([None, 1.0, math.nan])["min"])
    with pytest.raises(NonFiniteError):
        dumps(seed_stats([math.inf, 1.0]))
