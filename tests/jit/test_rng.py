import numpy as np

from cml_edge.jit.rng import randint, stream_key, uniform


def test_same_key_counter_same_draw_and_streams_differ():
    k1, k2 = stream_key(0, 1), stream_key(0, 2)
    assert uniform(k1, 5) == uniform(k1, 5)
    assert uniform(k1, 5) != uniform(k2, 5)
    assert stream_key(1, 1) != k1


def test_uniform_moments():
    key = stream_key(3, 9)
    n = 100_000
    u = np.array([uniform(key, i) for i in range(n)])
    assert u.min() >= 0 and u.max() < 1
    assert abs(u.mean() - 0.5) < 4 * np.sqrt(1 / 12 / n)


def test_randint_is_uniform():
    key = stream_key(0, 4)
    counts = np.bincount([randint(key, i, 7) for i in range(70_000)], minlength=7)
    expected = 10_000
    chi2 = ((counts - expected) ** 2 / expected).sum()
    assert chi2 < 22.5  # 99.9th percentile of chi-square with 6 degrees of freedom
