"""Every file kind the tool reads, written, one field corrupted at random, read again:
refused in one line (InputError) or read, never another exception. A property test over
model files (the record in their ``meta``), run files, task files, DQN results, maps and
scenario files."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from cml_edge.baselines import load_results
from cml_edge.core.cml import CML
from cml_edge.core.model_file import load_model, save_model
from cml_edge.engine.runs import RUN_FILE, open_run
from cml_edge.engine.sweep import Task, load_done, run_sweep, task_path
from cml_edge.errors import InputError
from cml_edge.grid.maps import load_map, load_scen

ROOT = Path(__file__).resolve().parents[2]
MAPS = ROOT / "cml_edge" / "data" / "maps"
SETTINGS = {"run": "property", "seeds": 2}

# values a careless or hostile edit puts in a field: other types, other ranges, non-numbers
ODD = st.sampled_from([None, True, "", "x", "nan", -1, 0, 2**70, 1e308, -1e-308, [], [1, "a"],
                       {}, {"k": None}, "\u0663"])


def paths_of(doc: Any, at: tuple = ()) -> list[tuple]:
    """Every place in a JSON document: a key of an object or an index of a list."""
    found = [at] if at else []
    if isinstance(doc, dict):
        for k, v in doc.items():
            found += paths_of(v, at + (k,))
    elif isinstance(doc, list):
        for i, v in enumerate(doc):
            found += paths_of(v, at + (i,))
    return found


@st.composite
def corrupted(draw, doc: Any) -> Any:
    """``doc`` with the value at one of its places replaced by an odd one (or removed)."""
    doc = json.loads(json.dumps(doc))
    where = draw(st.sampled_from(paths_of(doc)))
    parent = doc
    for key in where[:-1]:
        parent = parent[key]
    if isinstance(parent, dict) and draw(st.booleans()):
        del parent[where[-1]]
    else:
        parent[where[-1]] = draw(ODD)
    return doc


def read_or_refuse(read, *args) -> None:
    """The property: ``read(*args)`` returns, or raises InputError of one line."""
    try:
        read(*args)
    except InputError as exc:
        assert "\n" not in str(exc) and str(exc), repr(exc)


def square(x: int) -> dict:
    return {"x": x, "x2": x * x}


TASKS = [Task(f"t{i}", f"{__name__}:square", {"x": i}) for i in range(2)]
PROPERTY = settings(max_examples=60, deadline=None,
                    suppress_health_check=[HealthCheck.function_scoped_fixture])


@pytest.fixture(scope="module")
def model_meta(tmp_path_factory) -> tuple[dict[str, np.ndarray], dict]:
    path = tmp_path_factory.mktemp("model") / "m.npz"
    record = {"arena": 8, "walks": 2, "steps": 10, "seed": 3, "explore": "random",
              "schedule": "walk"}
    save_model(path, CML.create(backend="int8"), record)
    with np.load(path) as z:
        arrays = {k: z[k] for k in z.files}
    return arrays, json.loads(str(arrays["meta"]))


@PROPERTY
@given(data=st.data())
def test_a_model_file_with_a_corrupted_record(model_meta, tmp_path_factory, data):
    arrays, meta = model_meta
    path = tmp_path_factory.mktemp("m") / "m.npz"
    if data.draw(st.booleans()):  # its record, or the member that says its layout
        arrays = {**arrays, "meta": np.array(json.dumps(data.draw(corrupted(meta))))}
    else:
        arrays = {**arrays, "format_version": np.array(data.draw(ODD))}
    np.savez(path, **arrays)
    read_or_refuse(load_model, path)


@PROPERTY
@given(data=st.data())
def test_a_run_folder_with_a_corrupted_run_or_task_file(tmp_path_factory, data):
    out = tmp_path_factory.mktemp("run")
    run_sweep(TASKS, out, workers=1, settings=SETTINGS)
    name = data.draw(st.sampled_from([RUN_FILE, "tasks/t0.json"]))
    doc = json.loads((out / name).read_text())
    (out / name).write_text(json.dumps(data.draw(corrupted(doc))))
    read_or_refuse(open_run, out, SETTINGS, TASKS)
    done = load_done(out, TASKS[0], SETTINGS)  # a task file is used whole or computed again
    assert done is None or done["result"] == square(0)
    assert task_path(out, "t1").exists()


@PROPERTY
@given(data=st.data())
def test_a_dqn_results_file_with_a_corrupted_field(tmp_path_factory, data):
    doc = json.loads((ROOT / "hw_reports" / "baselines" / "dqn_results.json").read_text())
    path = tmp_path_factory.mktemp("dqn") / "dqn.json"
    path.write_text(json.dumps(data.draw(corrupted(doc))))
    read_or_refuse(load_results, path)


@PROPERTY
@given(data=st.data())
def test_a_map_or_scenario_file_with_a_corrupted_line(tmp_path_factory, data):
    """The text formats: one line of maze.map or its .scen replaced by odd text."""
    name = data.draw(st.sampled_from(["maze.map", "maze.map.scen"]))
    lines = (MAPS / name).read_text().splitlines()
    i = data.draw(st.integers(0, min(len(lines) - 1, 8)))
    lines[i] = data.draw(st.sampled_from(["", "type octile", "height -4", "width 1e9",
                                          "version x", "map", "@@", "1\tm\t9\t9\t0\t0\t1\t1\t1",
                                          "\u0663 \u0663", lines[i] + " 7"]))
    path = tmp_path_factory.mktemp("map") / name
    path.write_text("\n".join(lines) + "\n")
    read_or_refuse(load_map if name.endswith(".map") else load_scen, path)
