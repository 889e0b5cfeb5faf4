"""IBM aihwkit in the loop: ``device characterize --against aihwkit`` and its verdict, the
snapshot ``--preset aihwkit:NAME`` runs from held to aihwkit's live parameters, the
devices it draws held to aihwkit's, and the worker's timing task, at small sizes, in
aihwkit's own environment (``bash scripts/aihwkit_env.sh``; the tests marked ``aihwkit``
are skipped, with the reason, where it is not built). The presets by name without
aihwkit: ``test_aihwkit_presets.py``."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from cml_edge.backends.crossbar.aihwkit import runner, snapshot

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
    code, _, err = cli("device", "characterize", "--against", "aihwkit", "--preset",
                       "aihwkit:PCMPresetDevice", "--devices", "10")
    assert code == 2 and runner.BUILD_COMMAND in err


def test_against_refuses_a_preset_without_an_aihwkit_device(cli):
    code, _, err = cli("device", "characterize", "--against", "aihwkit", "--preset", "ideal")
    assert code == 2 and "allowed: pcm, reram" in err
    code, _, err = cli("device", "characterize", "--against", "aihwkit", "--targets", "1")
    assert code == 2 and "--targets" in err


@needs_aihwkit
def test_against_pcm_table_json_and_plot(cli, tmp_path):
    # aihwkit's side is unseeded (its tiles draw from their own generators), a fresh draw
    # every run: at 400 devices 122 to 125 of the 136 rows were within 10 % in four runs,
    # about the 90 % required (122.4); at 2,000, 132.
    png = tmp_path / "pcm.png"
    code, out, err = cli("device", "characterize", "--against", "aihwkit", "--preset", "pcm",
                         "--devices", "2000", "--json", "--plot", png)
    assert code == 0, err
    r = json.loads(out)
    assert r["aihwkit_device"] == "PCMPresetDevice" and r["versions"]["aihwkit"] == "1.1.0"
    assert r["passed"] is True and r["required"] == 0.9
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
    # up pulse at 53.5 uS moves it 0.337 uS (soft bounds, 0.4 of the way from w 0). The
    # bounds come from aihwkit's own devices: the hidden steps of 204,800 of its devices
    # at that point (tiles of 4,096) have mean 0.3375 and std 0.614 uS; 100,000 draws of
    # 300 of them gave means 0.035 uS apart (std / sqrt(300)), a std of 0.478..0.795 uS,
    # |mean - 0.3375| beyond 3 standard errors (the draw's own std / sqrt(300)) in 0.26 %
    # of draws, beyond 4 in 0.005 %, never beyond 5 (at most 4.23). So each side's mean
    # is held to 5 of its own standard errors, not to a fixed 0.2..0.45, which one run in
    # ~6,000 leaves (a 0.4655 did); aihwkit's side is unseeded (its tiles draw from their
    # own generators), so it is a fresh draw every run
    means = [row for row in r["rows"] if row["quantity"].startswith("mean")]
    assert len(means) == 18 and all(row["quantity"] == "mean step, hidden (uS)"
                                    for row in means)
    first = means[0]
    assert first["g_us"] == 53.5 and first["direction"] == "up"
    theirs = r["aihwkit"]["pulses"]["pulses"][0]["hidden_std"] * 175.0 / 2.0  # uS
    ours = r["project"]["pulses"][0]["hidden_step_std_us"]
    for got, std in ((first["aihwkit"], theirs), (first["project"], ours)):
        assert 0.4 < std < 0.9 and abs(got - 0.3375) < 5 * std / math.sqrt(300)


@needs_aihwkit
def test_a_failed_verdict_exits_1_after_printing_the_full_result(cli):
    # the project's side with twice aihwkit's step: every mean and std row off by 2x
    code, out, err = cli("device", "characterize", "--against", "aihwkit", "--preset",
                         "aihwkit:GokmenVlasovPresetDevice", "--set", "pulse_step=0.0016",
                         "--devices", "200", "--json")
    assert code == 1 and err.count("\n") == 1
    assert "rows of preset 'aihwkit:GokmenVlasovPresetDevice' within 10%, fewer than the " \
           "90% required" in err
    r = json.loads(out)
    assert r["passed"] is False and r["within"] < 0.9 * r["rows_total"] and r["rows"]
    code, out, _ = cli("device", "characterize", "--against", "aihwkit", "--preset",
                       "aihwkit:GokmenVlasovPresetDevice", "--devices", "2000")
    assert code == 0 and "passed (at least 90% required)" in out


@needs_aihwkit
def test_the_snapshot_is_aihwkit_s_live_parameters():
    """``cml_edge/data/aihwkit_presets.json`` equals what aihwkit gives now (else rerun
    ``python -m cml_edge.backends.crossbar.aihwkit.snapshot``)."""
    live, kept = snapshot.take(), snapshot.load()
    for key in ("aihwkit", "presets", "classes", "command"):
        assert live[key] == kept[key], key


@needs_aihwkit
@pytest.mark.parametrize("name", [n for n in snapshot.load()["presets"]
                                  if not n.endswith("UnitCell")])
def test_each_device_is_drawn_as_aihwkit_draws_it(name):
    """The device-to-device parameters of 20,000 devices (bounds, step scales, reference,
    decay scale; in weight units) at aihwkit's quantiles 10, 50 and 90 %, within 5 % of
    aihwkit's 10-90 % spread (the quantiles' sampling error is under 1 %)."""
    from cml_edge.backends.crossbar.aihwkit.presets import PREFIX, describe
    from cml_edge.backends.crossbar.array import CrossbarArray
    from cml_edge.backends.crossbar.codes import AUX_DECAY, AUX_REF

    qs = [0.1, 0.5, 0.9]
    theirs = runner.run("population", device=name, devices=20_000, quantiles=qs)
    arr = CrossbarArray.from_float(np.zeros((20_000, 1)), seed=4, index=0,
                                   preset=PREFIX + name, w_max_q=1.0)
    st, P, m = arr.state, arr.state.params, describe(PREFIX + name)["map"]
    per_w = (P.g_max - P.g_min) / (m["w_max"] - m["w_min"])
    g0 = P.g_min + P.step_center * (P.g_max - P.g_min)
    ours = {"max_bound": (st.bnd[1] - g0) / per_w, "min_bound": (st.bnd[0] - g0) / per_w,
            "dwmin_up": st.step[0] * P.dP / per_w, "dwmin_down": st.step[1] * P.dP / per_w,
            "decay_scales": st.aux[AUX_DECAY] if P.lifetime > 0 else np.ones(20_000)}
    if "reference" in theirs:
        ours["reference"] = st.aux[AUX_REF] / per_w
    for key, values in ours.items():
        want = theirs[key]["quantiles"]
        got = np.quantile(values, qs)
        assert np.abs(got - want).max() <= 0.05 * (want[2] - want[0]) + 1e-6, (key, got, want)


@needs_aihwkit
def test_worker_times_a_training_and_a_planning_step():
    r = runner.run("bench", device="ReRamSBPresetDevice", shapes=[[16, 2], [8, 16]],
                   xs=[[0.3, -0.4], [0.1] * 16], ds=[[0.01] * 16, [0.2] * 8], lrs=[0.01] * 2,
                   seed=0, steps=3, repeats=1)
    assert all(r[f"{s}_{a}_s"] > 0 for s in ("train", "plan") for a in ("public", "bare"))
