"""``timings`` in the long commands' JSON and ``--profile``'s table on stderr: their
structure and consistency, never a duration."""

import json

from cml_edge.cli.output import PROFILE_ROWS

EMULATE = ["emulate", "--backend", "float", "--seeds", 1, "--walks", 2, "--steps", 50,
           "--trials", 5]
EPS = 1e-3


def _check(t):
    assert set(t) == {"stages", "wall_s", "cpu_s", "compile_s"}
    assert min(t["wall_s"], t["cpu_s"], t["compile_s"]) >= 0
    for s in t["stages"]:
        assert set(s) == {"name", "calls", "wall_s", "cpu_s", "compile_s"}
        assert s["calls"] >= 1 and min(s["wall_s"], s["cpu_s"], s["compile_s"]) >= 0
        assert s["compile_s"] <= s["wall_s"] + EPS
    top = sum(s["wall_s"] for s in t["stages"] if "/" not in s["name"])
    assert top <= t["wall_s"] + EPS and t["compile_s"] <= t["wall_s"] + EPS


def test_emulate_json_has_its_stages(cli):
    stages = ["train", "train/curve", "evaluate", "twin", "replay"]
    for run in ("first", "again"):
        code, out, err = cli(*EMULATE, "--json")
        assert code == 0, err
        t = json.loads(out)["timings"]
        _check(t)
        names = [s["name"] for s in t["stages"]]
        warm_up = [n for n in names if n.split("/")[0] == "compile"]
        if run == "again":  # the first run's warm-up (a cold cache) left its parts compiled
            assert not warm_up
        assert names == warm_up + stages, run
        assert all(s["calls"] == 1 for s in t["stages"] if s["name"] != "train/curve")


def test_profile_prints_the_longest_stages_on_stderr(cli, tmp_path):
    assert cli(*EMULATE)[0] == 0  # compiled: no warm-up stages in the table below
    code, out, err = cli("--profile", *EMULATE, "--json")
    assert code == 0, err
    json.loads(out)  # stdout stays one JSON object
    lines = err.splitlines()
    assert lines[-7].startswith("profile: ") and " wall, " in lines[-7] and \
        lines[-7].endswith(" compiling")
    assert lines[-6].split() == ["stage", "wall", "CPU", "compile", "share"]
    assert {line.split()[0] for line in lines[-5:]} == {
        "train", "train/curve", "evaluate", "twin", "replay"}
    assert all(line.endswith(" %") for line in lines[-5:])
    model = tmp_path / "m.npz"  # after the command's name, without --json: the table too
    code, out, err = cli("train", "--arena", 10, "--walks", 2, "--steps", 50, "--out", model,
                         "--profile")
    assert code == 0 and out.startswith("train: seed 0"), err
    rows = err.splitlines()[-2:]
    assert {r.split()[0] for r in rows} == {"train", "write"}
    assert len(err.splitlines()) <= PROFILE_ROWS + 3
    code, out, err = cli("train", "--arena", 10, "--walks", 2, "--steps", 50, "--out", model,
                         "--json")
    assert [s["name"] for s in json.loads(out)["timings"]["stages"]] == ["train", "write"]
    assert "profile" not in err
