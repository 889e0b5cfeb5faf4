import numpy as np

from cml_edge.grid.arena import GridArena
from cml_edge.grid.metrics import Pairs, draw_pairs, e_pos, summarize


def test_pairs_are_fixed_by_seed_distinct_and_free():
    arena = GridArena.with_obstacles(30, 300, seed=1)
    a, b = draw_pairs(arena, 100, 123), draw_pairs(arena, 100, 123)
    assert (a.starts == b.starts).all() and (a.goals == b.goals).all()
    assert not (a.starts == a.goals).all(1).any()
    assert not arena.blocked[a.starts[:, 0], a.starts[:, 1]].any()
    assert not arena.blocked[a.goals[:, 0], a.goals[:, 1]].any()
    assert ((a.geodesic >= a.chebyshev) | (a.geodesic == -1)).all()


def test_summary_by_hand():
    pairs = Pairs(np.array([[0, 0], [0, 0], [5, 5]]), np.array([[3, 0], [4, 4], [9, 5]]),
                  np.array([3, 4, 4]), np.array([3, 4, -1]))
    final = np.array([[3, 0], [4, 4], [6, 9]])
    steps = np.array([3, 6, 100])
    s = summarize(final, steps, pairs)
    assert s["success_rate"] == 2 / 3
    assert s["overhead_mean"] == (1 + 1.5) / 2 and s["overhead_median"] == 1.25
    np.testing.assert_allclose(s["e_pos_mean"], 5.0 / 3)
    assert s["connected_pairs"] == 2 and s["success_rate_connected"] == 1.0
    assert e_pos(final, pairs.goals)[2] == 5.0


def test_no_success_gives_null_overhead():
    pairs = Pairs(np.array([[0, 0]]), np.array([[1, 1]]), np.array([1]), np.array([1]))
    s = summarize(np.array([[0, 0]]), np.array([100]), pairs)
    assert s["overhead_mean"] is None and s["success_rate"] == 0.0


def test_overhead_is_over_the_chebyshev_distance_and_the_geodesic_one_apart():
    """Eq. 9 divides by the Chebyshev distance; with obstacles a second overhead divides by
    the geodesic (BFS) distance. Here a wall makes the geodesic 8 for a Chebyshev 4."""
    pairs = Pairs(np.array([[0, 0], [0, 0]]), np.array([[4, 0], [0, 4]]), np.array([4, 4]),
                  np.array([8, 4]))
    s = summarize(np.array([[4, 0], [0, 4]]), np.array([10, 6]), pairs)
    assert s["success_rate"] == 1.0
    assert s["overhead_mean"] == (10 / 4 + 6 / 4) / 2 and s["overhead_median"] == 2.0
    assert s["overhead_geodesic_mean"] == (10 / 8 + 6 / 4) / 2


def test_a_trial_ending_next_to_its_goal_is_not_a_success():
    """Success is the final position being the goal: one cell off (straight or diagonal)
    is a miss, with its e_pos, and leaves the overhead undefined."""
    goal = np.array([[5, 5]] * 3)
    pairs = Pairs(np.array([[0, 0]] * 3), goal, np.array([5] * 3), np.array([5] * 3))
    final = np.array([[4, 5], [6, 6], [5, 4]])
    s = summarize(final, np.array([100, 100, 100]), pairs)
    assert s["success_rate"] == 0.0 and s["success_rate_connected"] == 0.0
    assert s["overhead_mean"] is None and s["overhead_geodesic_mean"] is None
    np.testing.assert_allclose(s["e_pos_mean"], (2 + np.sqrt(2)) / 3)
