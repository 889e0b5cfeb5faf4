import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cml_edge.grid.arena import MOVES, NTH_MOVE, POPCOUNT, GridArena, chebyshev, move_masks


def test_moves_are_the_eight_king_moves():
    assert len({tuple(m) for m in MOVES}) == 8
    assert np.abs(MOVES).max() == 1 and not (MOVES == 0).all(axis=1).any()


def test_corner_and_interior_availability():
    arena = GridArena.empty(5)
    assert arena.available((0, 0)).sum() == 3
    assert arena.available((2, 2)).sum() == 8
    assert arena.available((4, 2)).sum() == 5
    for a in np.nonzero(arena.available((0, 0)))[0]:
        assert (MOVES[a] >= 0).all()


def test_obstacles_block_moves_and_are_seeded():
    a = GridArena.with_obstacles(30, 200, seed=7)
    b = GridArena.with_obstacles(30, 200, seed=7)
    c = GridArena.with_obstacles(30, 200, seed=8)
    assert a.n_obstacles == 200
    assert (a.blocked == b.blocked).all() and not (a.blocked == c.blocked).all()
    x, y = np.argwhere(~a.blocked)[0]
    for k, ok in enumerate(a.available((x, y))):
        target = (x + MOVES[k, 0], y + MOVES[k, 1])
        assert ok == a.is_free(target)


@settings(max_examples=30, deadline=None)
@given(st.integers(2, 12), st.integers(0, 2**31 - 1))
def test_move_masks_match_available(n, seed):
    arena = GridArena.with_obstacles(n, min(n * n - 2, n), seed)
    masks = move_masks(arena.free)
    for x in range(n):
        for y in range(n):
            bits = [(masks[x, y] >> a) & 1 for a in range(8)]
            assert bits == arena.available((x, y)).astype(int).tolist()
            assert POPCOUNT[masks[x, y]] == sum(bits)


def test_nth_move_table():
    assert NTH_MOVE[0b10110, 0] == 1 and NTH_MOVE[0b10110, 2] == 4 and NTH_MOVE[0b10110, 3] == -1


def test_geodesic_bfs():
    arena = GridArena.empty(6)
    d = arena.geodesic((0, 0))
    assert d[5, 3] == 5 and (d == chebyshev(np.argwhere(d >= 0), [0, 0]).reshape(6, 6)).all()
    walled = GridArena(6, np.zeros((6, 6), bool))
    walled.blocked[2, :] = True
    d = walled.geodesic((0, 0))
    assert d[4, 4] == -1 and d[1, 5] == 5


@settings(max_examples=40, deadline=None)
@given(st.integers(2, 14), st.integers(0, 2**31 - 1), st.floats(0.0, 0.6))
def test_geodesic_is_the_shortest_path_length(n, seed, density):
    """BFS distances satisfy their definition on cluttered arenas: 0 at the source, and
    every other free cell is 1 + the least distance of its reachable neighbours, or -1
    (unreachable) exactly when no neighbour is reachable; blocked cells stay -1."""
    arena = GridArena.with_obstacles(n, min(n * n - 2, int(density * n * n)), seed)
    free = np.argwhere(~arena.blocked)
    sx, sy = free[seed % len(free)]
    d = arena.geodesic((sx, sy))
    assert d[sx, sy] == 0 and (d[arena.blocked] == -1).all()
    for x, y in free:
        if (x, y) == (sx, sy):
            continue
        near = [d[x + dx, y + dy] for dx, dy in MOVES
                if arena.is_free((x + dx, y + dy)) and d[x + dx, y + dy] >= 0]
        assert d[x, y] == (1 + min(near) if near else -1)
    assert (arena.geodesic((-1, 0)) == -1).all() and (arena.geodesic((n, n - 1)) == -1).all()


@pytest.mark.parametrize("size", [1, 0, -3, 2.5, True])
def test_bad_sizes(size):
    with pytest.raises(ValueError, match="arena size"):
        GridArena.empty(size)


def test_too_many_obstacles():
    with pytest.raises(ValueError, match="obstacles"):
        GridArena.with_obstacles(4, 15, seed=0)
