import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial import cKDTree

from cml_edge.grid.arena import GridArena
from cml_edge.grid.exploration import knn_novelty, random_action, threshold


class VisitedSet:
    """The reference the compiled index is held to: distinct cells, scipy's cKDTree."""

    def __init__(self) -> None:
        self.cells: list[tuple[int, int]] = []
        self._seen: set[tuple[int, int]] = set()
        self._tree: cKDTree | None = None

    def add(self, x: int, y: int) -> None:
        if (x, y) not in self._seen:
            self._seen.add((x, y))
            self.cells.append((x, y))
            self._tree = None

    def novelty(self, x: int, y: int, k: int = 5) -> float:
        """Eq. 4: sum of distances to the k nearest visited cells, summed in ascending order."""
        m = min(k, len(self.cells))
        if m == 0:
            return 0.0
        if self._tree is None:
            self._tree = cKDTree(np.array(self.cells, dtype=np.float64))
        dist, _ = self._tree.query([float(x), float(y)], k=m)
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
@given(st.integers(3, 25), st.floats(0.0, 0.5), st.integers(0, 2**31 - 1))
def test_grid_knn_equals_ckdtree(n, density, seed):
    rng = np.random.default_rng(seed)
    visited = (rng.random((n, n)) < density).astype(np.uint8)
    ref = VisitedSet()
    for x, y in np.argwhere(visited):
        ref.add(int(x), int(y))
    best = np.zeros(5)
    for _ in range(5):
        x, y = rng.integers(-1, n + 1, 2)
        assert knn_novelty(visited, int(visited.sum()), x, y, 5, best) == ref.novelty(x, y)


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
        train_loop(FactoredLearner.of(cml, 30), explorer, c.obs_origin, c.obs_scale, 0, 1,
                   config.steps, np.zeros(100))
        coverage[explore] = explorer.n_visited[0]
    assert coverage["mixed"] > 1.5 * coverage["random"]
