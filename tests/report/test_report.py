"""The hardware-budget report: counts from the formulas, a schema, numbers traceable to JSON."""

import json
import re

import pytest

from cml_edge.core.cml import CML
from cml_edge.costs import dqn as dqn_costs
from cml_edge.costs import ledger
from cml_edge.errors import InputError
from cml_edge.report import build_report, write_report
from cml_edge.report.numbers import human
from cml_edge.report.scorecard import Breakpoint, ScorecardPlan, breakpoint_row


def test_paper_counts_from_real_shapes():
    s = dqn_costs.DQNSettings()
    assert dqn_costs.dqn_parameter_count(s) == 4872 and dqn_costs.dqn_inference_flops(s) == 9472
    cml = CML.create()
    assert cml.parameter_count() == 4608 and cml.inference_flops() == 9464
    assert ledger.factored_accumulators(cml) == 60


def test_memory_by_hand():
    mem = ledger.cml_memory(CML.create(backend="float32"), "mixed", 30)
    assert mem["parameter_bytes"] == 4608 * 4
    assert mem["train_bytes_direct"] == 4608 * 4 * 2 + 900 / 8
    dqn = dqn_costs.dqn_memory(dqn_costs.DQNSettings())
    assert dqn["train_bytes_replay"] == 50_000 * 36
    assert dqn["train_bytes"] == 5 * 4872 * 4 + 50_000 * 36 + 32 * (2 + 256 + 8) * 4


def test_steps_to_converge_uses_the_dqn_criterion():
    from cml_edge.report.build import steps_to_converge

    assert steps_to_converge([10.0, 1.0, 0.3, 0.0], 900) == 3 * 900  # stays within 0.5
    assert steps_to_converge([0.0, 0.6, 0.0], 900) == 3 * 900  # a late excursion counts
    assert steps_to_converge([], 900) is None


def test_energy_is_counted_with_sources_and_never_guessed():
    fp32, fp64 = (ledger.cost_model(CML.create(backend=b)) for b in ("float32", "float"))
    e, sources = ledger.energy_pj(fp32, {"macs": 10, "bytes_read": 8})
    assert e == pytest.approx(10 * 4.6 + 8 * 1.25) and all("Horowitz" in s for s in sources)
    assert (fp32.name, fp64.name) == ("fp32", "fp64")
    assert ledger.energy_pj(fp64, {"macs": 10}) == (None, [])
    analog = ledger.cost_model(CML.create(backend="crossbar"))
    e, sources = ledger.energy_pj(analog, {"analog_macs": 10, "device_pulses": 3,
                                           "refresh_pulses": 1, "macs": 99})
    assert e == 10 * 0.205 + 4 * 64.0 and len(sources) == 2


# the reference report's plan as it was written out by hand before the devices declared it
# (label, backend, options) of the systems; (figure, label, backend, options) of the sweeps;
# (label, backend, options, knob, range, fields, good, integer, log) of the break points
CROSSBAR_PRESETS = ("ideal", "pcm", "reram", "pcm-symmetric", "reram-symmetric")
HAND_SYSTEMS = [("float64", "float", {}), ("float32", "float32", {}), ("int16", "int16", {}),
                ("int8", "int8", {}),
                *[(f"crossbar-{p}", "crossbar", {"preset": p}) for p in CROSSBAR_PRESETS],
                ("loihi2", "loihi2", {})]
HAND_SWEEPS = [
    *[("bits", f"{b} bits {r}", "fixed", {"bits": b, "rounding": r})
      for r in ("stochastic", "nearest") for b in (16, 8, 6, 4)],
    *[("levels", f"pcm {n} levels", "crossbar", {"preset": "pcm", "levels": n})
      for n in (4, 16, 64, 256)],
    *[("read noise", f"pcm read_noise {x:g}", "crossbar", {"preset": "pcm", "read_noise": x})
      for x in (0.05, 0.2, 0.5, 1.0)],
]
HAND_KNOBS = {  # knob: (range, fields, good, integer, log)
    "read_noise": ((0.0, 0.5), ("read_noise",), "low", False, False),
    "prog_noise": ((0.0, 20.0), ("prog_noise",), "low", False, False),
    "levels": ((2, 1001), ("levels",), "high", True, True),
    "drift_time": ((1.0, 3.15576e9), ("idle_s",), "low", False, True),
    "stuck": ((0.0, 0.5), ("stuck_low", "stuck_high"), "low", False, False),
    "adc_bits": ((2, 14), ("adc_bits",), "high", True, False),
}
CROSSBAR_KNOBS = ("read_noise", "prog_noise", "levels", "drift_time", "stuck", "adc_bits")
HAND_BREAKPOINTS = [
    *[(f"crossbar-{p}", "crossbar", {"preset": p}, knob, *HAND_KNOBS[knob])
      for p in ("pcm", "reram") for knob in CROSSBAR_KNOBS],
    *[("crossbar-ideal", "crossbar", {"preset": "ideal"}, knob, *HAND_KNOBS[knob])
      for knob in ("read_noise", "levels", "stuck", "adc_bits")],
    ("fixed", "fixed", {}, "bits", (2, 16), ("bits",), "high", True, False),
    ("loihi2", "loihi2", {}, "bits", (1, 8), ("num_weight_bits",), "high", True, False),
]


def test_the_reference_plan_is_what_the_devices_declare():
    """The same systems, sweeps and break points (each knob's range, fields, direction and
    grid) as the hand-kept lists, in the same order and with the same types (an int range
    stays int in the JSON)."""
    from cml_edge.backends import backend_spec, report_sweeps, report_systems
    from cml_edge.scenarios.breakpoint import get_knob

    plan = ScorecardPlan.of(quick=False)
    assert repr(report_systems()) == repr(plan.devices) == repr(HAND_SYSTEMS)
    assert repr(report_sweeps()) == repr(HAND_SWEEPS)
    derived = []
    for b in plan.breakpoints:
        k = get_knob(b.knob, backend_spec(b.backend).device.name)
        assert b.scenario == "paper" and b.value_range is None
        derived.append((b.device, b.backend, b.options, b.knob, (k.lo, k.hi), k.fields,
                        k.good, k.integer, k.log))
    assert repr(derived) == repr(HAND_BREAKPOINTS)


@pytest.mark.slow
def test_schema(report):
    rep, out = report
    data = json.loads((out / "report.json").read_text())
    for key in ("schema_version", "command", "versions", "protocol", "systems", "costs",
                "sweeps", "generated", "wall_time_s", "scorecard", "breakpoints", "recovery"):
        assert key in data
    labels = [s["label"] for s in data["systems"]]
    assert labels == ["float32", "DQN-simplified", "DQN-tailored", "DQN-goal-conditioned"]
    for s in data["systems"]:
        for key in ("success_rate", "e_pos_mean", "overhead_mean", "parameters",
                    "parameter_bytes", "train_bytes_direct", "update_bytes_per_run_direct",
                    "update_bytes_per_step_direct", "energy_per_run_uj", "train_wall_s"):
            assert key in s
    assert [w["label"] for w in data["sweeps"]] == ["pcm read_noise 0.2"]
    for png in ("convergence.png", "accuracy.png", "memory_traffic.png", "trajectories.png",
                "sweeps.png", "scorecard.png", "breakpoints.png", "recovery.png"):
        assert (out / png).read_bytes()[:4] == b"\x89PNG"


@pytest.mark.slow
def test_the_quick_report_runs_every_section_at_the_quick_budget(report):
    from cml_edge.scenarios.registry import BUDGETS

    rep, _ = report
    quick = BUDGETS["quick"]
    assert (rep["protocol"]["walks"], rep["protocol"]["steps"], rep["protocol"]["trials"]) == (
        quick.walks, quick.steps, quick.trials)
    row = rep["systems"][0]
    assert row["trials"] == quick.trials and len(row["curve_e_pos_mean"]) == quick.walks
    assert row["train_steps"] == quick.walks * quick.steps  # the ledger's model too


UNITS = ("", "%", "B", "uJ", "nJ", "pJ", "s", "pulses", "x")  # x: the 3-D section's ratios
"""The units the report's tables print a number of report.json in."""


def _numbers(obj):
    if isinstance(obj, dict):
        for v in obj.values():
            yield from _numbers(v)
    elif isinstance(obj, list):
        for v in obj:
            yield from _numbers(v)
    elif isinstance(obj, (int, float)) and not isinstance(obj, bool):
        yield obj


def _md_cells(md: str) -> list[str]:
    return [c.strip() for line in md.splitlines() if line.startswith("| ")
            for c in line.strip("|").split("|")]


@pytest.mark.slow
def test_every_number_in_the_markdown_tables_is_in_the_json(report):
    """Each number of report.md's tables is a number of report.json as people read it
    (human, in one of the report's units), or the DQN's energy over a CML device's."""
    _, out = report
    data = json.loads((out / "report.json").read_text())
    known = {human(v, u) for v in _numbers(data) for u in UNITS}
    energy = [s["energy_per_run_uj"] for s in data["systems"] if s["energy_per_run_uj"]]
    known |= {human(a / b, "x") for a in energy for b in energy}
    md = (out / "report.md").read_text()
    numbers = [c for c in _md_cells(md) if re.fullmatch(r"-?[0-9][0-9.,e+-]*( \S+)?", c)]
    assert numbers and all(n in known for n in numbers), [n for n in numbers if n not in known]


def test_the_reference_markdown_has_no_exponent_for_a_count_or_a_size(reference_page):
    """report.md's counts and byte sizes read in full, with SI prefixes or in words; only a
    weight error at float64 rounding keeps an exponent."""
    md = (reference_page / "report.md").read_text()
    assert "e+" not in md
    tables = [line for line in md.splitlines() if line.startswith("| ")]
    exponents = [c for line in tables for c in _md_cells(line) if re.search(r"\de-", c)]
    assert exponents and all(re.fullmatch(r"\d\.\d\de-\d\d", c) for c in exponents)
    assert "| 36.9 kB |" in md and "| 100 % |" in md


@pytest.mark.slow
def test_interrupted_report_leaves_nothing(tmp_path, monkeypatch, report):
    rep, _ = report
    import cml_edge.report.render as render

    def boom(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(render, "render_markdown", boom)
    with pytest.raises(KeyboardInterrupt):
        write_report(rep, tmp_path / "r")
    assert list(tmp_path.iterdir()) == []


def test_report_refuses_a_missing_dqn_results_file(tmp_path, capsys):
    from cml_edge.cli import main

    assert main(["report", "--quick", "--out", str(tmp_path / "r"),
                 "--dqn-results", str(tmp_path / "none.json")]) == 2
    assert "no such file" in capsys.readouterr().err and not (tmp_path / "r").exists()


@pytest.mark.slow
def test_scorecard_sections(report):
    rep, _ = report
    card = rep["scorecard"]
    stable = {"device", "scenario", "success_rate", "overhead_mean", "weight_error",
              "decision_agreement", "seeds"}
    assert all(stable <= set(r) and r["seeds"] == 2 for r in card)
    cells = {(r["device"], r["scenario"], r["part"]) for r in card}
    parts = ["paper"] + [f"K{k}" for k in (0, 1, 2, 5, 10, 20)]
    assert cells == {(d, "paper" if p == "paper" else "recovery", p)
                     for d in ("float32", "crossbar-pcm") for p in parts}
    float32 = {r["part"]: r for r in card if r["device"] == "float32"}
    assert 0 < float32["paper"]["weight_error"] < 1e-3  # float32 rounding, not zero
    rec = rep["recovery"]
    assert {"device", "walks", "success_rate", "pulses", "energy_uJ"} <= set(rec[0])
    pcm = {r["walks"]: r for r in rec if r["device"] == "crossbar-pcm"}
    assert sorted(pcm) == [0, 1, 2, 5, 10, 20]
    assert pcm[0]["pulses"] == 0 and 0 < pcm[1]["pulses"] < pcm[20]["pulses"]
    assert 0 < pcm[1]["energy_uJ"] < pcm[20]["energy_uJ"]
    assert all(r["pulses"] == 0 and r["writes"] > 0 for r in rec
               if r["device"] == "float32" and r["walks"] > 0)
    (bp,) = rep["breakpoints"]  # the tiny budget fails at the good end: no bracket
    assert {"device", "knob", "scenario", "value", "target", "seeds"} <= set(bp)
    assert bp["value"] is None and bp["note"].startswith("no break point within")


@pytest.mark.slow
def test_breakpoint_row_bracketed():
    row = breakpoint_row(Breakpoint("fixed", "fixed", {}, "bits", value_range=(2, 16)),
                         ScorecardPlan(2, "quick", 2, workers=1))
    assert row["value"] in [e["value"] for e in row["evaluations"]]
    ok = {e["value"]: e["success_rate"] >= row["target"] for e in row["evaluations"]}
    assert ok[row["bracket"][0]] and not ok[row["bracket"][1]]


def test_the_devices_cost_models_price_the_reference_report_to_the_last_bit():
    """The energy and counted FLOPs of every CML system of the committed reference report,
    recomputed from its counters with each device's declared cost model."""
    from pathlib import Path

    from cml_edge.backends import backend_spec
    from cml_edge.report.build import counted_flops

    path = Path(__file__).parents[2] / "hw_reports" / "reference" / "report.json"
    systems = [s for s in json.loads(path.read_text())["systems"] if s["kind"] == "cml"]
    assert len(systems) == 10
    for s in systems:
        device = backend_spec(s["backend"]).device
        model = device.cost_model(device.make_config(
            **{**device.backend_options(s["backend"]), **s["options"]}))
        train, sources = ledger.energy_pj(model, s["train_counters"])
        plan, _ = ledger.energy_pj(model, s["plan_counters"])
        assert (None if train is None else train / 1e6) == s["energy_per_run_uj"], s["label"]
        assert (None if plan is None else plan / s["plan_steps"] / 1e3) == \
            s["energy_per_action_nj"], s["label"]
        assert sources == s["energy_sources"], s["label"]
        assert counted_flops(ledger.counted_macs(model, s["plan_counters"]),
                             s["plan_steps"]) == s["inference_flops_counted"], s["label"]


SMALL = {"quick": True, "systems": [("float32", "float32", {})], "sweeps": [],
         "scorecard": ScorecardPlan(2, "tiny", 2, devices=[("float32", "float32", {})],
                                    scenarios=("paper", "clutter"), breakpoints=(
                                        Breakpoint("float32", "float32", {}, "drift_time"),),
                                    workers=1),
         "space": False}  # the 3-D section's tasks: tests/report/test_report_space.py


def _measured(rep):
    """The report without its times and date."""
    skip = {"generated", "wall_time_s", "train_wall_s", "protocol_wall_s"}
    return {k: v if k != "systems" else [{a: b for a, b in s.items() if a not in skip}
                                         for s in v]
            for k, v in rep.items() if k not in skip}


@pytest.mark.slow
def test_a_killed_report_resumes_from_its_finished_tasks(tmp_path):
    ran = build_report(folder=tmp_path, **SMALL)
    files = sorted((tmp_path / "tasks").glob("*.json"))
    assert len(files) == 2 + 1 + 2 + 2 * 2  # protocol seeds, operations, models, two ends
    for f in files[::2]:
        f.unlink()
    seen = []
    again = build_report(folder=tmp_path, progress=lambda *s: seen.append(s), **SMALL)
    assert _measured(again) == _measured(ran)
    first = {}
    for stage, done, total in seen:  # each stage's first call: the tasks kept
        first.setdefault(stage, total - done)
    assert sum(first.values()) == len(files[::2])  # only the removed tasks ran again
    assert list(first) == ["systems", "scorecard", "breakpoints, round 1"]  # a bar a round
    with pytest.raises(InputError, match="other settings"):
        build_report(folder=tmp_path, **{**SMALL, "quick": False})
    assert _measured(build_report(folder=tmp_path, restart=True, **SMALL)) == _measured(ran)


@pytest.mark.slow
def test_the_report_on_dask_gives_the_pools_numbers(tmp_path):
    pytest.importorskip("distributed")
    from distributed import LocalCluster

    on_pool = build_report(workers=2, **SMALL)
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                      dashboard_address=None) as cluster:
        on_dask = build_report(scheduler=cluster.scheduler_address, folder=tmp_path, **SMALL)
    assert _measured(on_dask) == _measured(on_pool)


def test_tasks_are_grouped_by_the_kernels_they_compile():
    from cml_edge.engine.sweep import Task
    from cml_edge.report.batch import device_group

    def group(backend, seed, world="grid"):
        return device_group(Task(f"{backend}-{world}-s{seed}", "cml_edge.scenarios.tasks:x",
                                 {"world": world, "backend": backend, "seed": seed}))

    assert group("int8", 0)[0] != group("int16", 0)[0]  # kernels of their own number type
    assert group("float", 0)[0] != group("float32", 0)[0]
    assert group("crossbar", 0) == group("crossbar", 1)  # two seeds of one run
    assert group("int8", 0)[1] == group("int16", 1)[1]  # one kind of run
    assert group("crossbar", 0)[1] != group("crossbar", 0, "robot")[1]
