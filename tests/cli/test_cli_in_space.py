"""The grid's commands in three dimensions: train, evaluate, navigate and emulate with
--dims 3 (and --moves face), and the plane's results untouched."""

import pytest

from cml_edge.core.model_file import load_model, save_model
from cml_edge.grid.protocol import Protocol
from cml_edge.grid.training import TrainConfig

SMALL = ["--arena", "6", "--walks", "4", "--steps", "80"]


@pytest.mark.parametrize("moves, actions", [("king", 26), ("face", 6)])
def test_train_evaluate_navigate_in_space(tmp_path, cli, moves, actions, cli_json, cli_bad):
    model = tmp_path / "m3.npz"
    trained = cli_json("train", *SMALL, "--dims", 3, "--moves", moves, "--out", model)
    assert (trained["dims"], trained["moves"]) == (3, moves)
    cml, record = load_model(model)
    assert (cml.config.n_i, cml.config.n_a) == (3, actions)
    assert (record["dims"], record["moves"], record["arena"]) == (3, moves, 6)
    evaluated = cli_json("evaluate", model, "--trials", 12, "--obstacles", 20, "--planner",
                      "escape")
    assert evaluated["trials"] == 12 and (evaluated["dims"], evaluated["moves"]) == (3, moves)
    assert evaluated["decision_agreement"]["mean"] == 1.0  # float: the twin's own decisions
    png = tmp_path / "nav3.png"
    nav = cli_json("navigate", model, "--start", 0, 0, 0, "--goal", 5, 3, 4, "--plot", png)
    assert nav["trajectory"][0] == [0, 0, 0] and len(nav["trajectory"]) == nav["steps"] + 1
    assert nav["chebyshev"] == (5 if moves == "king" else 12)
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    code, out, _ = cli("navigate", model, "--start", 0, 0, 0, "--goal", 5, 3, 4)
    assert code == 0 and "(0, 0, 0) -> (5, 3, 4)" in out and "trajectory (x,y,z):" in out
    assert "is not a cell of the 3-D arena" in cli_bad("navigate", model, "--start", 0, 0,
                                                     "--goal", 1, 1)
    assert "--goal 6 0 0 is off the 6 x 6 x 6 arena" in cli_bad(
        "navigate", model, "--start", 0, 0, 0, "--goal", 6, 0, 0)


def test_voxel_maps_and_emulate_in_space(tmp_path, cli, cli_json):
    from cml_edge.grid.voxels import shipped_voxel_path

    model = tmp_path / "m16.npz"
    cli_json("train", "--arena", 16, "--walks", 6, "--steps", 200, "--dims", 3, "--out",
          model)
    on_map = cli_json("evaluate", model, "--map", "pillars", "--scen",
                   shipped_voxel_path("pillars", ".3dscen"))
    assert on_map["arena"] == 16 and on_map["trials"] == 100 and on_map["map"] == "pillars"
    emulated = cli_json("emulate", *SMALL, "--dims", 3, "--seeds", 2, "--trials", 8)
    assert (emulated["dims"], emulated["moves"], emulated["seeds"]) == (3, "king", 2)
    assert len(emulated["per_seed"]) == 2 and 0.0 <= emulated["success_rate"] <= 1.0
    code, out, _ = cli("emulate", *SMALL, "--dims", 3, "--seeds", 1, "--trials", 4)
    assert code == 0 and "6 x 6 x 6 arena" in out
    plane = cli_json("emulate", *SMALL, "--seeds", 1, "--trials", 4)
    assert "dims" not in plane and "moves" not in plane  # the plane's JSON as before
    from cml_edge.report.reference import differences

    # a volume is never set beside the plane's reference figures
    assert "dims 3 (reference: 2)" in differences(emulated)
    assert not any(d.startswith(("dims", "moves")) for d in differences(plane))


def test_a_model_whose_record_and_shape_disagree_is_refused(tmp_path, cli_json, cli_bad):
    model = tmp_path / "m.npz"
    cli_json("train", *SMALL, "--out", model)
    cml, record = load_model(model)
    save_model(tmp_path / "liar.npz", cml, {**record, "dims": 3})
    line = cli_bad("evaluate", tmp_path / "liar.npz")
    assert "has 2 inputs and 8 actions; a grid model of 3 dimensions with king moves has 3 " \
           "and 26" in line


def test_protocols_of_the_plane_read_as_before():
    plane = Protocol(seeds=(0,), train=TrainConfig(2, 20))
    assert "dims" not in plane.to_dict() and "moves" not in plane.to_dict()
    space = Protocol(seeds=(0,), train=TrainConfig(2, 20), dims=3, moves="face")
    assert Protocol.from_dict(space.to_dict()) == space
    assert space.cml_config().n_i == 3 and space.cml_config().n_a == 6
    for fields, message in (({"dims": 4}, "dims 4"), ({"moves": "queen"}, "unknown moves"),
                            ({"dims": 3, "map": "rooms"}, "rooms")):
        with pytest.raises(Exception, match=message):
            Protocol(**fields).evaluation()
