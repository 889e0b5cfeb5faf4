"""What a person reads: the main job's table, the bench's table, the other commands'
views, and the line on stderr while kernels compile; ``--json`` keeps its keys."""

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
from numba import njit

from cml_edge.bench.timing import ratios
from cml_edge.cli import build_parser
from cml_edge.cli.compiling import announce_compiles, what_compiles
from cml_edge.cli.output import fidelity_rows, num, reference_rows, saturation, show_fields
from cml_edge.cli.tools import show_bench
from cml_edge.engine.warmup import cores
from cml_edge.report.numbers import human
from cml_edge.report.reference import PROTOCOL, context

RUN = ["--seeds", 1, "--trials", 5, "--walks", 5, "--steps", 100]
ROOT = Path(__file__).resolve().parents[2]

# The keys of `cml-edge emulate --json`, as the command printed them before its table
# was written (the table changes no key), and its stages' times (`timings`).
EMULATE_KEYS = {
    "arena", "backend", "backend_options", "cml_edge_version", "command", "compute_path",
    "connected_pairs", "counters", "curve_e_pos_mean", "decision_agreement", "e_pos_mean",
    "e_pos_median", "epoch_walks", "eval_arena", "eval_seed", "explore", "fidelity_twin",
    "idle_s", "max_steps", "obstacles", "overhead_geodesic_mean", "overhead_mean",
    "overhead_median", "path", "per_seed", "planner", "read_snr", "schedule", "seed_list",
    "seeds", "steps", "success_rate", "success_rate_connected", "train_error", "trials",
    "utility", "walks", "wall_time_s", "weight_error", "timings", "costs"}
PER_SEED_KEYS = {
    "seed", "trials", "success_rate", "e_pos_mean", "e_pos_median", "overhead_mean",
    "overhead_median", "connected_pairs", "success_rate_connected", "overhead_geodesic_mean",
    "weight_error", "decision_agreement", "decisions", "decisions_agreed", "read_snr"}
CROSSBAR_COUNTERS = {
    "matvecs", "rmatvecs", "analog_macs", "dac_conversions", "adc_conversions",
    "adc_saturations", "outer_updates", "acc_writes", "line_pulses", "coincidences",
    "device_pulses", "devices_written", "commits", "rng_draws", "refreshes", "refresh_pulses",
    "calibration_reads", "bm_rereads", "pulses_capped"}


def test_the_emulate_table_names_the_preset_and_its_fidelity_on_one_screen(cli):
    code, out, err = cli("emulate", "--backend", "crossbar", *RUN)
    assert code == 0, err
    lines = out.splitlines()
    assert len(lines) <= 24 and max(map(len, lines)) <= 100, out
    assert lines[0].startswith("emulate: 1 seed x 5 trials, 30 x 30 arena")
    rows = {line.split("  ")[1].strip(): line for line in lines[1:]}
    assert "crossbar (preset pcm)" in rows["device"]
    assert re.search(r" %  \([0-5] of 5 trials\)$", rows["success rate"]), out
    for row in ("path overhead", "weight error", "decision agreement", "read SNR",
                "saturation", "verdict", "time"):
        assert row in rows, out
    assert "ADC conversions" in rows["saturation"] and "decisions" in rows["decision agreement"]
    assert "fidelity_twin" not in out and "matvecs" not in out  # no raw dump


def test_emulate_json_keeps_its_keys(cli):
    code, out, err = cli("emulate", "--backend", "crossbar", *RUN, "--json")
    assert code == 0, err
    result = json.loads(out)
    assert set(result) == EMULATE_KEYS
    assert set(result["per_seed"][0]) == PER_SEED_KEYS
    assert set(result["counters"]) == CROSSBAR_COUNTERS
    assert set(result["weight_error"]) == {"W_q", "W_k", "W_v", "matrix_mean"}
    assert set(result["read_snr"]) == {"W_q", "W_k", "W_v"}
    assert result["backend_options"] == {} and isinstance(result["fidelity_twin"], str)


@pytest.mark.parametrize("backend,device,saturates", [
    ("float", "float", "none (the device does not saturate)"),
    ("int8", "int8", "0 (3 counters: no saturation, clip or wrap)"),
])
def test_the_table_on_other_devices(cli, backend, device, saturates):
    code, out, err = cli("emulate", "--backend", backend, "--arena", 10, "--seeds", 2,
                         "--trials", 5, "--walks", 3, "--steps", 60)
    assert code == 0, err
    assert "2 seeds x 5 trials, 10 x 10 arena" in out
    assert f"device              {device}\n" in out and saturates in out
    if backend == "float":  # the float64 array reads as its twin: no SNR to give
        assert "read SNR            n/a" in out and "e+1" not in out
    else:
        assert " +- " in out  # two seeds: a spread


def test_emulate_on_chips_ends_with_the_table(cli, tmp_path):
    code, out, err = cli("emulate", "--backend", "crossbar", "--arena", 10, "--walks", 3,
                         "--steps", 60, "--trials", 5, "--seeds", 1, "--chips", 2,
                         "--workers", 1, "--chips-out", tmp_path / "c")
    assert code == 0, err
    lines = out.splitlines()
    assert len(lines) <= 24
    assert lines[0] == "emulate: crossbar (preset pcm) on 2 chips (0..1): 1 seed x 5 trials " \
                       "each, 10 x 10 arena"
    assert "yield" in out
    assert any(line.split()[:2] == ["weight", "error"] for line in lines)


def test_numbers_have_sensible_digits():
    """Three significant digits, thousands separators, no exponent for a count or a size:
    the report's formatting (cml_edge.report.numbers)."""
    assert [num(v) for v in (0.37595245132562005, 2.4515, 1192.4, 3.3e15, 4.76e-17, 0.0, 7,
                             6367854592, None)] == [
        "0.376", "2.45", "1,190", "3,300 trillion", "4.76e-17", "0", "7", "6.37 billion",
        "n/a"]
    assert [human(v, u) for v, u in ((36864, "B"), (5303.2, "uJ"), (1.13, "nJ"),
                                     (0.9233, "%"), (1, "%"), (0.99996, "%"),
                                     (3.15576e9, "s"), (130.5, "s"))] == [
        "36.9 kB", "5.3 mJ", "1.13 nJ", "92.3 %", "100 %", "99.996 %", "100 years",
        "2.17 min"]


def test_saturation_reads_the_devices_counters():
    assert saturation({"macs": 5}) == "none (the device does not saturate)"
    assert saturation({"adc_conversions": 1000, "adc_saturations": 5}) == \
        "5 of 1,000 ADC conversions (0.5 %)"
    assert saturation({"acc_saturations": 2, "sign_clips": 1, "neuron_wraps": 0}) == \
        "3: 2 learning-accumulator writes saturated, 1 weights clipped to their sign"
    assert saturation({"saturations": 70}) == "70 weight writes saturated"


PAPER_RUN = {**PROTOCOL, "backend": "crossbar", "backend_options": {}, "success_rate": 1.0,
             "overhead_mean": 1.0, "seeds": 10, "trials": 100,
             "weight_error": {"matrix_mean": {"mean": 0.885, "std": 0.1, "min": 0.7,
                                              "max": 1.0}},
             "decision_agreement": {"mean": 0.794, "std": 0.05, "min": 0.7, "max": 0.9},
             "per_seed": [{"seed": s, "weight_error": {"matrix_mean": 0.8},
                           "decision_agreement": 0.83} for s in range(10)]}


def test_the_fidelity_stands_beside_the_reference_devices():
    """On the paper's protocol, weight error and agreement are placed beside the reference
    report's devices (seeds 0-2) and the run's own mean on those seeds; a verdict names
    what it was judged against."""
    ctx = context(PAPER_RUN)
    assert ctx["own"] == "crossbar-pcm" and not ctx["differs"]
    text = "\n".join(f"{a} {b}" for a, b in fidelity_rows(PAPER_RUN, ctx))
    assert "reference report, seeds 0-2: crossbar-pcm 83.2 %, float32 100 %, int8 82.1 %" \
        in text
    assert "this run on seeds 0-2: 83 %" in text
    verdict = " ".join(b for _, b in reference_rows(PAPER_RUN, ctx))
    assert verdict.startswith("survives: success 100 %, overhead 1, agreement 79.4 %")
    assert "float64 on the same protocol (reference report)" in verdict
    other = {**PAPER_RUN, "walks": 30}
    rows = reference_rows(other, context(other))
    assert "walks 30 (reference: 100)" in " ".join(b for _, b in rows)
    assert "reference report" not in "\n".join(b for _, b in fidelity_rows(other,
                                                                            context(other)))
    worse = {**PAPER_RUN, "success_rate": 0.85}
    assert reference_rows(worse, context(worse))[0][1].startswith(
        "fails: success 85 % (float64 100 %)")


def test_emulate_out_carries_the_timings_its_json_has(cli, tmp_path):
    code, out, err = cli("emulate", "--backend", "int8", *RUN, "--out", tmp_path / "r.json")
    assert code == 0, err
    written = json.loads((tmp_path / "r.json").read_text())
    assert set(written) == EMULATE_KEYS and written["timings"]["stages"]


def _bench_result():
    float_figs = {"train_step_us_random": 0.91234567, "train_step_us_mixed": 0.95,
                  "plan_step_us": 1.2, "train_step_us_factored": 0.2012,
                  "train_total_s_factored": 0.018, "plan_step_us_factored": 0.5}
    fused = {"train_step_us_fused": 0.8, "plan_step_us_fused": 1.0,
             "train_step_us_fused_factored": 0.19}
    int8 = {"train_step_us_random": 2.1234567890123, "train_step_us_mixed": 2.2,
            "plan_step_us": 2.6}
    return {"backends": {"float": float_figs, "int8": int8}, "yardstick": fused,
            "ratios": ratios(float_figs, fused, {"int8": int8}), "repeats": 5, "walks": 100,
            "steps": 900, "settings": []}


def test_the_bench_table(capsys, cli, monkeypatch):
    show_bench(_bench_result())
    out = capsys.readouterr().out
    lines = out.splitlines()
    assert lines[0].startswith("bench: CPU us per step, median of 5 runs")
    assert lines[1].split() == ["backend", "train", "mixed", "plan", "train", "x", "plan", "x",
                                "goal"]
    rows = [line[2:22].strip() for line in lines[2:7]]
    assert rows == ["float", "float factored", "int8", "yardstick (fused)",
                    "yardstick factored"]
    cells = {row: line[22:].split() for row, line in zip(rows, lines[2:7])}
    assert cells["float"] == ["0.912", "0.95", "1.2", "1.14", "1.2", "<=", "1.3", "met"]
    assert cells["float factored"] == ["0.201", "0.5", "1.06", "<=", "1.1", "met"]
    assert cells["int8"] == ["2.12", "2.2", "2.6", "2.33", "2.17", "<=", "2", "missed"]
    assert cells["yardstick factored"] == ["0.19"]
    assert "{" not in out and "2.1234" not in out
    # the command prints the same table; --json the result itself
    import cml_edge.bench.timing as timing

    monkeypatch.setattr(timing, "run_bench", lambda *a, **k: _bench_result())
    code, out2, _ = cli("bench", "--backends", "int8")
    assert code == 0 and out2 == out
    code, out3, _ = cli("bench", "--backends", "int8", "--json")
    assert json.loads(out3) == _bench_result()


def test_train_evaluate_navigate_views(cli, tmp_path):
    model = tmp_path / "m.npz"
    code, out, err = cli("train", "--arena", 10, "--walks", 4, "--steps", 60, "--out", model)
    assert code == 0, err
    assert out.splitlines()[0] == "train: seed 0, 10 x 10 arena, 4 walks x 60 steps (random " \
        "exploration, walk schedule)"
    assert "final training error" in out and "train_error" not in out
    code, out, err = cli("evaluate", model, "--trials", 6)
    assert code == 0, err
    assert out.startswith("evaluate ") and "decision agreement" in out
    assert "n/a (no read error beyond float64 rounding)" in out
    code, out, err = cli("navigate", model, "--start", 0, 0, "--goal", 5, 5)
    assert code == 0, err
    assert out.startswith("navigate: (0, 0) -> (5, 5), paper planner, factored path")
    assert "trajectory (x,y):\n    0,0 " in out


def test_show_fields_labels_and_leaves_the_rest_to_json(capsys):
    show_fields({"report": "r/report.md", "systems": 7, "wall_time_s": 130.5,
                 "actions_per_s": 1234.5678, "grid": list(range(20)), "_private": 1})
    out = capsys.readouterr().out
    assert out.splitlines() == ["  report         r/report.md", "  systems        7",
                                "  wall time      2.17 min", "  actions per s  1,230",
                                "  (--json also gives grid)"]


def test_device_characterize_help_names_crossbar():
    sub = build_parser()._subparsers._group_actions[0].choices["device"]
    char = sub._subparsers._group_actions[0].choices["characterize"]
    text = char.format_help()
    assert "default float" not in text and "the device: crossbar (default" in text


def test_the_compile_notice_is_one_line_at_the_first_compile(capsys):
    args = build_parser().parse_args(["emulate", "--backend", "int8"])

    def add(a, b):
        return a + b

    add.__module__ = "cml_edge.grid.example"  # a cml_edge function not compiled yet
    kernel = njit(add)
    with announce_compiles(args):
        kernel(1, 2)
        kernel(1.0, 2.0)
    err = capsys.readouterr().err
    n = cores()
    assert err == "cml-edge: first run: compiling the int8 kernels and grid loops on " \
                  f"{n} core{'s' * (n > 1)} (1-3 min once, then cached)\n"
    with announce_compiles(args):
        kernel(3, 4)  # compiled: nothing to say
    assert capsys.readouterr().err == ""
    for argv in (["robot", "train", "--out", "r.npz"], ["scenario", "robot"]):
        assert what_compiles(build_parser().parse_args(argv))[0].endswith(" robot loops"), argv


def _run_cold_or_warm(cache: Path, tmp_path: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache), "PYTHONPATH": str(ROOT)}
    code = "import sys; from cml_edge.cli import main; sys.exit(main(sys.argv[1:]))"
    return subprocess.run([sys.executable, "-c", code, "train", "--arena", "5", "--walks",
                           "1", "--steps", "10", "--out", str(tmp_path / "m.npz")],
                          env=env, capture_output=True, text=True, timeout=1800)


@pytest.mark.slow
def test_the_compile_notice_appears_on_a_cold_cache_only(tmp_path):
    cache = tmp_path / "numba"
    cache.mkdir()
    cold = _run_cold_or_warm(cache, tmp_path)
    assert cold.returncode == 0, cold.stderr
    assert "cml-edge: first run: compiling the float kernels and grid loops" in cold.stderr
    warm = _run_cold_or_warm(cache, tmp_path)
    assert warm.returncode == 0, warm.stderr
    assert "compiling" not in warm.stderr and warm.stdout.startswith("train: seed 0")


def test_the_breakpoint_view(capsys):
    from cml_edge.cli.scenario import show_breakpoint

    show_breakpoint({
        "scenario": "paper", "backend": "crossbar", "backend_options": {}, "knob": "levels",
        "field": "levels", "good": "high", "target": 0.95, "value": 9, "bracket": [9, 8],
        "range": [2, 64], "grid": list(range(2, 65)), "seeds": 3, "seed_list": [0, 1, 2],
        "budget": "quick", "part": None, "n_evaluations": 3, "command": "cml-edge ...",
        "evaluations": [{"value": 64, "success_rate": 1.0, "parts": {}},
                        {"value": 2, "success_rate": 0.1, "parts": {}},
                        {"value": 9, "success_rate": 0.96, "parts": {}}]})
    lines = capsys.readouterr().out.splitlines()
    assert lines[0] == "breakpoint: levels (levels) on paper, crossbar (preset pcm); 3 seeds, " \
                       "quick budget"
    assert lines[1].split()[:3] == ["break", "point", "9:"]
    assert [line.split() for line in lines[4:]] == [
        ["levels", "success"], ["2", "10", "%"], ["9", "96", "%"], ["64", "100", "%"]]


def test_the_dqn_view(capsys):
    from cml_edge.cli.dqn import show_dqn

    summary = {"success_rate": 0.5, "overhead_mean": 1.23456, "e_pos_mean": 2.5}
    show_dqn({"config": "simplified", "seeds": 2, "train_steps": 100000, **summary,
              "parameters": 4874, "inference_flops": 9600, "convergence": {"cpu_s": 42.0},
              "cml": {"factored": {**summary, "convergence": {"cpu_s": 0.25}}},
              "convergence_ratio": {"factored": {"wall": 100.0, "cpu": 168.0, "steps": 3.0}}})
    lines = capsys.readouterr().out.splitlines()
    assert lines[0] == "dqn evaluate: simplified, 2 seeds, 100,000 training steps"
    assert lines[2].split() == ["DQN", "50", "%", "1.23", "2.5", "42", "s"]
    assert lines[3].split()[:2] == ["CML", "factored"]
    assert "168 x the CPU time" in lines[-1]


def test_the_sweep_view(capsys):
    from cml_edge.cli.tools import show_sweep

    show_sweep({"experiment": "convergence", "rows": [], "out": "runs/x"})
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].startswith("| ") and lines[-1] == "results: runs/x/results.json, " \
        "results.csv, figure.png"


def test_stage_progress_off_a_terminal_says_each_tenth_once(capsys):
    from cml_edge.cli.tools import StageProgress

    progress = StageProgress("report")
    for done in range(21):
        progress("systems", done, 20)
    progress("scorecard", 3, 3)
    lines = capsys.readouterr().err.splitlines()
    assert [line.split(" (")[0] for line in lines] == [
        *(f"report: systems: {2 * k}/20 tasks" for k in range(11)),
        "report: scorecard: 3/3 tasks"]
