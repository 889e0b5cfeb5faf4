"""The command line: the JSON keys the README's command tour promises, saved models that
load back, and one-line errors with exit status 2 for bad input."""

import json
import zipfile

import numpy as np
import pytest

from cml_edge.core.model_file import FORMAT_VERSION, load_model, save_model

SMALL = ["--arena", "10", "--walks", "4", "--steps", "60"]



@pytest.fixture
def model(tmp_path, cli):
    path = tmp_path / "m.npz"
    code, out, err = cli("train", *SMALL, "--seed", 1, "--out", path, "--json")
    assert code == 0, err
    result = json.loads(out)
    assert result["model"] == str(path) and result["path"] == "factored"
    return path


def test_train_evaluate_navigate(model, tmp_path, cli):
    code, out, _ = cli("evaluate", model, "--trials", 20, "--json")
    assert code == 0
    result = json.loads(out)
    for key in ("backend", "seeds", "trials", "success_rate", "e_pos_mean", "e_pos_median",
                "overhead_mean", "overhead_median"):
        assert key in result
    assert result["trials"] == 20 and result["arena"] == 10
    png = tmp_path / "nav.png"
    code, out, _ = cli("navigate", model, "--start", 1, 1, "--goal", 8, 6, "--plot", png,
                       "--json")
    assert code == 0
    nav = json.loads(out)
    assert nav["path"][0] == [1, 1] and len(nav["path"]) == nav["steps"] + 1
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_compute_path_and_trajectory_keys(tmp_path, cli):
    code, out, _ = cli("train", *SMALL, "--out", tmp_path / "m.npz", "--json")
    trained = json.loads(out)
    assert trained["compute_path"] == trained["path"] == "factored"
    code, out, _ = cli("evaluate", tmp_path / "m.npz", "--trials", 5, "--path", "direct",
                       "--json")
    evaluated = json.loads(out)
    assert evaluated["compute_path"] == evaluated["path"] == "direct"
    code, out, _ = cli("navigate", tmp_path / "m.npz", "--start", 0, 0, "--goal", 5, 5,
                       "--json")
    nav = json.loads(out)
    assert nav["trajectory"] == nav["path"] and nav["trajectory"][0] == [0, 0]
    assert nav["compute_path"] == "factored"
    code, out, _ = cli("navigate", tmp_path / "m.npz", "--start", 0, 0, "--goal", 5, 5)
    assert code == 0 and "trajectory (x,y):\n    0,0 " in out and "factored path" in out
    code, out, _ = cli("emulate", *SMALL, "--seeds", 1, "--trials", 5, "--json")
    emulated = json.loads(out)
    assert emulated["compute_path"] == emulated["path"] == "direct"


def test_saved_model_round_trip(model):
    cml, record = load_model(model)
    assert record["walks"] == 4 and record["arena"] == 10
    assert cml.config.obs_scale == 10.0 and cml.backend == "float"


def test_emulate_json_has_the_contract_keys(cli):
    code, out, _ = cli("emulate", *SMALL, "--seeds", 2, "--trials", 10, "--json")
    assert code == 0
    result = json.loads(out)
    for key in ("backend", "seeds", "trials", "success_rate", "e_pos_mean", "e_pos_median",
                "overhead_mean", "overhead_median", "counters"):
        assert key in result
    assert result["seeds"] == 2 and result["counters"]["matvecs"] > 0


def bad(cli, *argv):
    code, out, err = cli(*argv)
    assert code == 2 and out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("cml-edge: error:"), err
    assert "Traceback" not in err
    return lines[0]


@pytest.mark.parametrize("argv,needle", [
    (["train", "--arena", "1", "--out", "x.npz"], "'1'"),
    (["train", "--arena", "nan", "--out", "x.npz"], "'nan'"),
    (["train", "--walks", "2.5", "--out", "x.npz"], "'2.5'"),
    (["train", "--steps", "-4", "--out", "x.npz"], "'-4'"),
    (["train", "--explore", "greedy", "--out", "x.npz"], "greedy"),
    (["train", "--backend", "gpu", "--out", "x.npz"], "unknown backend 'gpu'"),
    (["emulate", "--trials", "0"], "'0'"),
    (["emulate", "--drift-time", "-1"], "outside the range"),
    (["emulate", "--drift-time", "inf"], "'inf'"),
    (["emulate", "--backend", "float", "--bits", "5"], "--bits is an option of the fixed"),
    (["emulate", "--backend", "int8", "--levels", "16"], "--levels is an option of the crossbar"),
])
def test_bad_input_exits_2_with_one_line(cli, tmp_path, monkeypatch, argv, needle):
    monkeypatch.chdir(tmp_path)
    assert needle in bad(cli, *argv)
    assert not (tmp_path / "x.npz").exists()


def test_bad_seed_and_output_paths_exit_2_before_any_work(model, cli, tmp_path):
    (tmp_path / "afile").write_text("x")
    before = sorted(tmp_path.iterdir())
    assert "--seed: '9223372036854775808' is beyond int64" in \
        bad(cli, "train", *SMALL, "--seed", 2**63, "--out", tmp_path / "x.npz")
    assert "--out" in bad(cli, "train", *SMALL, "--out", tmp_path) and \
        "is a folder" in bad(cli, "train", *SMALL, "--out", tmp_path)
    assert "which is a file" in bad(cli, "train", *SMALL, "--out", tmp_path / "afile" / "x.npz")
    assert "which is a file" in bad(cli, "emulate", *SMALL, "--out",
                                    tmp_path / "afile" / "x.json")
    assert "is a folder" in bad(cli, "navigate", model, "--start", 1, 1, "--goal", 2, 2,
                                "--plot", tmp_path)
    assert "is a folder, not a file" in bad(cli, "evaluate", tmp_path)
    assert sorted(tmp_path.iterdir()) == before


@pytest.mark.parametrize("start,goal,needle", [
    ((1, 1), (10, 3), "--goal 10 3 is off"),
    ((-1, 0), (3, 3), "--start -1 0 is off"),
])
def test_navigate_off_arena(model, cli, start, goal, needle):
    assert needle in bad(cli, "navigate", model, "--start", *start, "--goal", *goal)


def test_navigate_onto_obstacle(model, cli):
    from cml_edge.grid.arena import GridArena

    arena = GridArena.with_obstacles(10, 30, seed=123)
    x, y = np.argwhere(arena.blocked)[0]
    line = bad(cli, "navigate", model, "--obstacles", 30, "--start", x, y, "--goal", 0, 0)
    assert "on an obstacle" in line


def test_missing_corrupted_foreign_and_future_models(tmp_path, cli, model):
    assert "does not exist" in bad(cli, "evaluate", tmp_path / "none.npz")
    junk = tmp_path / "junk.npz"
    junk.write_bytes(b"not a zip at all")
    assert "not a readable" in bad(cli, "evaluate", junk)
    foreign = tmp_path / "foreign.npz"
    np.savez(foreign, weights=np.ones(3))
    assert "not a cml-edge model" in bad(cli, "evaluate", foreign)
    with zipfile.ZipFile(model) as z:
        members = {n: z.read(n) for n in z.namelist()}
    cut = tmp_path / "cut.npz"
    with zipfile.ZipFile(cut, "w") as z:
        for name, data in members.items():
            if not name.startswith("W_v/W"):
                z.writestr(name, data)
    assert "corrupted" in bad(cli, "evaluate", cut)
    cml, record = load_model(model)
    future = tmp_path / "future.npz"
    with np.load(model) as z:
        data = {k: z[k] for k in z.files}
    data["format_version"] = np.array(FORMAT_VERSION + 1)
    np.savez(future, **data)
    assert "format version" in bad(cli, "evaluate", future)
    cml.W_q.state.W[0, 0] = np.nan
    nan_model = tmp_path / "nan.npz"
    save_model(nan_model, cml, record)
    assert "non-finite" in bad(cli, "evaluate", nan_model)


def test_interrupted_write_leaves_nothing(tmp_path):
    from cml_edge.io.files import atomic_write

    target = tmp_path / "out.json"

    def explode(f):
        f.write(b"half")
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        atomic_write(target, explode)
    assert list(tmp_path.iterdir()) == []
