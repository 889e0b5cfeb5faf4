"""Compiled loops called in chunks (so a stop request is handled within about a second)
give exactly what one call gives: weights, counters, errors and plans, on a noisy device."""

import os
import signal
import sys

import numpy as np
import pytest

import cml_edge.engine.stop as stop
from cml_edge.core.cml import CML, CMLConfig
from cml_edge.engine.stop import CHUNK_STEPS, chunks
from cml_edge.grid.arena import GridArena
from cml_edge.grid.metrics import draw_pairs
from cml_edge.grid.planning import plan
from cml_edge.grid.training import TrainConfig, train
from cml_edge.robot.observation import RobotCMLSettings
from cml_edge.robot.planning import BASE_POSE, draw_goals, plan_robot
from cml_edge.robot.sim import KinematicSim, RobotConfig
from cml_edge.robot.training import RobotTrainConfig, train_robot


def test_chunks_cover_the_range_in_order_with_one_item_at_least():
    assert list(chunks(3, 10, CHUNK_STEPS // 3)) == [(3, 6), (6, 9), (9, 10)]
    assert list(chunks(0, 3, 10 * CHUNK_STEPS)) == [(0, 1), (1, 2), (2, 3)]
    assert list(chunks(5, 5, 1)) == []


def _same(a: CML, b: CML) -> None:
    for x, y in zip(a.arrays, b.arrays):
        assert np.array_equal(x.to_float(), y.to_float())
        assert x.counters == y.counters


@pytest.mark.parametrize("schedule", ["walk", "step"])
def test_grid_training_and_planning_in_chunks_are_one_call(schedule, monkeypatch):
    arena = GridArena.empty(8)
    config = TrainConfig(5, 50, schedule=schedule)
    pairs = draw_pairs(arena, 12, 4)
    runs = []
    for chunk in (10**9, 50):  # one call; a walk or a plan per call
        monkeypatch.setattr(stop, "CHUNK_STEPS", chunk)
        cml = CML.create(CMLConfig.for_arena(8), "crossbar", 2, preset="pcm")
        errors = train(cml, arena, config, 2)
        res = plan(cml, arena, pairs.starts, pairs.goals, max_steps=30, planner="escape")
        runs.append((cml, errors, res))
    (a, ea, ra), (b, eb, rb) = runs
    _same(a, b)
    assert np.array_equal(ea, eb)
    for field in ("final", "steps", "paths"):
        assert np.array_equal(getattr(ra, field), getattr(rb, field))


def test_robot_training_and_driving_in_chunks_are_one_call(monkeypatch):
    rc = RobotConfig()
    settings = RobotCMLSettings("xy")
    goals = draw_goals(rc, 5, 9)
    starts = np.tile(BASE_POSE, (5, 1))
    runs = []
    for chunk in (10**9, 40):
        monkeypatch.setattr(stop, "CHUNK_STEPS", chunk)
        cml = CML.create(settings.cml_config(), "crossbar", 4, preset="reram")
        info = train_robot(cml, KinematicSim(rc), settings, RobotTrainConfig(4, 40), 4)
        res = plan_robot(cml, KinematicSim(rc), settings, starts, goals, max_actions=20)
        runs.append((cml, info, res))
    (a, ia, ra), (b, ib, rb) = runs
    _same(a, b)
    assert np.array_equal(ia["train_error"], ib["train_error"])
    assert np.array_equal(ra.actions, rb.actions)
    assert np.array_equal(ra.poses, rb.poses, equal_nan=True)


def test_a_stop_swallowed_by_a_finalizer_is_raised_again_before_the_next_chunk(monkeypatch):
    """Python runs a signal's handler in whatever code runs; inside a finalizer the stop is
    printed as "Exception ignored" and dropped. The next chunk raises it again."""
    swallowed = []
    monkeypatch.setattr(sys, "unraisablehook", lambda u: swallowed.append(u.exc_type))

    class Finalized:
        def __del__(self) -> None:
            os.kill(os.getpid(), signal.SIGTERM)
            sum(range(1000))  # the handler runs here, inside the finalizer

    with stop.stop_on_signals():
        walks = chunks(0, 3, CHUNK_STEPS)
        assert next(walks) == (0, 1)
        Finalized()
        assert swallowed == [stop.Stopped]
        with pytest.raises(stop.Stopped):
            next(walks)
    assert not stop._noted  # a later command starts clean
