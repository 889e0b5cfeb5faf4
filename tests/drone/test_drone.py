"""The drone: exact kinematics, bounds, walls, the robot's CML loops driving it, model files,
the command line and the Gymnasium environment."""

import json
import math

import numpy as np
import pytest

from cml_edge.core.cml import CML
from cml_edge.drone.models import (
    DroneModelError,
    base_state,
    draw_drone_goals,
    load_drone_models,
    save_drone_models,
)
from cml_edge.drone.observation import DroneCMLSettings
from cml_edge.drone.sim import (
    DIRECTIONS,
    N_DRONE_ACTIONS,
    DroneConfig,
    DroneKinematicSim,
    make_drone_sim,
)
from cml_edge.robot.planning import plan_robot
from cml_edge.robot.sim import sim_available
from cml_edge.robot.training import RobotTrainConfig, train_robot

DC = DroneConfig()
MOVING = DroneConfig(ends="moving")
SMALL = ["--walks", "3", "--steps", "40"]


def _integrate(state, vc, config, h=2e-5):
    """A fine numerical integration of the flight controller, written from its rule and not
    from the closed form: accelerate at most ``accel`` straight towards the command; in the
    rest profile brake at ``accel`` over the last speed / accel seconds. Velocity is
    piecewise linear, so each step's position update (its mean velocity) is exact but for
    where the controller switches inside a step (an error of ~accel h^2)."""
    p, v = list(map(float, state[:3])), list(map(float, state[3:]))
    T = config.action_time
    brake_from = T - config.speed / config.accel if config.ends == "rest" else math.inf
    step = config.accel * h
    for i in range(int(round(T / h))):
        target = [0.0, 0.0, 0.0] if i * h >= brake_from - 1e-12 else [float(c) for c in vc]
        dv = [target[k] - v[k] for k in range(3)]
        norm = math.sqrt(sum(d * d for d in dv))
        v_new = target if norm <= step else [v[k] + step * dv[k] / norm for k in range(3)]
        p = [p[k] + 0.5 * (v[k] + v_new[k]) * h for k in range(3)]
        v = v_new
    return np.array(p), np.array(v)


def _random_flight(sim, n, rng):
    """Fly ``n`` random available actions; every simulation step's state, stacked."""
    sub = np.zeros((sim.config.steps_per_action + 1, 6))
    rows = []
    for _ in range(n):
        sim.step(int(rng.choice(np.flatnonzero(sim.available()))), sub)
        rows.append(sub.copy())
    return np.concatenate(rows)


# kinematics -------------------------------------------------------------------------------
def test_defaults_and_the_one_metre_action():
    assert (DC.speed, DC.accel, DC.action_time, DC.ramp) == (0.5, 2.0, 2.25, 0.25)
    assert DC.step_length == pytest.approx(1.0, abs=1e-15)
    assert DIRECTIONS.shape == (N_DRONE_ACTIONS, 3)
    assert np.allclose(np.linalg.norm(DIRECTIONS, axis=1), 1.0)
    assert len({tuple(np.round(d, 9)) for d in DIRECTIONS}) == 26  # all distinct


def test_rest_profile_moves_one_fixed_vector_from_every_pose():
    """Rest to rest, an action's displacement is the same from every position (what makes
    the CML's linear model exact in the world frame); the drone ends at rest."""
    sim = DroneKinematicSim(DC)
    rng = np.random.default_rng(0)
    for a in (0, 4, 8, 13, 25):
        ends = []
        for p in rng.uniform(5, 25, (5, 3)):
            sim.reset(p)
            new = sim.step(a)
            ends.append(new[:3] - p)
            assert np.array_equal(new[3:], np.zeros(3))
        assert np.ptp(np.array(ends), axis=0).max() < 1e-13
        assert ends[0] == pytest.approx(DIRECTIONS[a] * DC.step_length, abs=1e-13)


@pytest.mark.parametrize("config", [DC, MOVING], ids=["rest", "moving"])
def test_closed_form_matches_a_fine_numerical_integration(config):
    sim = DroneKinematicSim(config)
    starts = [np.array([10.0, 12.0, 14.0, 0.0, 0.0, 0.0]),
              np.array([10.0, 12.0, 14.0, 0.3, -0.2, 0.1]),  # moving: not on a command
              np.array([10.0, 12.0, 14.0, *(-0.5 * DIRECTIONS[0])])]  # flying the reverse
    for state in starts:
        for a in (0, 9, 25):
            sim.reset(state)
            new = sim.step(a)
            p, v = _integrate(state, DC.speed * DIRECTIONS[a], config)
            assert np.abs(new[:3] - p).max() < 1e-7, (state, a)
            assert np.abs(new[3:] - v).max() < 1e-7
    # the reverse command from full speed: 0.5 s of braking and re-accelerating, 1.75 s cruise
    if config.ends == "moving":
        sim.reset(starts[2])
        new = sim.step(0)
        assert new[0] - 10.0 == pytest.approx(0.5 * (2.25 - 0.5) + 0.0, abs=1e-12)


@pytest.mark.parametrize("config", [DC, MOVING], ids=["rest", "moving"])
def test_speed_and_acceleration_never_exceed_their_bounds(config):
    sim = DroneKinematicSim(config)
    sim.reset([15.0, 15.0, 15.0])
    rows = _random_flight(sim, 150, np.random.default_rng(1))
    speed = np.linalg.norm(rows[:, 3:], axis=1)
    assert speed.max() <= config.speed * (1 + 1e-12) and speed.max() > 0.99 * config.speed
    # within an action: |dv| over one 50 ms step at most accel x dt
    per = config.steps_per_action + 1
    flights = rows.reshape(-1, per, 6)
    dv = np.linalg.norm(np.diff(flights[:, :, 3:], axis=1), axis=2)
    assert dv.max() <= config.accel * config.dt * (1 + 1e-9) and dv.max() > 0.5 * 0.1


@pytest.mark.parametrize("config", [DC, MOVING], ids=["rest", "moving"])
def test_the_drone_never_leaves_the_volume(config):
    rng = np.random.default_rng(2)
    sim = DroneKinematicSim(config)
    for start in ([0.1, 0.1, 0.1], [29.9, 15.0, 0.5], [15.0, 29.5, 29.9], [3.0, 1.0, 2.0]):
        sim.reset(start)
        rows = _random_flight(sim, 300, rng)
        assert rows[:, :3].min() >= config.lo and rows[:, :3].max() <= config.hi


def test_availability_is_the_trajectory_inside_checked_finely():
    """The exact check agrees with the trajectory sampled every 0.5 ms, near walls."""
    rng = np.random.default_rng(3)
    for config in (DC, MOVING):
        sim = DroneKinematicSim(config)
        fine = DroneKinematicSim(DroneConfig(dt=0.0005, steps_per_action=4500, ends=config.ends))
        masked = 0
        for _ in range(25):
            p = rng.uniform(config.lo, config.lo + 1.5, 3)
            v = rng.normal(size=3)
            v *= rng.uniform(0, config.speed) / np.linalg.norm(v) if config.ends == "moving" else 0
            sim.reset([*p, *v])
            mask = sim.available()
            masked += mask.sum() < 26
            for a in range(26):
                path = np.zeros((4501, 6))
                fine.reset([*p, *v])
                end = fine.step(a, path)
                inside = path[:, :3].min() >= config.lo and path[:, :3].max() <= config.hi
                if config.ends == "moving":  # it must still brake to rest inside
                    stop = end[:3] + end[3:] * np.linalg.norm(end[3:]) / (2 * config.accel)
                    inside = inside and stop.min() >= config.lo and stop.max() <= config.hi
                assert bool(mask[a]) == inside, (p, v, a)
        assert masked >= 20
    sim = DroneKinematicSim(DC)
    sim.reset([15.0, 15.0, 15.0])
    assert sim.available().all()
    sim.reset([0.5, 15.0, 15.0])  # 0.4 m from the west wall: every move with -x is masked
    mask = sim.available()
    assert [a for a in range(26) if not mask[a]] == [a for a in range(26)
                                                     if DIRECTIONS[a, 0] < 0]


def test_bad_states_actions_and_configs_are_refused():
    sim = DroneKinematicSim(DC)
    with pytest.raises(ValueError, match="outside the volume"):
        sim.reset([0.05, 15.0, 15.0])
    with pytest.raises(ValueError, match="faster"):
        sim.reset([15.0, 15.0, 15.0, 1.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="three or six"):
        sim.reset([15.0, 15.0])
    sim.reset([15.0, 15.0, 15.0])
    with pytest.raises(ValueError, match="action"):
        sim.step(26)
    with pytest.raises(ValueError, match="ramp"):
        DroneConfig(steps_per_action=5)
    with pytest.raises(ValueError, match="action end"):
        DroneConfig(ends="hover")
    with pytest.raises(ValueError, match="simulator"):
        make_drone_sim("airsim")


# the CML loops on the drone ---------------------------------------------------------------
def _trained(seed, config=None, path="direct", backend="float", drone=DC):
    settings = DroneCMLSettings()
    cml = CML.create(settings.cml_config(), backend, seed)
    info = train_robot(cml, DroneKinematicSim(drone), settings, config or RobotTrainConfig(3, 40),
                       seed, path=path)
    return cml, info


@pytest.mark.parametrize("schedule", ["walk", "step"])
def test_reference_and_compiled_training_and_planning_agree_bit_for_bit(schedule):
    settings = DroneCMLSettings()
    goals = draw_drone_goals(DC, 4, 9)
    starts = np.tile(base_state(), (4, 1))
    for seed, backend, drone in ((5, "float", DC), (4, "int8", DC), (6, "float", MOVING)):
        config = RobotTrainConfig(3, 40, schedule)
        a, ia = _trained(seed, config, "direct", backend, drone)
        b, ib = _trained(seed, config, "reference", backend, drone)
        for x, y in zip(a.arrays, b.arrays):
            assert np.array_equal(x.to_float(), y.to_float())
            assert x.counters == y.counters
        assert np.array_equal(ia["train_error"], ib["train_error"])
        sim = DroneKinematicSim(drone)
        for stop in ("action", "step"):
            ra = plan_robot(a, sim, settings, starts, goals, 30, 0.6, "direct", True, stop)
            rb = plan_robot(a, sim, settings, starts, goals, 30, 0.6, "reference", True, stop)
            assert np.array_equal(ra.actions, rb.actions)
            assert np.array_equal(ra.poses, rb.poses, equal_nan=True)
            assert np.array_equal(ra.length, rb.length)
            assert np.array_equal(ra.trails, rb.trails)


def test_same_seed_same_flight_other_seed_other_weights():
    settings = DroneCMLSettings()
    goals = draw_drone_goals(DC, 3, 4)
    starts = np.tile(base_state(), (3, 1))
    runs = []
    for seed in (3, 3, 4):
        cml, _ = _trained(seed)
        res = plan_robot(cml, DroneKinematicSim(DC), settings, starts, goals, 20, 0.6,
                         keep_paths=True)
        runs.append((cml.W_q.to_float(), res))
    assert np.array_equal(runs[0][0], runs[1][0])
    assert all(np.array_equal(p, q) for p, q in zip(runs[0][1].paths, runs[1][1].paths))
    assert not np.array_equal(runs[0][0], runs[2][0])
    assert np.array_equal(draw_drone_goals(DC, 5, 7), draw_drone_goals(DC, 5, 7))
    goals = draw_drone_goals(DC, 200, 123)
    assert goals.shape == (200, 3) and goals.min() >= 0.5 and goals.max() <= 29.5


def test_eq3_gain_stays_below_one():
    _, info = _trained(0, RobotTrainConfig(2, 900))
    assert 0 < info["eq3_gain"] <= 0.001 * 900 * 0.75 < 1


def test_the_drone_walks_draw_only_available_actions_near_walls():
    """A plug-in answers for the pose it is asked about (the fidelity replay asks at the
    poses a run recorded)."""
    sim = DroneKinematicSim(DC)
    mask = np.zeros(26, np.uint8)
    rng = np.random.default_rng(4)
    for p in rng.uniform(DC.lo, DC.lo + 0.8, (10, 3)):
        count = sim_available(sim.plugin, base_state(p), mask)
        sim.reset(p)
        assert np.array_equal(mask, sim.available()) and count == mask.sum() < 26


@pytest.mark.slow
def test_a_trained_drone_reaches_its_goals():
    """The default training (100 walks x 900 actions) reaches every goal of 30 on float,
    along paths near the straight line."""
    cml, _ = _trained(0, RobotTrainConfig())
    goals = draw_drone_goals(DC, 30, 123)
    starts = np.tile(base_state(), (30, 1))
    res = plan_robot(cml, DroneKinematicSim(DC), DroneCMLSettings(), starts, goals, 100, 0.6)
    assert res.reached.all()


# model files ------------------------------------------------------------------------------
def test_model_file_round_trip_and_validation(tmp_path):
    from cml_edge.core.model_file import ModelFileError, load_model
    from cml_edge.robot.models import RobotModelError, load_robot_models

    cml, _ = _trained(2, RobotTrainConfig(1, 20))
    path = tmp_path / "d.npz"
    meta = {"drone": DC.to_dict(), "settings": DroneCMLSettings().to_dict(), "sim": "kinematic",
            "mujoco": None, "training": {"seeds": [2]}}
    save_drone_models(path, [cml, cml], meta)
    cmls, loaded = load_drone_models(path)
    assert len(cmls) == 2 and loaded["drone"] == DC.to_dict()
    assert np.array_equal(cmls[1].W_v.to_float(), cml.W_v.to_float())
    with pytest.raises(RobotModelError, match="a drone model: use cml-edge drone evaluate"):
        load_robot_models(path)
    with pytest.raises(ModelFileError, match="a drone model: use cml-edge drone evaluate"):
        load_model(path)
    data = dict(np.load(path))
    data["meta"] = np.array(json.dumps({**json.loads(str(data["meta"])), "sim": "airsim"}))
    np.savez(tmp_path / "bad.npz", **data)
    with pytest.raises(DroneModelError, match="corrupted drone model"):
        load_drone_models(tmp_path / "bad.npz")


# the command line -------------------------------------------------------------------------
@pytest.fixture
def model(tmp_path, cli):
    path = tmp_path / "drone.npz"
    code, out, err = cli("drone", "train", *SMALL, "--seeds", 2, "--out", path, "--json")
    assert code == 0, err
    result = json.loads(out)
    assert result["seeds"] == [0, 1] and result["ends"] == "rest"
    assert result["utility"] == "normalized" and all(g < 1 for g in result["eq3_gain"])
    return path


def test_cli_train_evaluate_navigate(model, tmp_path, cli):
    code, out, err = cli("drone", "evaluate", model, "--trials", 5, "--json")
    assert code == 0, err
    result = json.loads(out)
    for key in ("success_rate", "mean_actions", "path_ratio", "e_pos_mean", "per_seed",
                "actions_per_s", "decision_agreement", "timings", "radius"):
        assert key in result
    assert result["seeds"] == 2 and result["trials"] == 5 and result["radius"] == 0.6
    assert result["decision_agreement"]["mean"] == 1.0  # float: its own twin
    png = tmp_path / "flights.png"
    code, out, err = cli("drone", "navigate", model, "--goals", 3, "--plot", png, "--json")
    assert code == 0, err
    assert len(json.loads(out)["runs"]["goals"]) == 3
    from matplotlib.image import imread

    image = imread(png)
    assert image.ndim == 3 and image.shape[1] > 2 * image.shape[0]  # three views side by side
    code, out, _ = cli("drone", "navigate", model, "--start", 15, 15, 15, "--goal", 16, 15, 15,
                       "--stop", "step", "--json")
    result = json.loads(out)
    assert code == 0 and result["trials"] == 1 and result["start"] == [15, 15, 15]
    code, out, err = cli("drone", "evaluate", model, "--trials", 3)
    assert code == 0 and out.startswith("drone evaluate: 2 models x 3 goals on kinematic")


@pytest.mark.parametrize("argv, message", [
    (["train", "--walks", "0", "--out", "X"], "--walks"),
    (["train", "--ends", "hover", "--out", "X"], "hover"),
    (["train", "--backend", "abacus", "--out", "X"], "abacus"),
    (["train", "--mujoco-kv", "2", "--out", "X"], "--sim mujoco"),
    (["evaluate", "MISSING"], "does not exist"),
])
def test_cli_bad_input_exits_2_and_writes_nothing(tmp_path, cli, argv, message):
    argv = [str(tmp_path / a) if a in ("X", "MISSING") else a for a in argv]
    code, out, err = cli("drone", *argv)
    assert code == 2 and out == ""
    assert len(err.strip().splitlines()) == 1 and message in err
    assert not any(tmp_path.iterdir())


def test_cli_bad_planning_input_exits_2(model, tmp_path, cli):
    for argv, message in (
        (["evaluate", model, "--seeds", 5], "holds 2 models"),
        (["evaluate", model, "--start", 40, 2, 2], "outside the volume"),
        (["navigate", model, "--goal", 31, 2, 2], "outside the"),
        (["navigate", model, "--goal", 3, 2], "expected 3"),
        (["navigate", model, "--model-index", 2], "holds 2 models"),
        (["navigate", model, "--plot", tmp_path], "is a folder"),
    ):
        code, out, err = cli("drone", *argv)
        assert code == 2 and out == "" and message in err, err
        assert len(err.strip().splitlines()) == 1
    code, _, err = cli("robot", "evaluate", model)
    assert code == 2 and "a drone model" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["drone.npz"]


# Gymnasium --------------------------------------------------------------------------------
@pytest.mark.parametrize("kwargs", [{}, {"goal_conditioned": True, "reward": "tailored"},
                                    {"start": "random", "drone": MOVING}])
def test_gymnasium_checkers(kwargs):
    gym = pytest.importorskip("gymnasium")
    import warnings

    from gymnasium.utils.env_checker import check_env

    import cml_edge  # noqa: F401  (registers the ids)

    env = gym.make("cml_edge/DroneNav-v0", **kwargs)  # the passive checker wraps it
    obs, _ = env.reset(seed=0)
    for a in range(5):
        obs, *_ = env.step(a)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(env.unwrapped, skip_render_check=True)
    assert env.observation_space.contains(obs)


def test_gym_environment_dynamics():
    pytest.importorskip("gymnasium")
    from cml_edge.drone.env import DroneNavEnv

    env = DroneNavEnv(goal_conditioned=True, reward="tailored", render_mode="ansi")
    obs, info = env.reset(seed=0, options={"start": (0.5, 15.0, 15.0), "goal": (15, 15, 15)})
    assert obs.shape == (6,) and env.action_space.n == 26
    west = int(np.argmax(-DIRECTIONS[:, 0]))  # straight towards the west wall: masked
    assert info["action_mask"][west] == 0
    obs2, reward, terminated, truncated, info = env.step(west)  # blocked: the drone stays
    assert np.array_equal(obs, obs2) and reward == pytest.approx(-14.5, abs=1e-9)
    env.reset(options={"start": (10.0, 10.0, 10.0), "goal": (11.0, 10.0, 10.0)})
    _, reward, terminated, _, info = env.step(0)  # one metre east
    assert terminated and info["is_success"] and reward > 90
    assert env.render().startswith("t=1 position=(11.00, 10.00, 10.00)")
    with pytest.raises(ValueError):
        DroneNavEnv(reward="sparse")
    with pytest.raises(ValueError):
        env.step(26)


# MuJoCo (the robot extra) -----------------------------------------------------------------
def test_mujoco_drone_follows_the_kinematic_one_and_stays_inside():
    pytest.importorskip("mujoco")
    mj = make_drone_sim("mujoco", DC)
    kin = DroneKinematicSim(DC)
    for sim in (mj, kin):
        sim.reset([5.0, 5.0, 5.0])
        for a in (0, 0, 13, 25, 7):
            sim.step(a)
    # Stated tolerance: 2 cm over five actions (the servo's lag; no drift, as the
    # controller tracks the reference position), and nearly at rest.
    assert np.abs(mj.pose[:3] - kin.pose[:3]).max() < 0.02
    assert np.linalg.norm(mj.pose[3:]) < 0.05
    mj.reset([0.3, 0.3, 0.3])
    rows = _random_flight(mj, 12, np.random.default_rng(5))
    assert rows[:, :3].min() >= DC.lo - 0.02 and rows[:, :3].max() <= DC.hi + 0.02


def test_mujoco_drone_trains_and_flies_through_the_loops(tmp_path, cli):
    pytest.importorskip("mujoco")
    path = tmp_path / "mj.npz"
    code, out, err = cli("drone", "train", "--sim", "mujoco", "--walks", 1, "--steps", 6,
                         "--out", path, "--json")
    assert code == 0, err
    assert json.loads(out)["sim"] == "mujoco"
    code, out, err = cli("drone", "evaluate", path, "--trials", 2, "--max-actions", 3, "--json")
    assert code == 0, err
    data = json.loads(out)
    assert data["sim"] == "mujoco" and data["fidelity_twin"].startswith("unavailable")


# the scenarios' world ---------------------------------------------------------------------
def test_the_drone_world_meets_the_protocol():
    from cml_edge.core.world import get_world

    world = get_world("drone")
    run = {"walks": 2, "steps": 60}
    part = {"name": "p", "trials": 3, "eval_seed": 7}
    trained = world.train(1, run, "int8", {}, None)
    twin = world.twin(1, run)
    planned = world.plan(trained.cml, part, run)
    assert planned.starts.shape == (3, 6) and planned.goals.shape == (3, 3)
    record = world.summarise(1, trained.cml, twin, part, planned)
    assert record["trials"] == 3 and record["decisions"] == int(planned.result.steps.sum())
    pooled = world.pool([record, record])
    assert pooled["trials"] == 6 and pooled["success_rate"] == record["success_rate"]
    with pytest.raises(ValueError, match="the drone does not relearn"):
        world.relearn(trained.cml, twin, 1, run, 2, 0)
