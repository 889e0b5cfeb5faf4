"""MovingAI voxel maps and scenarios: read strictly, placed in a cube, shipped and
regenerated."""

from pathlib import Path

import numpy as np
import pytest

from cml_edge.grid.maps import MapFormatError
from cml_edge.grid.voxels import (
    VoxelProblem,
    format_voxel_map,
    format_voxel_scen,
    load_voxel_map,
    load_voxel_scen,
    parse_voxel_map,
    parse_voxel_scen,
    shipped_voxel_maps,
    shipped_voxel_path,
    voxel_distances,
    voxel_pairs,
)


def test_a_voxel_map_round_trips_and_pads_to_a_cube():
    blocked = np.zeros((4, 3, 2), bool)
    blocked[1, 2, 0] = blocked[3, 0, 1] = True
    vmap = parse_voxel_map(format_voxel_map(blocked), "m.3dmap")
    assert (vmap.blocked == blocked).all() and vmap.side == 4
    arena = vmap.arena()
    assert arena.dims == 3 and arena.size == 4
    assert arena.blocked[1, 2, 0] and arena.blocked[3, 0, 1] and not arena.blocked[0, 0, 0]
    assert arena.blocked[:, 3, :].all() and arena.blocked[:, :, 2:].all()  # the padding
    rev = parse_voxel_map("rev_voxel 2 2 2\n0 0 0\n1 1 1\n")
    assert rev.blocked.sum() == 6 and not rev.blocked[0, 0, 0] and not rev.blocked[1, 1, 1]


@pytest.mark.parametrize("text, message", [
    ("", "wrong header ''"),
    ("octile 2 2 2\n", "wrong header 'octile 2 2 2'"),
    ("voxel 2 2\n", "wrong header"),
    ("voxel 2 x 2\n", "not an integer"),
    ("voxel 0 2 2\n", "sides 0 x 2 x 2 are not allowed"),
    ("voxel 1 1 1\n", "sides 1 x 1 x 1"),
    ("voxel 2 2 2\n0 0\n", "line 2: 2 fields, expected 3"),
    ("voxel 2 2 2\n0 2 0\n", "voxel 0 2 0 is off the 2 x 2 x 2 map"),
    ("voxel 2 2 2\n0 -1 0\n", "off the"),
    ("rev_voxel 2 2 2\n0 0 0\n", "fewer than two free voxels"),
])
def test_bad_voxel_maps_are_one_line_errors(text, message):
    with pytest.raises(MapFormatError, match=message) as err:
        parse_voxel_map(text, "bad.3dmap")
    assert "\n" not in str(err.value)


def test_scenarios_of_both_versions():
    name, probs = parse_voxel_scen("version 1\nm.3dmap\n0 0 0 1 1 1 1.7 1.0\n\n")
    assert name == "m.3dmap" and probs == [VoxelProblem((0, 0, 0), (1, 1, 1), 1.7)]
    _, probs = parse_voxel_scen("version 2\nm.3dmap\n0 0 0 1 1 0 1.4 1.0 1.0\n")
    assert probs[0].goal == (1, 1, 0)
    text = format_voxel_scen("m.3dmap", [VoxelProblem((0, 1, 0), (1, 0, 1), 1.5)])
    assert parse_voxel_scen(text)[1] == [VoxelProblem((0, 1, 0), (1, 0, 1), 1.5)]


@pytest.mark.parametrize("text, message", [
    ("version 3\nm.3dmap\n", "wrong header 'version 3'"),
    ("version 1\n", "line 2: expected the map's file name"),
    ("version 1\nm.3dmap\n", "no problems"),
    ("version 1\nm.3dmap\n0 0 0 1 1 1 1.7\n", "line 3: 7 fields, expected 8"),
    ("version 2\nm.3dmap\n0 0 0 1 1 1 1.7 1\n", "8 fields, expected 9"),
    ("version 1\nm.3dmap\n0 0 0 1 1 a 1.7 1\n", "not an integer"),
    ("version 1\nm.3dmap\n0 0 0 1 1 1 x 1\n", "not a number"),
])
def test_bad_voxel_scenarios_are_one_line_errors(text, message):
    with pytest.raises(MapFormatError, match=message):
        parse_voxel_scen(text, "bad.3dscen")


def test_problems_must_fit_the_map():
    vmap = parse_voxel_map("voxel 3 3 3\n1 1 1\n")
    ok = voxel_pairs(vmap, [VoxelProblem((0, 0, 0), (2, 2, 2), 2 * 3 ** 0.5)])
    assert ok.geodesic.tolist() == [3] and ok.chebyshev.tolist() == [2]  # round the centre
    for problem, message in ((VoxelProblem((0, 0, 0), (1, 1, 1), 1.0), "blocked voxel"),
                             (VoxelProblem((0, 0, 3), (2, 2, 2), 1.0), "off the 3 x 3 x 3"),
                             (VoxelProblem((2, 2, 2), (2, 2, 2), 0.0), "starts at its goal")):
        with pytest.raises(MapFormatError, match=message):
            voxel_pairs(vmap, [problem], "s.3dscen")


def test_path_costs_count_faces_edges_and_corners():
    vmap = parse_voxel_map("voxel 3 3 3\n1 1 1\n")
    d = voxel_distances(vmap.arena(), (0, 0, 0))
    assert d[1, 0, 0] == 1.0 and d[1, 1, 0] == pytest.approx(2 ** 0.5)
    assert d[2, 2, 2] == pytest.approx(2 ** 0.5 + 3 ** 0.5 + 1)  # round the blocked centre
    assert np.isinf(d[1, 1, 1])


def test_the_shipped_voxel_maps():
    assert shipped_voxel_maps() == ["floors", "pillars", "shaft"]
    for name in shipped_voxel_maps():
        vmap = load_voxel_map(shipped_voxel_path(name))
        map_name, probs = load_voxel_scen(shipped_voxel_path(name, ".3dscen"))
        assert map_name == f"{name}.3dmap" and vmap.side == 16 and len(probs) == 100
        pairs = voxel_pairs(vmap, probs)
        assert (pairs.geodesic > 0).all()
        cost = np.array([p.cost for p in probs])
        assert (cost >= pairs.geodesic - 1e-9).all()
    with pytest.raises(MapFormatError, match="no shipped voxel map 'nowhere'"):
        shipped_voxel_path("nowhere")


@pytest.mark.slow
def test_make_voxels_regenerates_the_shipped_files(tmp_path):
    from cml_edge.data.make_voxels import main

    main(["--out", str(tmp_path)])
    for name in shipped_voxel_maps():
        for suffix in (".3dmap", ".3dscen"):
            shipped = Path(shipped_voxel_path(name, suffix)).read_text()
            assert (tmp_path / f"{name}{suffix}").read_text() == shipped, name + suffix
