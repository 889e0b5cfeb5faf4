"""IBM aihwkit in the loop: ``device characterize --against aihwkit``, ``--preset
aihwkit:NAME`` and the worker's timing task, at small sizes, in aihwkit's own environment
(``bash scripts/aihwkit_env.sh``; the tests marked ``aihwkit`` are skipped, with the
reason, where it is not built)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from cml_edge.backends.crossbar.aihwkit import runner
from cml_edge.errors import InputError

_built = pytest.mark.skipif(runner.python() is None,
                            reason=f"aihwkit's environment is not built ({runner.venv_dir()}): "
                                   f"{runner.BUILD_COMMAND}")


def needs_aihwkit(test):
    """Marked ``aihwkit``, and skipped with the reason where its environment is missing."""
    return pytest.mark.aihwkit(_built(test))


def test_missing_environment_is_one_line_naming_the_build_command(cli, monkeypatch, tmp_path):
    monkeypatch.setenv(runner.VENV_VARIABLE, str(tmp_path / "none"))
    code, out, err = cli("device", "characterize", "--against", "aihwkit", "--devices", "10")
    assert code == 2 and out == ""
    assert err.strip().count("\n") == 0 and runner.BUILD_COMMAND in err
    code, _, err = cli("emulate", "--backend", "crossbar", "--preset",
                       "aihwkit:PCMPresetDevice")
    assert code == 2 and runner.BUILD_COMMAND in err


def test_against_refuses_a_preset_without_an_aihwkit_device(cli):
    code, _, err = cli("device", "characterize", "--against", "aihwkit", "--preset", "ideal")
    assert code == 2 and "allowed: pcm, reram" in err
    code, _, err = cli("device", "characterize", "--against", "aihwkit", "--targets", "1")
    assert code == 2 and "--targets" in err


@needs_aihwkit
def test_against_pcm_table_json_and_plot(cli, tmp_path):
    png = tmp_path / "pcm.png"
    code, out, err = cli("device", "characterize", "--against", "aihwkit", "--preset", "pcm",
                         "--devices", "400", "--json", "--plot", png)
    assert code == 0, err
    r = json.loads(out)
    assert r["aihwkit_device"] == "PCMPresetDevice" and r["versions"]["aihwkit"] == "1.1.0"
    assert r["map"] == {"w_min": 0.0, "w_max": 2.0, "g_min_us": 0.0, "g_max_us": 25.0}
    checks = r["by_check"]
    assert checks["pulse"]["rows"] == 18  # 9 targets, up only (SET-only), mean and std
    assert checks["full range"]["rows"] == 1
    assert r["rows_total"] == sum(c["rows"] for c in checks.values())
    assert r["within"] == sum(row["within"] for row in r["rows"])
    # aihwkit's PCM step at 0.5 uS is 3.2 uS (ExpStep, A_up -27.235): the map is right
    first = r["rows"][0]
    assert first["g_us"] == 0.5 and 2.8 < first["aihwkit"] < 3.6
    # the inference model is the same on both sides: drift exponents agree closely
    nu = [row for row in r["rows"] if row["quantity"] == "nu mean"]
    assert len(nu) == 9 and all(row["within"] for row in nu)
    assert png.stat().st_size > 10_000


@needs_aihwkit
def test_against_reram_pulses_both_ways():
    from cml_edge.backends.crossbar.aihwkit.compare import compare

    r = compare("reram", devices=300, max_pulses=3000)
    assert r["aihwkit_device"] == "ReRamSBPresetDevice"
    assert r["by_check"]["pulse"]["rows"] == 36 and "programming" not in r["by_check"]
    # write noise 56 dw_min = 9.8 uS per read after a pulse, programmed noise-free
    stds = [row["aihwkit"] for row in r["rows"] if row["quantity"] == "step std (uS)"]
    assert 8.0 < float(np.median(stds)) < 11.5
    # aihwkit's mean device reaches 90 % of the range in about 1,800 pulses
    assert 1200 < r["aihwkit"]["pulses"]["pulses_to_full_range"]["up"] < 2500
    # under the write noise the means are of the hidden state's step, on both sides: one
    # up pulse at 53.5 uS moves it about 0.33 uS (soft bounds, 0.4 of the way from w 0)
    means = [row for row in r["rows"] if row["quantity"].startswith("mean")]
    assert len(means) == 18 and all(row["quantity"] == "mean step, hidden (uS)"
                                    for row in means)
    first = means[0]
    assert first["g_us"] == 53.5 and first["direction"] == "up"
    assert 0.2 < first["aihwkit"] < 0.45 and 0.2 < first["project"] < 0.45


@needs_aihwkit
def test_aihwkit_presets_map_or_refuse():
    from cml_edge.backends.crossbar.aihwkit.presets import describe
    from cml_edge.backends.crossbar.array import CrossbarArray
    from cml_edge.backends.crossbar.config import make_config

    pcm = make_config("aihwkit:PCMPresetDevice")
    assert (pcm.step_model, pcm.levels, pcm.exp_a_up, pcm.c2c) == ("exp", 201, -27.235,
                                                                   "complex")
    assert pcm.pulse_gain == pytest.approx(3.235)  # aihwkit's weight granularity / dw_min
    reram = describe("aihwkit:ReRamSBPresetDevice")
    assert reram["fields"]["step_model"] == "soft" and reram["fields"]["write_noise"] == 56
    assert "reset_std" in reram["inert"] and not reram["refused"]
    with pytest.raises(InputError, match="lifetime_dtod 0.3"):
        make_config("aihwkit:CapacitorPresetDevice")
    with pytest.raises(InputError, match="OneSidedUnitCell"):
        make_config("aihwkit:PCMPresetUnitCell")
    with pytest.raises(InputError, match="allowed: .*aihwkit:GokmenVlasovPresetDevice"):
        make_config("aihwkit:NoSuchDevice")
    # the device runs in the project's kernels: a pulsed update moves its weights
    rng = np.random.default_rng(0)
    arr = CrossbarArray.from_float(rng.normal(0, 0.1, (8, 4)), seed=1, index=0,
                                   preset="aihwkit:GokmenVlasovPresetDevice")
    before = arr.to_float().copy()
    arr.outer_update(np.full(8, 0.5), np.ones(4), 0.1, False)
    assert not np.array_equal(arr.to_float(), before)


@needs_aihwkit
def test_worker_times_a_training_and_a_planning_step():
    r = runner.run("bench", device="ReRamSBPresetDevice", shapes=[[16, 2], [8, 16]],
                   xs=[[0.3, -0.4], [0.1] * 16], ds=[[0.01] * 16, [0.2] * 8], lrs=[0.01] * 2,
                   seed=0, steps=3, repeats=1)
    assert all(r[f"{s}_{a}_s"] > 0 for s in ("train", "plan") for a in ("public", "bare"))
