"""Run folders that know what they hold: the settings file written first, a run of other
settings refused (naming the first differing setting) unless started over, more seeds
resuming, and task files trusted only when their checksum matches."""

import json

import pytest

from cml_edge import __version__
from cml_edge.engine.runs import RUN_FILE, first_difference, open_run
from cml_edge.engine.sweep import Task, load_done, run_sweep, task_path
from cml_edge.errors import InputError

SETTINGS = {"run": "scenario", "backend": "crossbar",
            "backend_options": {"preset": "pcm"}, "budget": "tiny"}
calls = []


def square(x: int) -> dict:
    calls.append(x)
    return {"x": x, "x2": x * x}


def tasks(n, scale=1):
    return [Task(f"t{i}", f"{__name__}:square", {"x": i * scale}) for i in range(n)]


def sweep(out, n=3, settings=SETTINGS, **kw):
    calls.clear()
    return run_sweep(tasks(n, kw.pop("scale", 1)), out, workers=1, settings=settings, **kw)


def test_the_settings_file_is_written_first(tmp_path):
    with pytest.raises(RuntimeError):
        run_sweep([Task("t0", f"{__name__}:fail")], tmp_path, workers=1, settings=SETTINGS)
    doc = json.loads((tmp_path / RUN_FILE).read_text())
    assert doc == {"format": "cml-edge-run", "cml_edge_version": __version__,
                   "settings": SETTINGS}


def fail() -> None:
    raise RuntimeError("a task that fails")


def test_more_tasks_resume_and_other_settings_are_refused(tmp_path):
    first = sweep(tmp_path)
    assert calls == [0, 1, 2]
    assert sweep(tmp_path, 5) == {**first, "t3": {"x": 3, "x2": 9}, "t4": {"x": 4, "x2": 16}}
    assert calls == [3, 4]  # more seeds: the finished tasks kept
    before = {p.name: p.stat().st_mtime_ns for p in (tmp_path / "tasks").iterdir()}
    other = {**SETTINGS, "backend_options": {"preset": "ideal"}}
    with pytest.raises(InputError, match=r"other settings \(backend_options.preset: 'pcm' "
                                         r"there, 'ideal' now\).*--restart"):
        sweep(tmp_path, settings=other)
    with pytest.raises(InputError, match=r"budget: 'tiny' there, 'quick' now"):
        sweep(tmp_path, settings={**SETTINGS, "budget": "quick"})
    assert calls == []  # refused before any task
    assert before == {p.name: p.stat().st_mtime_ns for p in (tmp_path / "tasks").iterdir()}
    again = sweep(tmp_path, 2, settings=other, restart=True)
    assert calls == [0, 1] and again == {k: first[k] for k in ("t0", "t1")}
    assert sorted(p.name for p in (tmp_path / "tasks").iterdir()) == ["t0.json", "t1.json"]
    assert json.loads((tmp_path / RUN_FILE).read_text())["settings"] == other


def test_a_folder_without_a_settings_file_is_checked_task_by_task(tmp_path):
    run_sweep(tasks(2), tmp_path, workers=1)  # no settings: an older run folder
    with pytest.raises(InputError, match=r"task t1 of another run \(x: 1 there, 10 now\)"):
        sweep(tmp_path, 2, scale=10)
    assert not (tmp_path / RUN_FILE).exists()
    sweep(tmp_path, 2)  # the same tasks: adopted (recomputed, as they carry no settings)
    assert (tmp_path / RUN_FILE).exists()


def test_a_task_file_is_trusted_only_when_its_checksum_matches(tmp_path):
    sweep(tmp_path)
    path = task_path(tmp_path, "t1")
    doc = json.loads(path.read_text())
    assert len(doc["checksum"]) == 64
    doc["result"]["x2"] = 2  # edited to other valid JSON
    path.write_text(json.dumps(doc))
    task_path(tmp_path, "t2").write_text('{"format": "cml-edge-sweep-ta')  # half written
    assert load_done(tmp_path, tasks(3)[1], SETTINGS) is None
    assert sweep(tmp_path)["t1"] == {"x": 1, "x2": 1} and calls == [1, 2]
    # a task file of the same call in a run of other settings does not match either
    assert load_done(tmp_path, tasks(3)[0], SETTINGS) is not None
    assert load_done(tmp_path, tasks(3)[0], {**SETTINGS, "budget": "quick"}) is None


def test_first_difference():
    assert first_difference({"a": 1, "b": {"c": 2}}, {"a": 1, "b": {"c": 2}}) is None
    assert first_difference({"a": 1, "b": {"c": 2}}, {"a": 1, "b": {"c": 3}}) == \
        "b.c: 2 there, 3 now"
    assert first_difference({"a": 1}, {"a": 1, "n": 4}) == "n: not set there, 4 now"
    assert first_difference({"a": 1, "n": 4}, {"a": 1}) == "n: 4 there, not set now"


def test_a_broken_settings_file_is_refused(tmp_path):
    (tmp_path / RUN_FILE).write_text("{")
    with pytest.raises(InputError, match="not a cml-edge run file"):
        open_run(tmp_path, SETTINGS, [])
    open_run(tmp_path, SETTINGS, [], restart=True)


SCENARIO = ["scenario", "paper", "--budget", "tiny"]


def test_a_scenario_run_of_other_settings_is_refused(cli, tmp_path):
    out = tmp_path / "run"
    code, _, err = cli(*SCENARIO, "--seeds", 2, "--out", out, "--json")
    assert code == 0, err
    files = {p: p.stat().st_mtime_ns for p in out.rglob("*")}
    code, _, err = cli("scenario", "paper", "--quick", "--seeds", 4, "--out", out)
    assert code == 2 and err.count("\n") == 1 and "budget: 'tiny' there, 'quick' now" in err
    code, _, err = cli(*SCENARIO, "--backend", "int8", "--out", out)
    assert code == 2 and "backend: 'float' there, 'int8' now" in err, err
    assert files == {p: p.stat().st_mtime_ns for p in out.rglob("*")}  # nothing touched
    code, more, err = cli(*SCENARIO, "--seeds", 3, "--out", out, "--json")  # resumes
    assert code == 0 and json.loads(more)["seeds"] == 3
    code, _, err = cli(*SCENARIO, "--restart", "--seeds", 1, "--budget", "tiny")
    assert code == 2 and "--restart needs --out" in err


def test_emulate_chips_write_only_where_asked(cli, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    small = ["emulate", "--backend", "crossbar", "--arena", 10, "--walks", 2, "--steps", 40,
             "--trials", 4, "--seeds", 1, "--chips", 2, "--workers", 1, "--json"]
    code, out, err = cli(*small)
    assert code == 0, err
    assert json.loads(out)["out"] is None and list(tmp_path.iterdir()) == []
    code, out, err = cli(*small, "--chips-out", "c")
    assert code == 0 and json.loads(out)["out"] == "c"
    code, _, err = cli(*small[:-1], "--eval-seed", 5, "--chips-out", "c")
    assert code == 2 and "protocol.eval_seed: " in err, err
    code, _, err = cli(*small, "--eval-seed", 5, "--chips-out", "c", "--restart")
    assert code == 0, err


@pytest.mark.slow
def test_a_breakpoint_folder_of_other_settings_is_refused_unless_restarted(cli, tmp_path):
    out = tmp_path / "bp"
    bp = ["breakpoint", "--scenario", "paper", "--knob", "bits", "--backend", "fixed",
          "--budget", "tiny", "--range", 4, 8, "--workers", 1, "--out", out, "--json"]
    code, _, err = cli(*bp)
    assert code == 0 and "note: --budget tiny is a smoke test" in err, err
    code, _, err = cli(*bp, "--act-bits", 6)
    last = err.strip().splitlines()[-1]  # after the tiny budget's note
    assert code == 2 and last.startswith("cml-edge: error: ") and "--restart" in last, err
    code, again, err = cli(*bp, "--act-bits", 6, "--restart")
    assert code == 0 and json.loads(again)["knob"] == "bits", err


@pytest.mark.parametrize("blocked", ["tasks", "tasks/t1.json"])
def test_a_run_folder_that_cannot_take_its_task_files_is_refused_before_any_task(
        tmp_path, blocked):
    """``tasks`` a file, or a task's file a folder: refused before the first task runs and
    before the settings file is written (so nothing is left behind)."""
    if blocked == "tasks":
        (tmp_path / "tasks").write_text("")
    else:
        (tmp_path / blocked).mkdir(parents=True)
    with pytest.raises(InputError, match="is a f"):
        sweep(tmp_path)
    assert calls == [] and not (tmp_path / RUN_FILE).exists()
