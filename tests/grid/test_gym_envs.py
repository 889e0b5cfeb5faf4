"""The Gymnasium grid environments (cml_edge.grid.env): checkers, dynamics, Eqs. 6-7."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from cml_edge.protocol import R_GOAL

gym = pytest.importorskip("gymnasium")

from cml_edge.grid.arena import MOVES, GridArena  # noqa: E402
from cml_edge.grid.env import (  # noqa: E402
    ENV_3D_ID,
    ENV_ID,
    GOAL_ENV_ID,
    GridNavEnv,
    apply_moves,
    scale_positions,
)

VARIANTS = [
    {},
    {"reward": "tailored"},
    {"goal_conditioned": True},
    {"goal_conditioned": True, "reward": "tailored", "obstacles": 120},
    {"size": 5, "goal": (0, 4)},
    {"dims": 3, "size": 8},
    {"dims": 3, "size": 6, "moves": "face", "goal_conditioned": True, "obstacles": 30},
]


@pytest.mark.parametrize("kwargs", VARIANTS)
def test_gymnasium_checker(kwargs):
    from gymnasium.utils.env_checker import check_env

    env = gym.make(ENV_ID, **kwargs).unwrapped  # made through the registry: has a spec
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the checker's warnings fail the test
        check_env(env, skip_render_check=False)


@pytest.mark.parametrize("kwargs", VARIANTS)
def test_sb3_checker(kwargs):
    sb3_checker = pytest.importorskip("stable_baselines3.common.env_checker")
    sb3_checker.check_env(GridNavEnv(**kwargs), warn=True)


def test_registered_ids():
    env = gym.make(ENV_ID, goal=(3, 4))
    obs, _ = env.reset(seed=0)
    assert obs.shape == (2,) and env.unwrapped.goal.tolist() == [3, 4]
    env = gym.make(GOAL_ENV_ID)
    obs, _ = env.reset(seed=0)
    assert obs.shape == (4,)
    env = gym.make("cml_edge.grid.env:cml_edge/GridNav-v0", reward="tailored")
    assert env.unwrapped.reward_name == "tailored"
    env = gym.make(ENV_3D_ID, size=10)
    obs, info = env.reset(seed=0, options={"start": (0, 0, 0)})
    assert obs.shape == (3,) and env.action_space.n == 26 and info["goal"] == (5, 5, 5)
    obs, _, _, _, info = env.step(8)  # straight up (move_table: the ninth move)
    assert info["position"] == (0, 0, 1) and obs.tolist()[2] == pytest.approx(2 / 9 - 1)
    layers = gym.make(ENV_3D_ID, size=4, render_mode="ansi").unwrapped.render()
    assert layers.startswith("z = 3\n") and "z = 0\n" in layers and layers.count("A") == 1


def test_three_dimensional_moves_match_the_arena():
    arena = GridArena.with_obstacles(5, 25, seed=2, dims=3)
    cells = np.argwhere(~arena.blocked)
    for a in range(26):
        nxt = apply_moves(arena.free, cells, np.full(len(cells), a), arena.move_table)
        allowed = np.array([arena.available(c)[a] for c in cells])
        assert ((nxt != cells).any(axis=1) == allowed).all()
        assert arena.free[tuple(nxt.T)].all()


def test_observation_scaling():
    assert scale_positions([0, 29], 30).tolist() == [-1.0, 1.0]
    env = GridNavEnv(size=30, goal_conditioned=True)
    obs, info = env.reset(seed=1, options={"start": (0, 29), "goal": (29, 0)})
    assert obs.dtype == np.float32
    assert obs.tolist() == [-1.0, 1.0, 1.0, -1.0]
    assert info["position"] == (0, 29) and info["goal"] == (29, 0)


def test_moves_are_king_moves_and_blocked_moves_stay():
    env = GridNavEnv(size=10, goal=(9, 9))
    for a in range(8):
        env.reset(options={"start": (5, 5)})
        env.step(a)
        assert env.pos.tolist() == (np.array([5, 5]) + MOVES[a]).tolist()
    env.reset(options={"start": (0, 0)})
    _, r, term, trunc, info = env.step(4)  # W off the arena: stays
    assert info["position"] == (0, 0) and not term and not trunc
    assert r == pytest.approx(-np.hypot(9, 9))


def test_apply_moves_agrees_with_arena_masks():
    arena = GridArena.with_obstacles(8, 20, seed=3)
    free = arena.free
    cells = np.argwhere(~arena.blocked)
    for a in range(8):
        nxt = apply_moves(free, cells, np.full(len(cells), a))
        allowed = np.array([arena.available(c)[a] for c in cells])
        moved = (nxt != cells).any(axis=1)
        assert (moved == allowed).all()
        assert arena.free[nxt[:, 0], nxt[:, 1]].all()


def test_goal_terminates_and_simplified_reward():
    env = GridNavEnv(size=10, goal=(3, 3))
    env.reset(options={"start": (1, 1)})
    _, r, term, _, _ = env.step(1)  # NE to (2, 2)
    assert r == pytest.approx(-np.sqrt(2)) and not term
    _, r, term, trunc, info = env.step(1)
    assert r == 0.0 and term and not trunc and info["is_success"]


def test_truncation_at_100_steps():
    env = GridNavEnv(size=10, goal=(9, 9))
    env.reset(options={"start": (0, 0)})
    for t in range(1, 101):
        _, _, term, trunc, _ = env.step(4 if t % 2 else 0)  # W/E: never reaches the goal
        assert not term
        assert trunc == (t == 100)


def test_tailored_return_is_eq7():
    """Episode return = sum_t -|p_goal - p(t)| + R_goal - max(T - d_Ch, 0)."""
    env = GridNavEnv(size=10, goal=(5, 2), reward="tailored")
    env.reset(options={"start": (1, 2)})  # d_Ch = 4
    actions = [2, 6, 0, 0, 0, 0]  # N, S (two wasted steps), then 4 x E
    total, dists = 0.0, []
    for a in actions:
        _, r, term, _, info = env.step(a)
        total += r
        dists.append(np.hypot(*(np.array(info["position"]) - [5, 2])))
    assert term
    expected = -sum(dists) + R_GOAL - max(len(actions) - 4, 0)
    assert total == pytest.approx(expected)


def test_start_never_on_goal_and_seeded():
    env = GridNavEnv(size=3, goal=(1, 1))
    starts = set()
    for s in range(50):
        _, info = env.reset(seed=s)
        assert info["position"] != (1, 1)
        starts.add(info["position"])
    assert len(starts) == 8
    a = GridNavEnv(goal_conditioned=True).reset(seed=7)[0]
    b = GridNavEnv(goal_conditioned=True).reset(seed=7)[0]
    assert (a == b).all()


def test_obstacles_match_arena_and_bad_input():
    env = GridNavEnv(size=12, obstacles=30, obstacle_seed=5, goal_conditioned=True)
    assert (env.arena.blocked == GridArena.with_obstacles(12, 30, 5).blocked).all()
    for _ in range(20):
        _, info = env.reset()
        assert env.arena.is_free(info["position"]) and env.arena.is_free(info["goal"])
    with pytest.raises(ValueError, match="goal"):
        GridNavEnv(size=10, goal=(10, 0))
    with pytest.raises(ValueError, match="reward"):
        GridNavEnv(reward="sparse")
    with pytest.raises(ValueError, match="fixed-goal"):
        GridNavEnv().reset(options={"goal": (1, 1)})
    with pytest.raises(ValueError, match="action"):
        env.step(8)
