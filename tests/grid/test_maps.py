"""MovingAI maps and scenarios: parsing, conventions, malformed files, shipped maps."""

from pathlib import Path

import numpy as np
import pytest

from cml_edge.grid.maps import (
    MapFormatError,
    format_map,
    load_map,
    load_scen,
    parse_map,
    parse_scen,
    scenario_pairs,
    shipped_maps,
    shipped_path,
    step_budget,
)

GOOD = "type octile\nheight 3\nwidth 4\nmap\n.@..\n..T.\nG..W\n"


def test_parse_indexing_and_characters():
    grid = parse_map(GOOD, "good.map")
    assert (grid.height, grid.width, grid.side) == (3, 4, 4)
    arena = grid.arena()
    assert arena.size == 4
    # blocked[x, y] is the character at row y, column x
    assert arena.blocked[1, 0] and arena.blocked[2, 1] and arena.blocked[3, 2]
    assert not arena.blocked[0, 2]  # 'G' is free
    assert arena.blocked[:, 3].all()  # the padding row y = 3 is blocked
    assert arena.n_obstacles == 3 + 4


def test_tall_map_is_padded_on_the_right():
    grid = parse_map("type octile\nheight 3\nwidth 2\nmap\n..\n.@\n..\n")
    arena = grid.arena()
    assert arena.size == 3 and arena.blocked[2, :].all() and arena.blocked[1, 1]
    assert arena.n_obstacles == 4


def test_format_round_trip():
    blocked = np.random.default_rng(0).random((5, 7)) < 0.3
    assert np.array_equal(parse_map(format_map(blocked)).blocked, blocked)


@pytest.mark.parametrize("text,needle", [
    ("type octile\nheight 3\nwidth 4\n.@..\n..T.\nG..W\n", "wrong header"),
    ("typ octile\nheight 3\nwidth 4\nmap\n.@..\n..T.\nG..W\n", "wrong header"),
    ("type octile\nwidth 4\nheight 3\nmap\n.@..\n..T.\nG..W\n", "wrong header"),
    ("type tile\nheight 3\nwidth 4\nmap\n.@..\n..T.\nG..W\n", "not supported"),
    ("type octile\nheight three\nwidth 4\nmap\n.@..\n..T.\nG..W\n", "not a positive integer"),
    ("type octile\nheight 3\nwidth 4\nmap\n.@..\n..T\nG..W\n", "ragged row"),
    ("type octile\nheight 3\nwidth 4\nmap\n.@..\n..X.\nG..W\n", "unknown character 'X'"),
    ("type octile\nheight 4\nwidth 4\nmap\n.@..\n..T.\nG..W\n", "has 3 rows"),
    ("type octile\nheight 2\nwidth 4\nmap\n.@..\n..T.\nG..W\n", "has 3 rows"),
    ("type octile\nheight 1\nwidth 2\nmap\n@@\n", "fewer than two free cells"),
    ("", "header ends"),
])
def test_malformed_maps_raise_one_line(text, needle):
    with pytest.raises(MapFormatError, match=needle) as info:
        parse_map(text, "bad.map")
    assert "\n" not in str(info.value)


def test_missing_and_binary_files(tmp_path):
    with pytest.raises(MapFormatError, match="does not exist"):
        load_map(tmp_path / "none.map")
    junk = tmp_path / "junk.map"
    junk.write_bytes(b"\xff\xfe\x00binary")
    with pytest.raises(MapFormatError, match="map file .*junk.map' is not ascii text"):
        load_map(junk)


SCEN = "version 1\n0\tgood.map\t4\t3\t0\t0\t3\t0\t3.0\n1 good.map 4 3 0 2 2 2 2.0\n"


def test_scenarios_parse_to_pairs():
    grid = parse_map(GOOD, "good.map")
    scen = parse_scen(SCEN, "good.map.scen")
    assert [s.start for s in scen] == [(0, 0), (0, 2)] and scen[1].bucket == 1
    pairs = scenario_pairs(grid, scen)
    assert pairs.starts.tolist() == [[0, 0], [0, 2]] and pairs.goals.tolist() == [[3, 0], [2, 2]]
    assert pairs.chebyshev.tolist() == [3, 2]
    assert pairs.geodesic.tolist() == [3, 2]  # around (1, 0) through (1, 1): 3 king moves


@pytest.mark.parametrize("text,needle", [
    ("version 2\n", "wrong header"),
    ("0\tgood.map\t4\t3\t0\t0\t3\t0\t3.0\n", "wrong header"),
    ("version 1\n0\tgood.map\t4\t3\t0\t0\t3\t0\n", "8 fields, expected 9"),
    ("version 1\n0\tgood.map\t4\t3\tx\t0\t3\t0\t3.0\n", "not a number"),
    ("version 1\n", "no scenarios"),
])
def test_malformed_scenarios(text, needle):
    with pytest.raises(MapFormatError, match=needle):
        parse_scen(text, "bad.scen")


@pytest.mark.parametrize("line,needle", [
    ("0\tgood.map\t5\t3\t0\t0\t3\t0\t3.0", "for a 5 x 3 map"),
    ("0\tgood.map\t4\t3\t0\t0\t4\t0\t3.0", "off the 4 x 3 map"),
    ("0\tgood.map\t4\t3\t1\t0\t3\t0\t3.0", "on a blocked cell"),
])
def test_scenarios_that_do_not_fit_the_map(line, needle):
    grid = parse_map(GOOD, "good.map")
    with pytest.raises(MapFormatError, match=needle):
        scenario_pairs(grid, parse_scen("version 1\n" + line + "\n"))


def test_step_budget():
    assert [step_budget(n) for n in (10, 30, 32, 60, 120)] == [100, 100, 107, 200, 400]


@pytest.mark.slow
def test_shipped_maps_and_scenarios_are_valid_and_connected():
    assert {"rooms", "utrap", "maze"} <= set(shipped_maps())
    for name in shipped_maps():
        grid = load_map(shipped_path(name))
        scen = load_scen(shipped_path(name, ".map.scen"))
        pairs = scenario_pairs(grid, scen)
        assert len(scen) == 100 and (pairs.geodesic > 0).all()
        octile = np.array([s.optimal_length for s in scen])
        assert (octile >= pairs.chebyshev - 1e-9).all() and (octile >= pairs.geodesic - 1e-9).all()
    with pytest.raises(MapFormatError, match="no shipped map"):
        shipped_path("nowhere")


@pytest.mark.slow
def test_make_maps_regenerates_the_shipped_files(tmp_path, capsys):
    from cml_edge.data.make_maps import main

    main(["--out", str(tmp_path)])
    for name in shipped_maps():
        for suffix in (".map", ".map.scen"):
            shipped = Path(shipped_path(name, suffix)).read_text()
            assert (tmp_path / f"{name}{suffix}").read_text() == shipped, name + suffix
