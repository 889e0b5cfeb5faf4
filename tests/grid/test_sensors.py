"""Range sensors in the embedding: the readings, the loops that read them, the settings."""

import numpy as np
import pytest

from cml_edge.core.cml import CML
from cml_edge.errors import InputError
from cml_edge.grid.arena import GridArena
from cml_edge.grid.fidelity import decision_agreement, plan_states
from cml_edge.grid.metrics import draw_pairs
from cml_edge.grid.paths import default_path
from cml_edge.grid.planning import plan
from cml_edge.grid.seed_run import cml_config_for
from cml_edge.grid.sensors import Sensors
from cml_edge.grid.training import TrainConfig, train


def _blocked(size, cells, dims=2):
    blocked = np.zeros((size,) * dims, bool)
    for c in cells:
        blocked[c] = True
    return blocked


def test_readings_count_free_cells_to_an_obstacle_or_the_edge_clipped_at_the_range():
    arena = GridArena(7, _blocked(7, [(4, 1), (1, 3)])).sensing(Sensors(8, range=3))
    readings = arena.cells().readings.reshape(7, 7, 8)
    w = 0.5 / np.sqrt(8)
    # from (1, 1): east 2 free cells then (4, 1); north-east (2,2),(3,3),(4,4): clipped at 3;
    # north (1,2) then (1,3); every other direction one cell, then the edge
    d = np.array([2, 3, 1, 1, 1, 1, 1, 1])
    np.testing.assert_allclose(readings[1, 1], -w * (1 - d / 3))
    assert (readings[4, 1] == 0).all() and (readings[1, 3] == 0).all()  # obstacles read 0
    assert (readings[3, 3, [0, 2]] == 0).all()  # three free cells east and north: zero
    face = GridArena(7, _blocked(7, [(4, 1)])).sensing(Sensors(4, range=4, weight=0.3))
    wf = 0.3 / 2
    # face directions east, north, west, south from (1, 1)
    np.testing.assert_allclose(face.cells().readings.reshape(7, 7, 4)[1, 1],
                               -wf * (1 - np.array([2, 4, 1, 1]) / 4))


def test_readings_in_space_and_the_sensor_counts():
    blocked = _blocked(5, [(2, 2, 4)], dims=3)
    arena = GridArena(5, blocked).sensing(Sensors(6, range=9, weight=0.6))
    r = arena.cells().readings.reshape(5, 5, 5, 6)
    # face order: +x, +y, -x, -y, +z, -z (the arena's action order)
    d = np.array([2, 2, 2, 2, 1, 2])  # from the centre (2, 2, 2); (2, 2, 4) blocks +z
    np.testing.assert_allclose(r[2, 2, 2], -0.6 / np.sqrt(6) * (1 - d / 9))
    assert GridArena.empty(5, 3).sensing(Sensors(26)).cells().readings.shape == (125, 26)
    for k, dims in ((5, 2), (8, 3), (27, 3)):
        with pytest.raises(InputError, match=f"--sensors {k} is not allowed"):
            GridArena.empty(5, dims).sensing(Sensors(k))


@pytest.mark.parametrize("bad, match", [
    ({"k": -1}, "sensors -1"), ({"range": 0}, "sensor range 0"),
    ({"weight": 3.0}, "sensor weight 3.0 is outside"), ({"weight": "x"}, "not a number"),
    ({"goal": "there"}, "unknown sensor goal"), ({"train_obstacles": -2}, "training obstacles"),
])
def test_bad_sensor_settings_are_refused(bad, match):
    with pytest.raises(InputError, match=match):
        Sensors(**bad)


def test_too_many_training_obstacles_and_a_foreign_key_are_refused():
    with pytest.raises(InputError, match="training obstacles 24 do not fit"):
        GridArena.sensed(Sensors(train_obstacles=24), 5)
    with pytest.raises(InputError, match="unknown sensor settings keys: colour"):
        Sensors.from_dict({"k": 8, "colour": 1})


def test_the_training_arena_holds_a_third_of_the_cells_from_the_layout_seed():
    s = Sensors(8)
    a, b = GridArena.sensed(s, 30), GridArena.sensed(s, 30)
    assert a.n_obstacles == 300 and np.array_equal(a.blocked, b.blocked)
    assert a.sensors is s and a.n_sensors == 8
    other = GridArena.sensed(Sensors(8, layout_seed=7), 30)
    assert not np.array_equal(a.blocked, other.blocked)
    assert GridArena.sensed(Sensors(6, train_obstacles=17), 10, 3).n_obstacles == 17
    assert GridArena.sensed(Sensors(6), 9, 3).n_obstacles == 243


def _trained(arena, path, seed=3, walks=5, steps=70):
    cml = CML.create(cml_config_for(arena), "float", seed)
    return cml, train(cml, arena, TrainConfig(walks, steps, "mixed"), seed, path=path, epoch=2)


def test_sensed_training_is_the_same_on_the_reference_and_direct_paths():
    arena = GridArena.sensed(Sensors(8, range=3, train_obstacles=12), 7)
    ref, e_ref = _trained(arena, "reference")
    direct, e_direct = _trained(arena, "direct")
    assert ref.W_q.shape == (256, 10)
    for k, w in ref.weights().items():
        assert np.array_equal(w, direct.weights()[k]), k
    assert np.array_equal(e_ref, e_direct)
    plain, _ = _trained(GridArena(7, arena.blocked), "direct")
    assert not np.allclose(plain.W_v.to_float(), direct.W_v.to_float())  # the sensors count


def test_no_readings_trains_as_the_plain_arena_bit_for_bit():
    control = GridArena.sensed(Sensors(0, train_obstacles=12), 7)
    plain = GridArena(7, control.blocked)
    a, e_a = _trained(control, "direct")
    b, e_b = _trained(plain, "direct")
    for k, w in a.weights().items():
        assert np.array_equal(w, b.weights()[k]), k
    assert np.array_equal(e_a, e_b)


def test_sensors_refuse_the_factored_shortcut_and_a_model_of_other_inputs():
    arena = GridArena.sensed(Sensors(8, train_obstacles=5), 6)
    cml = CML.create(cml_config_for(arena), "float", 0)
    assert default_path(cml, "walk", arena=arena) == "direct"
    assert default_path(cml, "walk") == "factored"  # planning: the factored maps apply
    with pytest.raises(InputError, match="observation of the position alone"):
        train(cml, arena, TrainConfig(2, 10), 0, path="factored")
    plain = CML.create(cml_config_for(GridArena.empty(6)), "float", 0)
    with pytest.raises(InputError, match="the CML takes 2 inputs; the 2-D arena with 8 range "
                                         "sensors gives 10"):
        train(plain, arena, TrainConfig(2, 10), 0)
    with pytest.raises(InputError, match="takes 10 inputs"):
        plan(cml, GridArena.empty(6), np.array([[0, 0]]), np.array([[5, 5]]))


@pytest.mark.parametrize("goal", ["open", "here"])
@pytest.mark.parametrize("planner", ["paper", "escape"])
def test_sensed_plans_agree_on_every_path_and_replay_alike(goal, planner):
    sensors = Sensors(8, range=4, goal=goal, train_obstacles=30)
    cml, _ = _trained(GridArena.sensed(sensors, 10), "direct", walks=30, steps=200)
    arena = GridArena.with_obstacles(10, 25, 4).sensing(sensors)
    pairs = draw_pairs(arena, 15, 8)
    runs = {p: plan(cml, arena, pairs.starts, pairs.goals, path=p, planner=planner)
            for p in ("reference", "direct", "factored")}
    for field in ("final", "steps", "paths"):
        assert np.array_equal(getattr(runs["reference"], field), getattr(runs["direct"], field))
        assert np.array_equal(getattr(runs["direct"], field), getattr(runs["factored"], field))
    res = runs["direct"]
    assert decision_agreement(cml, arena, pairs.goals, res, planner, 100) == (
        int(res.steps.sum()), int(res.steps.sum()))


def test_the_goal_reads_open_space_or_the_agents_own_proximities():
    sensors = Sensors(8, range=4, train_obstacles=30)
    cml, _ = _trained(GridArena.sensed(sensors, 10), "direct", walks=20, steps=100)
    blocked = GridArena.with_obstacles(10, 25, 4)
    pairs = draw_pairs(blocked, 10, 8)
    here = blocked.sensing(Sensors(8, range=4, goal="here", train_obstacles=30))
    opened = blocked.sensing(sensors)
    res = plan(cml, opened, pairs.starts, pairs.goals)
    for (o, d), (o_h, d_h) in zip(plan_states(cml, opened, pairs.goals, res, 0),
                                  plan_states(cml, here, pairs.goals, res, 0)):
        assert np.array_equal(o, o_h) and np.array_equal(d[:2], d_h[:2])
        assert np.array_equal(d[2:], -o[2:]) and not d_h[2:].any()
    assert (plan(cml, here, pairs.starts, pairs.goals).paths != res.paths).any()
