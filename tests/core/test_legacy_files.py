"""Model files saved by the previous release load and evaluate exactly as that release did.

tests/data/legacy/ holds small models written by the release before the one-folder-per-
device layout (commit 30f00e8) and ``expected.json``, what that release read from them
(generate.py there says how). The current loader converts their state layout; the
weights, an evaluation and a probe of further reads and updates must agree bit for bit.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np
import pytest

from cml_edge.core.model_file import load_model

LEGACY = Path(__file__).resolve().parents[1] / "data" / "legacy"
EXPECTED = json.loads((LEGACY / "expected.json").read_text())["files"]


def sha(a: np.ndarray) -> str:
    return hashlib.sha256(np.ascontiguousarray(a, dtype=np.float64).tobytes()).hexdigest()


def test_every_backend_kind_is_covered():
    kinds = {json.loads(str(np.load(LEGACY / f"{n}.npz")["W_q/__options__"])).get("preset")
             for n in EXPECTED}
    assert {"pcm", "reram"} <= kinds
    assert {EXPECTED[n]["backend"] for n in EXPECTED} == {"float", "float32", "int8", "fixed",
                                                          "crossbar"}


@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_legacy_weights_load_unchanged(name):
    cml, record = load_model(LEGACY / f"{name}.npz")
    want = EXPECTED[name]
    assert cml.backend == want["backend"]
    assert {k: sha(v) for k, v in cml.weights().items()} == want["weights"]


@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_legacy_model_evaluates_as_before(name, cli):
    code, out, err = cli("evaluate", LEGACY / f"{name}.npz", "--trials", 20, "--json")
    assert code == 0, err
    result = json.loads(out)
    result.pop("model")
    want = EXPECTED[name]["evaluate"]  # every key the old release printed, unchanged
    assert {k: result.get(k) for k in want} == want


@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_legacy_arrays_continue_bit_for_bit(name):
    cml, _ = load_model(LEGACY / f"{name}.npz")
    for matrix, arr in zip(("W_q", "W_k", "W_v"), cml.arrays):
        want = EXPECTED[name]["probe"][matrix]
        rows, cols = arr.shape
        x = np.sin(np.arange(cols) + 1.0)
        y = np.cos(np.arange(rows) + 1.0)
        post, pre = np.linspace(-1.0, 1.0, rows), np.linspace(0.5, -0.5, cols)
        assert arr.matvec(x).tolist() == want["matvec"]
        assert arr.rmatvec(y).tolist() == want["rmatvec"]
        arr.outer_update(post, pre, 0.01, defer=False)
        arr.outer_update(post, pre, 0.02, defer=True)
        arr.commit()
        assert sha(arr.to_float()) == want["weights_after"]
        counters = arr.counters  # as before, and counters added since count nothing here
        assert {k: counters[k] for k in want["counters"]} == want["counters"]
        assert {counters[k] for k in counters.keys() - want["counters"].keys()} <= {0}


def test_legacy_drift_factor_is_kept():
    """pcm-drift was saved after an hour of compensated drift: its alpha is not 1."""
    cml, _ = load_model(LEGACY / "pcm-drift.npz")
    plain, _ = load_model(LEGACY / "pcm.npz")
    assert EXPECTED["pcm-drift"]["weights"] != EXPECTED["pcm"]["weights"]
    assert cml.W_q.options()["drift_compensation"] and not plain.W_q.options()[
        "drift_compensation"]
