"""The experiments as sweeps, and the command line of sweep, --planner and --map."""

import json

import pytest

from cml_edge import experiments
from cml_edge.cli import main
from cml_edge.grid.maps import shipped_path


def test_task_grids():
    grid = {name: experiments.get(name).tasks(seeds=2) for name in experiments.EXPERIMENTS}
    assert len(grid["hyperparams"]) == 7 * 2  # (100, 900) is shared by both sweeps
    keys = {t.key for t in grid["hyperparams"]}
    assert {"walks100-steps300-s1", "walks25-steps900-s0"} <= keys
    evals = grid["obstacles"][0].params["evals"]
    assert [(e["planner"], e["obstacles"]) for e in evals][:5] == [
        ("paper", n) for n in (0, 100, 200, 300, 400)] and len(evals) == 10
    gen = grid["generalization"][0].params["evals"]
    assert [(e["size"], e["max_steps"]) for e in gen] == [(30, None), (60, None), (120, None)]
    from cml_edge.backends import BACKENDS

    backends = {t.params["backend"] for t in grid["backends"]}
    assert backends == set(BACKENDS)
    only = experiments.get("obstacles").tasks(seeds=1, planner="escape")
    assert {e["planner"] for e in only[0].params["evals"]} == {"escape"}
    maps = experiments.get("maps").tasks(seeds=1)
    assert {t.params["arena"] for t in maps} == {32}


def test_unknown_experiment_and_rejected_options():
    with pytest.raises(ValueError, match="unknown experiment 'fig9'"):
        experiments.get("fig9")
    with pytest.raises(ValueError, match="does not take --map"):
        experiments.get("convergence").tasks(seeds=1, map="rooms")



@pytest.mark.slow
def test_sweep_command_writes_results_and_resumes(tmp_path, cli):
    out = tmp_path / "obst"
    code, stdout, err = cli("sweep", "maps", "--seeds", 1, "--workers", 1,
                            "--map", shipped_path("utrap"), "--scen",
                            shipped_path("utrap", ".map.scen"), "--out", out, "--json")
    assert code == 0, err
    summary = json.loads(stdout)
    rows = {r["planner"]: r for r in summary["rows"]}
    assert rows["paper"]["success_rate_connected"] < 0.5
    assert rows["escape"]["success_rate_connected"] > 0.9
    assert rows["escape"]["max_steps"] == 107
    for name in ("results.json", "results.csv", "figure.png"):
        assert (out / name).stat().st_size > 0
    assert (out / "figure.png").read_bytes()[:4] == b"\x89PNG"
    task = next((out / "tasks").iterdir())
    before = task.stat().st_mtime_ns
    code, stdout2, _ = cli("sweep", "maps", "--seeds", 1, "--workers", 1, "--map",
                           shipped_path("utrap"), "--scen", shipped_path("utrap", ".map.scen"),
                           "--out", out, "--json")
    assert code == 0 and task.stat().st_mtime_ns == before
    assert json.loads(stdout2)["rows"] == summary["rows"]


def test_sweep_into_a_file_exits_2(cli, tmp_path):
    (tmp_path / "afile").write_text("x")
    line = bad(cli, "sweep", "convergence", "--seeds", 1, "--out", tmp_path / "afile")
    assert "is a file (allowed: a folder)" in line


@pytest.fixture(scope="module")
def model(tmp_path_factory):
    path = tmp_path_factory.mktemp("m") / "m32.npz"
    assert main(["train", "--arena", "32", "--seed", "1", "--out", str(path)]) == 0
    return path


@pytest.mark.slow
def test_evaluate_and_navigate_on_a_map(model, cli):
    scen = shipped_path("rooms", ".map.scen")
    res = {}
    for planner in ("paper", "escape"):
        code, out, err = cli("evaluate", model, "--map", shipped_path("rooms"), "--scen",
                             scen, "--planner", planner, "--json")
        assert code == 0, err
        res[planner] = json.loads(out)
    assert res["escape"]["max_steps"] == 107 and res["escape"]["trials"] == 100
    assert res["escape"]["success_rate_connected"] > res["paper"]["success_rate_connected"]
    code, out, _ = cli("navigate", model, "--map", "utrap", "--start", 15, 15,
                       "--goal", 27, 15, "--planner", "escape", "--json")
    nav = json.loads(out)
    assert code == 0 and nav["reached"] and nav["planner"] == "escape"


def test_emulate_with_planner_and_map(cli):
    code, out, err = cli("emulate", "--walks", 20, "--seeds", 1, "--trials", 10,
                         "--map", "utrap", "--planner", "escape", "--path", "factored", "--json")
    assert code == 0, err
    result = json.loads(out)
    assert result["arena"] == 32 and result["planner"] == "escape" and result["max_steps"] == 107
    assert result["map"] == "utrap" and result["connected_pairs"] == 10


def bad(cli, *argv):
    code, out, err = cli(*argv)
    assert code == 2 and out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("cml-edge: error:"), err
    return lines[0]


@pytest.mark.parametrize("argv,needle", [
    (["sweep", "fig9"], "unknown experiment 'fig9'"),
    (["sweep", "obstacles", "--workers", "0"], "'0'"),
    (["sweep", "obstacles", "--seeds", "-1"], "'-1'"),
    (["sweep", "obstacles", "--planner", "astar"], "astar"),
    (["sweep", "maps", "--scen", "x.scen"], "--scen needs --map"),
    (["sweep", "maps", "--map", "nowhere.map"], "does not exist"),
    (["sweep", "convergence", "--map", "rooms"], "does not take --map"),
    (["emulate", "--planner", "astar"], "astar"),
    (["emulate", "--map", "rooms", "--obstacles", "5"], "cannot be combined with --map"),
    (["emulate", "--map", "rooms", "--arena", "40"], "conflicts with --map"),
    (["emulate", "--map", "nowhere"], "no shipped map 'nowhere'"),
    (["emulate", "--scen", "x.scen"], "--scen needs --map"),
])
def test_bad_input_exits_2_with_one_line(cli, tmp_path, monkeypatch, argv, needle):
    monkeypatch.chdir(tmp_path)
    out = ["--out", "o"] if argv[0] == "sweep" else []
    assert needle in bad(cli, *argv, *out)
    assert list(tmp_path.iterdir()) == []


def test_malformed_map_files_exit_2(model, cli, tmp_path):
    ragged = tmp_path / "ragged.map"
    ragged.write_text("type octile\nheight 2\nwidth 3\nmap\n...\n..\n")
    assert "ragged row" in bad(cli, "evaluate", model, "--map", ragged)
    odd = tmp_path / "odd.map"
    odd.write_text("type octile\nheight 2\nwidth 3\nmap\n...\n.x.\n")
    assert "unknown character 'x'" in bad(cli, "evaluate", model, "--map", odd)
    scen = tmp_path / "s.scen"
    scen.write_text("version 1\n0\trooms.map\t32\t32\t10\t0\t0\t0\t1.0\n")
    assert "blocked cell" in bad(cli, "evaluate", model, "--map", "rooms", "--scen", scen)
    assert "--arena 40 cannot be combined" in bad(cli, "evaluate", model, "--map", "rooms",
                                                  "--arena", 40)
    assert "astar" in bad(cli, "evaluate", model, "--planner", "astar")
