import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cml_edge.errors import InputError
from cml_edge.grid.arena import MOVES, GridArena, chebyshev, move_table, nth_move, unpack_moves
from cml_edge.grid.metrics import draw_pairs


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
    masks = arena.move_masks
    assert masks.dtype == np.uint32 and masks.shape == (n, n)
    mask = np.zeros(8, np.uint8)
    for x in range(n):
        for y in range(n):
            bits = [(int(masks[x, y]) >> a) & 1 for a in range(8)]
            assert bits == arena.available((x, y)).astype(int).tolist()
            assert unpack_moves(masks[x, y], mask) == sum(bits) and bits == mask.tolist()
            for a in range(8):  # the move's target, by the flat offsets the loops take
                if bits[a]:
                    c = np.ravel_multi_index((x, y), (n, n)) + arena.cells().offsets[a]
                    assert np.unravel_index(c, (n, n)) == (x + MOVES[a, 0], y + MOVES[a, 1])


def test_nth_move():
    assert nth_move(0b10110, 0) == 1 and nth_move(0b10110, 2) == 4 and nth_move(0b10110, 3) == -1
    assert nth_move(1 << 25, 0) == 25


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


def test_move_tables_extend_the_plane():
    """The third dimension's moves: the plane's first, then up, then down; each move's
    reverse is a move."""
    for dims, moves, count in ((2, "king", 8), (2, "face", 4), (3, "king", 26), (3, "face", 6)):
        t = move_table(dims, moves)
        assert t.shape == (count, dims) and len({tuple(m) for m in t}) == count
        assert np.abs(t).max() == 1 and not (t == 0).all(axis=1).any()
        assert {tuple(-m) for m in t} == {tuple(m) for m in t}
    assert (move_table(2) == MOVES).all()
    assert (move_table(3)[:8, :2] == MOVES).all() and (move_table(3)[:8, 2] == 0).all()
    assert move_table(3)[8].tolist() == [0, 0, 1] and move_table(3)[17].tolist() == [0, 0, -1]
    assert (np.abs(move_table(3, "face")).sum(axis=1) == 1).all()
    with pytest.raises(InputError, match="dims 4"):
        move_table(4)
    with pytest.raises(InputError, match="unknown move set 'queen'"):
        GridArena.empty(5, 3, "queen")


@settings(max_examples=20, deadline=None)
@given(st.integers(2, 6), st.integers(0, 2**31 - 1), st.sampled_from(["king", "face"]))
def test_masks_and_geodesics_in_three_dimensions(n, seed, moves):
    arena = GridArena.with_obstacles(n, min(n ** 3 - 2, 2 * n), seed, dims=3, moves=moves)
    table = arena.move_table
    free = [tuple(p) for p in np.argwhere(~arena.blocked)]
    for p in free:
        want = [arena.is_free(tuple(np.add(p, m))) for m in table]
        assert arena.available(p).tolist() == want
    source = free[0]
    dist = {source: 0}  # breadth-first in Python
    frontier = [source]
    while frontier:
        nxt = []
        for p in frontier:
            for m in table:
                q = tuple(int(v) for v in np.add(p, m))
                if q not in dist and arena.is_free(q):
                    dist[q] = dist[p] + 1
                    nxt.append(q)
        frontier = nxt
    d = arena.geodesic(source)
    for p in free:
        assert d[p] == dist.get(p, -1)
    assert (d[arena.blocked] == -1).all()


def test_three_dimensional_arenas_and_pairs():
    a = GridArena.with_obstacles(6, 40, seed=3, dims=3)
    assert a.dims == 3 and a.blocked.shape == (6, 6, 6) and a.n_obstacles == 40
    assert (GridArena.with_obstacles(6, 40, seed=3, dims=3).blocked == a.blocked).all()
    pairs = draw_pairs(a, 9, 4)
    assert pairs.starts.shape == (9, 3) and (pairs.starts != pairs.goals).any(axis=1).all()
    assert ((pairs.geodesic >= pairs.chebyshev) | (pairs.geodesic == -1)).all()
    face = GridArena.empty(5, 3, "face")
    p = draw_pairs(face, 7, 1)
    assert (p.geodesic == np.abs(p.starts - p.goals).sum(axis=1)).all()
    king = draw_pairs(GridArena.empty(5, 3), 7, 1)
    assert (king.geodesic == king.chebyshev).all()
    with pytest.raises(InputError, match="expected"):
        GridArena(4, np.zeros((4, 4, 4, 4), bool))
    with pytest.raises(InputError, match="obstacles 215"):
        GridArena.with_obstacles(6, 215, 0, dims=3)
