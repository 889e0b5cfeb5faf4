"""A run whose device produced NaN or infinity fails with one line (the device, the phase,
the matrix or metric), exit status 1, nothing on stdout and nothing written; what is
printed or written is strict JSON."""

import json

import numpy as np
import pytest

from cml_edge.cli import grid as grid_cli
from cml_edge.grid import training

SMALL = ["--arena", 8, "--walks", 2, "--steps", 30]


def _one_line(err: str) -> str:
    assert len(err.splitlines()) == 1 and "Traceback" not in err
    assert err.startswith("cml-edge: error: run failed: ")
    return err


def test_train_whose_weights_end_nan_fails_and_writes_no_model(cli, tmp_path, monkeypatch):
    def poison(learner, *args):
        learner.W_q.state.W[0, 0] = np.nan

    monkeypatch.setattr(training, "make_learner", lambda cml, *args: cml)
    monkeypatch.setattr(training, "train_loop", poison)
    out = tmp_path / "m.npz"
    code, stdout, err = cli("train", *SMALL, "--out", out, "--json")
    assert code == 1 and stdout == ""
    assert "float produced NaN in W_q of seed 0 after training" in _one_line(err)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("json_flag", [["--json"], []])
def test_a_nan_metric_is_never_printed_nor_written(cli, tmp_path, monkeypatch, json_flag):
    def protocol(p, progress=None, records=None):
        return {"backend": p.backend, "success_rate": 1.0, "read_snr": {"W_q": {"mean": np.nan}}}

    monkeypatch.setattr(grid_cli, "run_protocol", protocol)
    out = tmp_path / "r.json"
    code, stdout, err = cli("emulate", "--seeds", 1, "--out", out, *json_flag)
    assert code == 1 and stdout == ""
    assert "float metric read_snr.W_q.mean is nan; nothing written" in _one_line(err)
    assert not out.exists()


def test_a_result_with_null_is_strict_json(cli, tmp_path, monkeypatch):
    def protocol(p, progress=None, records=None):
        return {"backend": p.backend, "overhead_mean": None, "success_rate": 0.0}

    monkeypatch.setattr(grid_cli, "run_protocol", protocol)
    out = tmp_path / "r.json"
    code, stdout, err = cli("emulate", "--seeds", 1, "--out", out, "--json")
    assert code == 0 and err == ""
    assert json.loads(stdout)["overhead_mean"] is None
    assert json.loads(out.read_text(), parse_constant=pytest.fail)["overhead_mean"] is None


def test_a_drift_beyond_the_model_is_refused_before_it_can_make_nan(cli, tmp_path):
    """--drift-time 1e308 turned the conductances into NaN; it is refused up front now
    (the monkeypatched tests above cover the backstop for what cannot be refused)."""
    out = tmp_path / "r.json"
    code, stdout, err = cli("emulate", "--backend", "crossbar", "--drift-time", "1e308",
                            "--seeds", 1, "--trials", 3, *SMALL, "--json", "--out", out)
    assert code == 2 and stdout == ""
    assert err.splitlines() == [err.strip()] and "Traceback" not in err
    assert err.startswith("cml-edge: error: argument --drift-time: '1e308' is outside the range")
    assert not out.exists()
