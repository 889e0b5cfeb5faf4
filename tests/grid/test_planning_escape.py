"""The escape planner: reference == compiled, no loss where the paper's planner succeeds,
and it gets out of traps where the paper's planner halts."""

import numpy as np
import pytest

from cml_edge.backends import make_array
from cml_edge.core.cml import CML, CMLConfig
from cml_edge.grid.arena import MOVES, GridArena
from cml_edge.grid.maps import load_map, load_scen, scenario_pairs, shipped_path, step_budget
from cml_edge.grid.metrics import draw_pairs
from cml_edge.grid.planning import WALL_NEXT, plan
from cml_edge.grid.training import TrainConfig, train


@pytest.fixture(scope="module")
def cml30():
    cml = CML.create(CMLConfig.for_arena(30), seed=0)
    train(cml, GridArena.empty(30), TrainConfig(), seed=0, path="factored")
    return cml


def u_trap(size: int = 30) -> GridArena:
    """A U of walls opening west: bottom at column 20, arms along rows 8 and 21."""
    blocked = np.zeros((size, size), dtype=bool)
    blocked[20, 8:22] = True
    blocked[10:21, 8] = True
    blocked[10:21, 21] = True
    return GridArena(size, blocked)


def reached(res, goals):
    return (res.final == goals).all(1)


def test_wall_table_moves_to_a_ring_neighbour():
    for hand, side in enumerate((1, -1)):
        for d in range(8):
            wall = MOVES[(d + side) % 8] - MOVES[d]  # the last blocked cell seen, from d
            assert (MOVES[WALL_NEXT[hand, d]] == wall).all()
            assert np.abs(wall).sum() == 1  # ring neighbours are 4-adjacent


@pytest.mark.parametrize("arena", [u_trap(), GridArena.with_obstacles(30, 400, 123),
                                   GridArena.with_obstacles(30, 250, 7)],
                         ids=["utrap", "obst400", "obst250"])
def test_reference_equals_direct_and_factored(cml30, arena):
    pairs = draw_pairs(arena, 25, seed=3)
    cml30.reset_counters()
    ref = plan(cml30, arena, pairs.starts, pairs.goals, path="reference", planner="escape")
    ref_counters = cml30.counters()
    cml30.reset_counters()
    direct = plan(cml30, arena, pairs.starts, pairs.goals, path="direct", planner="escape")
    assert cml30.counters() == ref_counters and ref_counters["matvecs"] > 0
    fact = plan(cml30, arena, pairs.starts, pairs.goals, path="factored", planner="escape")
    assert np.array_equal(ref.paths, direct.paths) and np.array_equal(ref.steps, direct.steps)
    assert np.array_equal(fact.final, direct.final)
    assert (fact.paths == direct.paths).all(axis=(1, 2)).mean() >= 0.9


def test_escape_solves_a_u_trap_the_paper_planner_fails(cml30):
    arena = u_trap()
    starts = np.array([[14, 12], [16, 17], [12, 14], [18, 10]])
    goals = np.array([[27, 15], [26, 12], [28, 20], [25, 17]])
    paper = plan(cml30, arena, starts, goals, path="direct", planner="paper")
    escape = plan(cml30, arena, starts, goals, path="direct", planner="escape")
    assert not reached(paper, goals).any()
    assert reached(escape, goals).all()
    for p, n in zip(escape.paths, escape.steps):
        cells = p[: n + 1]
        assert not arena.blocked[cells[:, 0], cells[:, 1]].any()
        assert (np.abs(np.diff(cells, axis=0)).max(1) == 1).all()  # king moves only


@pytest.mark.slow
def test_shipped_utrap_and_rooms(cml30):
    cml = CML.create(CMLConfig.for_arena(32), seed=1)
    train(cml, GridArena.empty(32), TrainConfig(), seed=1, path="factored")
    for name, floor in (("utrap", 0.95), ("rooms", 0.9)):
        grid = load_map(shipped_path(name))
        pairs = scenario_pairs(grid, load_scen(shipped_path(name, ".map.scen")))
        rate = {p: reached(plan(cml, grid.arena(), pairs.starts, pairs.goals,
                                max_steps=step_budget(32), path="factored", planner=p),
                           pairs.goals).mean() for p in ("paper", "escape")}
        assert rate["paper"] < 0.6 and rate["escape"] >= floor, (name, rate)


@pytest.mark.parametrize("obstacles", [0, 100, 200])
def test_no_loss_where_the_paper_planner_succeeds(cml30, obstacles):
    arena = (GridArena.with_obstacles(30, obstacles, 123) if obstacles
             else GridArena.empty(30))
    pairs = draw_pairs(arena, 100, 123)
    paper = plan(cml30, arena, pairs.starts, pairs.goals, path="factored", planner="paper")
    escape = plan(cml30, arena, pairs.starts, pairs.goals, path="factored", planner="escape")
    ok = reached(paper, pairs.goals)
    assert np.array_equal(escape.paths[ok], paper.paths[ok])  # the very same paths
    assert reached(escape, pairs.goals).mean() >= ok.mean()
    if obstacles == 0:
        assert ok.all()


def test_escape_at_400_obstacles_beats_the_paper(cml30):
    arena = GridArena.with_obstacles(30, 400, 123)
    pairs = draw_pairs(arena, 100, 123)
    connected = pairs.geodesic > 0
    rate = {p: reached(plan(cml30, arena, pairs.starts, pairs.goals, path="factored",
                            planner=p), pairs.goals)[connected].mean()
            for p in ("paper", "escape")}
    assert rate["paper"] < 0.8 and rate["escape"] >= 0.9, rate


def test_unknown_planner(cml30):
    with pytest.raises(ValueError, match="unknown planner 'astar'"):
        plan(cml30, GridArena.empty(30), np.array([[0, 0]]), np.array([[3, 3]]), planner="astar")


def zeroed(cml, columns):
    """A copy of the float ``cml`` whose W_v ``columns`` are zero (they read as nothing)."""
    W_v = cml.W_v.to_float()
    W_v[:, columns] = 0.0
    out = CML.create(cml.config, seed=0)
    for dst, W in zip(out.arrays, (cml.W_q.to_float(), cml.W_k.to_float(), W_v)):
        dst.state.W[:] = W
    return out


@pytest.mark.parametrize("columns", [[0, 3], list(range(8))], ids=["some", "all"])
def test_escape_plans_when_columns_of_w_v_read_zero(cml30, columns):
    cml = zeroed(cml30, columns)
    arena = GridArena.with_obstacles(30, 250, 7)
    pairs = draw_pairs(arena, 10, seed=3)
    ref = plan(cml, arena, pairs.starts, pairs.goals, path="reference", planner="escape")
    direct = plan(cml, arena, pairs.starts, pairs.goals, path="direct", planner="escape")
    assert np.array_equal(ref.paths, direct.paths) and np.array_equal(ref.steps, direct.steps)
    assert (direct.steps > 0).all()


@pytest.mark.parametrize("backend, options", [
    ("crossbar", {"preset": "ideal", "adc_bits": 2}),
    ("crossbar", {"preset": "pcm", "adc_bits": 3}),
    ("crossbar", {"preset": "pcm-symmetric", "adc_bits": 2}), ("loihi2", {"num_message_bits": 1})])
def test_escape_on_coarse_reads(cml30, backend, options):
    """Reads coarse enough that W_v's columns round to zero: both planners plan, the
    reference and the compiled loop agree."""
    W = cml30.weights()
    cml = CML(cml30.config, tuple(make_array(backend, W[n], seed=0, index=i, **options)
                                  for i, n in enumerate(("W_q", "W_k", "W_v"))), backend)
    arena = GridArena.with_obstacles(30, 250, 7)
    pairs = draw_pairs(arena, 6, seed=3)
    for planner in ("paper", "escape"):
        ref = plan(cml, arena, pairs.starts, pairs.goals, path="reference", planner=planner)
        direct = plan(cml, arena, pairs.starts, pairs.goals, path="direct", planner=planner)
        assert np.array_equal(ref.paths, direct.paths), planner
