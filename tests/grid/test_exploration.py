import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial import cKDTree

from cml_edge.grid.arena import GridArena
from cml_edge.grid.exploration import knn_novelty, random_action, threshold


def novelty_reference(cells: np.ndarray, q, k: int = 5) -> float:
    """Eq. 4 by scipy's cKDTree: the sum of distances from q to the k nearest of the
    distinct visited ``cells`` (any number of axes), summed in ascending order."""
    m = min(k, len(cells))
    if m == 0:
        return 0.0
    dist, _ = cKDTree(np.asarray(cells, dtype=np.float64)).query(np.asarray(q, float), k=m)
    total = 0.0
    for d in np.atleast_1d(dist):
        total += float(d)
    return total


def test_threshold_is_eq_5():
    assert threshold(0, 30) == 1.0
    assert threshold(15, 30) == 0.5
    assert threshold(30, 30) == 0.0 and threshold(31, 30) == 0.0
    assert threshold(0, 0) == 0.0


@settings(max_examples=60, deadline=None)
@given(st.integers(3, 25), st.floats(0.0, 0.5), st.integers(0, 2**31 - 1), st.sampled_from([2, 3]))
def test_grid_knn_equals_ckdtree(n, density, seed, dims):
    """The compiled shells, on the plane and in space, find what the k-d tree finds."""
    n = n if dims == 2 else min(n, 9)
    rng = np.random.default_rng(seed)
    visited = (rng.random((n,) * dims) < density).astype(np.uint8)
    cells = np.argwhere(visited)
    best = np.zeros(5)
    off = np.zeros(dims, np.int64)
    for _ in range(5):
        q = rng.integers(-1, n + 1, dims)
        got = knn_novelty(visited.ravel(), len(cells), q.astype(np.int64), n, 5, best, off)
        assert got == novelty_reference(cells, q)


def test_random_action_is_uniform_over_available():
    moves = 0b10110010
    counts = np.zeros(8)
    for u in np.linspace(0, 1, 4000, endpoint=False):
        counts[random_action(moves, u)] += 1
    assert (counts[[1, 4, 5, 7]] == 1000).all() and counts.sum() == 4000


def test_mixed_exploration_covers_more_of_the_arena_early():
    from cml_edge.core.cml import CML
    from cml_edge.grid.exploration import GridExplorer
    from cml_edge.grid.training import FactoredLearner, TrainConfig, train_loop

    arena = GridArena.empty(30)
    coverage = {}
    for explore in ("random", "mixed"):
        cml = CML.create()
        config = TrainConfig(walks=100, steps=900, explore=explore)
        explorer = GridExplorer.of(arena, config, 0)
        c = cml.config
        train_loop(FactoredLearner.of(cml, arena), explorer, c.obs_origin, c.obs_scale, 0, 1,
                   config.steps, np.zeros(100))
        coverage[explore] = explorer.n_visited[0]
    assert coverage["mixed"] > 1.5 * coverage["random"]
