"""The continuous robot: kinematics, walls, MuJoCo, the CML loops, files, CLI, Gym."""

import json
import math

import numpy as np
import pytest

from cml_edge.core.cml import CML
from cml_edge.core.model_file import ModelFileError, load_model, save_model
from cml_edge.robot.models import (
    RobotModelError,
    load_robot_models,
    save_robot_models,
)
from cml_edge.robot.observation import (
    BEARING,
    OBSERVATIONS,
    RobotCMLSettings,
    RobotFrame,
    observe,
)
from cml_edge.robot.planning import BASE_POSE, draw_goals, plan_robot
from cml_edge.robot.sim import (
    WHEEL_FRACTIONS,
    KinematicSim,
    RobotConfig,
    action_geometry,
    make_sim,
    sim_available,
    wrap_angle,
)
from cml_edge.robot.training import RobotTrainConfig, train_robot

RC = RobotConfig()
SMALL = ["--walks", "3", "--steps", "40"]


def _random_actions(sim, n, rng):
    """Drive ``n`` random available actions; every simulation-step pose, stacked."""
    sub = np.zeros((RC.steps_per_action + 1, 3))
    poses = []
    for _ in range(n):
        a = int(rng.choice(np.flatnonzero(sim.available())))
        sim.step(a, sub)
        poses.append(sub.copy())
    return np.concatenate(poses)


# kinematics -------------------------------------------------------------------------------
def test_straight_actions_move_the_expected_distance():
    expected = RC.wheel_radius * 0.5 * RC.omega_max * RC.dt * RC.steps_per_action
    assert expected == pytest.approx(0.4986, abs=1e-4)  # 64 x 32 ms at 0.5 omega_max
    sim = KinematicSim(RC)
    for action, sign in ((1, 1.0), (6, -1.0)):
        sim.reset([15.0, 15.0, 0.7])
        x, y, th = sim.step(action)
        assert math.hypot(x - 15.0, y - 15.0) == pytest.approx(expected, rel=1e-12)
        assert th == pytest.approx(0.7, abs=1e-15)
        assert (x - 15.0, y - 15.0) == pytest.approx(
            (sign * expected * math.cos(0.7), sign * expected * math.sin(0.7)), rel=1e-12)


def test_arcs_turn_by_the_expected_angle_and_chord():
    sim = KinematicSim(RC)
    T = RC.dt * RC.steps_per_action
    geo = action_geometry(RC)
    for a, (fl, fr) in enumerate(WHEEL_FRACTIONS):
        turn = RC.wheel_radius * (fr - fl) * RC.omega_max / RC.axle_length * T
        v = RC.wheel_radius * (fl + fr) / 2 * RC.omega_max
        w = turn / T
        chord = abs(v * T) if w == 0 else abs(2 * v / w * math.sin(w * T / 2))
        sim.reset([15.0, 15.0, -2.0])
        x, y, th = sim.step(a)
        assert wrap_angle(th + 2.0) == pytest.approx(turn, abs=1e-12)
        assert math.hypot(x - 15.0, y - 15.0) == pytest.approx(chord, rel=1e-12)
        assert geo["chord_length"][a] == pytest.approx(chord, rel=1e-12)
    assert geo["turn"][0] == pytest.approx(0.9174, abs=1e-4)  # forward-left: 52.6 degrees
    assert geo["turn"][3] == pytest.approx(2.5688, abs=1e-4)  # sharp left: 147 degrees


def test_row_eight_is_the_mirror_of_row_six():
    assert list(WHEEL_FRACTIONS[7]) == list(WHEEL_FRACTIONS[5][::-1])
    geo = action_geometry(RC)
    assert geo["turn"][7] == -geo["turn"][5]
    assert geo["chord"][7, 1] == -geo["chord"][5, 1]
    assert len({tuple(r) for r in WHEEL_FRACTIONS}) == 8  # no duplicate left


def test_the_robot_never_leaves_the_arena():
    rng = np.random.default_rng(0)
    sim = KinematicSim(RC)
    for start in ([0.2, 0.2, 3.0], [29.8, 15.0, 0.0], [15.0, 29.7, 1.5], [3.0, 1.0, -2.0]):
        sim.reset(start)
        poses = _random_actions(sim, 400, rng)
        assert poses[:, :2].min() >= RC.lo and poses[:, :2].max() <= RC.hi


def test_an_action_that_would_leave_the_arena_is_unavailable():
    sim = KinematicSim(RC)
    sim.reset([0.4, 15.0, math.pi])  # facing the west wall, 0.23 m of room
    mask = sim.available()
    assert mask[1] == 0 and mask[6] == 1  # forward blocked, backward free
    sim.reset([15.0, 15.0, 0.0])
    assert sim.available().all()
    with pytest.raises(ValueError, match="outside the arena"):
        sim.reset([0.1, 15.0, 0.0])
    with pytest.raises(ValueError, match="action"):
        sim.step(8)


def test_kinematic_and_mujoco_agree_on_a_straight_run():
    pytest.importorskip("mujoco")
    mj = make_sim("mujoco", RC)
    kin = KinematicSim(RC)
    for sim in (mj, kin):
        sim.reset([5.0, 5.0, 0.3])
        for _ in range(5):
            sim.step(1)
    # Stated tolerance: 3 cm and 0.01 rad over 2.49 m (the motors' spin-up from rest costs
    # ~1 cm; no slip at Table 1's speeds with friction 1).
    assert np.hypot(*(mj.pose[:2] - kin.pose[:2])) < 0.03
    assert abs(wrap_angle(mj.pose[2] - kin.pose[2])) < 0.01
    assert mj.tilt() < 0.01


def test_mujoco_sim_stays_in_the_arena_and_reports_its_pose():
    pytest.importorskip("mujoco")
    sim = make_sim("mujoco", RC)
    sim.reset([0.5, 0.5, 3.5])
    poses = _random_actions(sim, 15, np.random.default_rng(1))
    assert poses[:, :2].min() >= RC.lo - 0.02 and poses[:, :2].max() <= RC.hi + 0.02


@pytest.mark.parametrize("name", ["kinematic", "mujoco"])
def test_plugins_mask_the_actions_at_the_pose_asked_about(name):
    """``sim_available(plugin, pose, mask)`` answers for ``pose``, wherever the robot is
    (the fidelity replay asks at the poses a run recorded)."""
    if name == "mujoco":
        pytest.importorskip("mujoco")
    sim = make_sim(name, RC)
    sim.reset([15.0, 15.0, 0.0])  # all actions available here
    rng = np.random.default_rng(4)
    corners = np.column_stack([rng.uniform(RC.lo, RC.lo + 0.6, (12, 2)),
                               rng.uniform(-np.pi, np.pi, 12)])
    mask = np.zeros(8, np.uint8)
    masked = 0
    for pose in corners:
        count = sim_available(sim.plugin, pose, mask)
        sim.reset(pose)
        assert np.array_equal(mask, sim.available()) and count == mask.sum()
        masked += count < 8
        sim.reset([15.0, 15.0, 0.0])
    assert masked >= 6


# the CML on the robot ------------------------------------------------------------------------
def test_heading_observation_makes_action_effects_pose_independent():
    """Read in the heading's frame, o_{t+1} - o_t of an action is the same at every pose
    (what lets the CML's fixed W_v a model it); in the world frame it is not."""
    sim = KinematicSim(RC)
    rng = np.random.default_rng(2)
    poses = np.column_stack([rng.uniform(5, 25, (6, 2)), rng.uniform(-np.pi, np.pi, 6)])
    for mode, invariant in ((1, True), (2, False), (0, False)):
        n = 2 if mode == 0 else 4
        deltas = []
        for pose in poses:
            sim.reset(pose)
            new = sim.step(0)
            o_t, o_1 = np.zeros(n), np.zeros(n)
            frame = RobotFrame(mode, BEARING, 15.0, 30.0, 1 / 30)
            observe(frame, pose, pose, o_t)
            observe(frame, pose, new, o_1)
            deltas.append(o_1 - o_t)
        spread = np.ptp(np.array(deltas), axis=0).max()
        assert (spread < 1e-12) == invariant


def _trained(settings, seed, config=None, path="direct", backend="float"):
    config = config or RobotTrainConfig(3, 40)
    cml = CML.create(settings.cml_config(), backend, seed)
    info = train_robot(cml, KinematicSim(RC), settings, config, seed, path=path)
    return cml, info


@pytest.mark.parametrize("schedule", ["walk", "step"])
def test_reference_and_compiled_training_and_planning_agree_bit_for_bit(schedule):
    sim = KinematicSim(RC)
    goals = draw_goals(RC, 4, 9)
    starts = np.tile(BASE_POSE, (4, 1))
    # seeds 4 and 6 have random-stream keys above 2^63 (a uint64 that is no int64)
    for observation, seed in [(o, 5) for o in OBSERVATIONS] + [("heading", 4), ("xy", 6)]:
        settings = RobotCMLSettings(observation)
        config = RobotTrainConfig(3, 40, schedule)
        a, ia = _trained(settings, seed, config, "direct")
        b, ib = _trained(settings, seed, config, "reference")
        for x, y in zip(a.arrays, b.arrays):
            assert np.array_equal(x.to_float(), y.to_float())
            assert x.counters == y.counters
        assert np.array_equal(ia["train_error"], ib["train_error"])
        ra = plan_robot(a, sim, settings, starts, goals, max_actions=30, path="direct")
        rb = plan_robot(a, sim, settings, starts, goals, max_actions=30, path="reference")
        assert np.array_equal(ra.actions, rb.actions)
        assert np.array_equal(ra.poses, rb.poses, equal_nan=True)
        assert np.array_equal(ra.length, rb.length)


def test_reference_and_compiled_agree_on_the_mujoco_robot():
    pytest.importorskip("mujoco")
    settings = RobotCMLSettings("heading")
    config = RobotTrainConfig(1, 6)
    cmls = []
    for path in ("direct", "reference"):
        cml = CML.create(settings.cml_config(), "float", 6)
        train_robot(cml, make_sim("mujoco", RC), settings, config, 6, path=path)
        cmls.append(cml)
    for x, y in zip(cmls[0].arrays, cmls[1].arrays):
        assert np.array_equal(x.to_float(), y.to_float())


def test_same_seed_same_trajectory_other_seed_other_weights():
    settings = RobotCMLSettings()
    sim = KinematicSim(RC)
    goals = draw_goals(RC, 3, 4)
    starts = np.tile(BASE_POSE, (3, 1))
    runs = []
    for seed in (3, 3, 4):
        cml, _ = _trained(settings, seed)
        res = plan_robot(cml, sim, settings, starts, goals, max_actions=20, keep_paths=True)
        runs.append((cml.W_q.to_float(), res))
    assert np.array_equal(runs[0][0], runs[1][0])
    assert all(np.array_equal(p, q) for p, q in zip(runs[0][1].paths, runs[1][1].paths))
    assert not np.array_equal(runs[0][0], runs[2][0])
    assert np.array_equal(draw_goals(RC, 5, 7), draw_goals(RC, 5, 7))


def test_eq3_gain_stays_below_one():
    """lr_q x steps x mean |o|^2 per walk; with o centred and divided by the side,
    |o|^2 <= 0.5 + h^2 anywhere in the arena, so 900 steps give < 0.46."""
    for observation in OBSERVATIONS:
        settings = RobotCMLSettings(observation)
        _, info = _trained(settings, 0, RobotTrainConfig(2, 900))
        bound = 0.001 * 900 * (0.5 + (settings.heading_scale ** 2 if settings.n_i == 4 else 0))
        assert 0 < info["eq3_gain"] <= bound < 1


def test_trained_heading_cml_reaches_goals_and_xy_cannot():
    """With the default training the heading-aware CML reaches its goals; the paper's (x, y)
    cannot tell which way the robot faces, so its actions' effects average out."""
    sim = KinematicSim(RC)
    goals = draw_goals(RC, 20, 123)
    starts = np.tile(BASE_POSE, (20, 1))
    rates = {}
    for observation in ("heading", "xy"):
        settings = RobotCMLSettings(observation)
        cml, _ = _trained(settings, 0, RobotTrainConfig())
        rates[observation] = plan_robot(cml, sim, settings, starts, goals).reached.mean()
    assert rates["heading"] >= 0.9 and rates["xy"] <= 0.2


def test_settings_reject_bad_values():
    with pytest.raises(ValueError, match="observation"):
        RobotCMLSettings("polar")
    with pytest.raises(ValueError, match="heading-scale"):
        RobotCMLSettings(heading_scale=float("nan"))
    with pytest.raises(ValueError, match="walks"):
        RobotTrainConfig(0, 10)
    with pytest.raises(ValueError, match="wheel_radius"):
        RobotConfig(wheel_radius=-1.0)
    with pytest.raises(ValueError, match="simulator"):
        make_sim("webots", RC)


# model files ------------------------------------------------------------------------------
def test_model_file_round_trip_and_validation(tmp_path):
    settings = RobotCMLSettings("xy")
    cml, _ = _trained(settings, 2, RobotTrainConfig(1, 20))
    path = tmp_path / "r.npz"
    meta = {"robot": RC.to_dict(), "settings": settings.to_dict(), "sim": "kinematic",
            "mujoco": None, "training": {"seeds": [2]}}
    save_robot_models(path, [cml, cml], meta)
    cmls, loaded = load_robot_models(path)
    assert len(cmls) == 2 and loaded["settings"] == settings.to_dict()
    assert np.array_equal(cmls[1].W_v.to_float(), cml.W_v.to_float())
    bad = tmp_path / "bad.npz"
    bad.write_bytes(b"not a zip")
    with pytest.raises(RobotModelError, match="readable"):
        load_robot_models(bad)
    with pytest.raises(RobotModelError, match="does not exist"):
        load_robot_models(tmp_path / "missing.npz")
    save_model(tmp_path / "grid.npz", cml, {})
    with pytest.raises(RobotModelError, match="a grid model: use cml-edge evaluate"):
        load_robot_models(tmp_path / "grid.npz")
    with pytest.raises(ModelFileError, match="a robot model: use cml-edge robot evaluate"):
        load_model(path)
    data = dict(np.load(path))
    data["format_version"] = np.array(99)
    np.savez(tmp_path / "v99.npz", **data)
    with pytest.raises(RobotModelError, match="version 99"):
        load_robot_models(tmp_path / "v99.npz")
    data = dict(np.load(path))
    data["meta"] = np.array(json.dumps({**json.loads(str(data["meta"])), "n_models": 3}))
    np.savez(tmp_path / "n3.npz", **data)
    with pytest.raises(RobotModelError, match="corrupted"):
        load_robot_models(tmp_path / "n3.npz")


# the command line -------------------------------------------------------------------------

@pytest.fixture
def model(tmp_path, cli):
    path = tmp_path / "robot.npz"
    code, out, err = cli("robot", "train", *SMALL, "--seeds", 2, "--out", path, "--json")
    assert code == 0, err
    result = json.loads(out)
    assert result["seeds"] == [0, 1] and all(g < 1 for g in result["eq3_gain"])
    return path


def test_cli_train_evaluate_navigate(model, tmp_path, cli):
    code, out, err = cli("robot", "evaluate", model, "--trials", 5, "--json")
    assert code == 0, err
    result = json.loads(out)
    for key in ("success_rate", "mean_actions", "path_ratio", "e_pos_mean", "per_seed",
                "actions_per_s"):
        assert key in result
    assert result["seeds"] == 2 and result["trials"] == 5 and len(result["per_seed"]) == 2
    png = tmp_path / "fig9.png"
    code, out, err = cli("robot", "navigate", model, "--goals", 3, "--plot", png,
                         "--json")
    assert code == 0, err
    assert png.read_bytes()[:4] == b"\x89PNG" and len(json.loads(out)["runs"]["goals"]) == 3
    code, out, _ = cli("robot", "navigate", model, "--goal", 3, 3, "--stop", "step",
                       "--json")
    assert code == 0 and json.loads(out)["trials"] == 1


@pytest.mark.parametrize("argv, message", [
    (["train", "--walks", "0", "--out", "X"], "--walks"),
    (["train", "--observation", "polar", "--out", "X"], "polar"),
    (["train", "--heading-scale", "nan", "--out", "X"], "nan"),
    (["train", "--backend", "abacus", "--out", "X"], "abacus"),
    (["train", "--mujoco-kv", "2", "--out", "X"], "--sim mujoco"),
    (["evaluate", "MISSING"], "does not exist"),
])
def test_cli_bad_input_exits_2_and_writes_nothing(tmp_path, cli, argv, message):
    argv = [str(tmp_path / a) if a in ("X", "MISSING") else a for a in argv]
    code, out, err = cli("robot", *argv)
    assert code == 2 and out == ""
    assert len(err.strip().splitlines()) == 1 and message in err
    assert not any(tmp_path.iterdir())


def test_cli_bad_planning_input_exits_2(model, tmp_path, cli):
    for argv, message in (
        (["evaluate", model, "--seeds", 5], "holds 2 models"),
        (["evaluate", model, "--observation", "xy"], "trained with the heading"),
        (["evaluate", model, "--base", 40, 2, 0], "outside the arena"),
        (["navigate", model, "--goal", 31, 2], "off the"),
        (["navigate", model, "--model-index", 2], "holds 2 models"),
    ):
        code, out, err = cli("robot", *argv)
        assert code == 2 and message in err and len(err.strip().splitlines()) == 1
    grid = tmp_path / "grid.npz"
    from cml_edge.core.cml import CMLConfig
    from cml_edge.core.model_file import save_model

    save_model(grid, CML.create(CMLConfig.for_arena(10)), {})
    code, _, err = cli("robot", "evaluate", grid)
    assert code == 2 and "grid model" in err


def test_cli_seeds_and_output_paths_out_of_range_exit_2(model, tmp_path, cli):
    (tmp_path / "afile").write_text("x")
    for argv, message in (
        (["train", *SMALL, "--seed", 2**63, "--out", tmp_path / "r.npz"],
         "--seed: '9223372036854775808' is beyond int64"),
        (["train", *SMALL, "--seed", 2**63 - 2, "--seeds", 3, "--out", tmp_path / "r.npz"],
         "is outside the range of --seed"),
        (["train", *SMALL, "--out", tmp_path], "is a folder"),
        (["train", *SMALL, "--out", tmp_path / "afile" / "r.npz"], "which is a file"),
        (["evaluate", model, "--eval-seed", 2**64], "'18446744073709551616' is beyond int64"),
        (["navigate", model, "--plot", tmp_path], "is a folder"),
    ):
        code, out, err = cli("robot", *argv)
        assert code == 2 and out == "", err
        assert len(err.strip().splitlines()) == 1 and message in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["afile", "robot.npz"]


# Gymnasium --------------------------------------------------------------------------------
def test_gym_environment():
    pytest.importorskip("gymnasium")
    from gymnasium.utils.env_checker import check_env

    from cml_edge.robot.env import RobotNavEnv

    env = RobotNavEnv(observation="heading", goal_conditioned=True, reward="tailored")
    check_env(env, skip_render_check=True)
    obs, info = env.reset(seed=0, options={"start": (0.4, 15.0, math.pi), "goal": (15, 15)})
    assert obs.shape == (6,) and info["action_mask"][1] == 0
    obs2, reward, terminated, truncated, info = env.step(1)  # blocked: the robot stays
    assert np.array_equal(obs, obs2) and reward == pytest.approx(-14.6, abs=0.01)
    env.reset(options={"start": (10.0, 10.0, 0.0), "goal": (10.5, 10.0)})
    _, reward, terminated, _, info = env.step(1)
    assert terminated and info["is_success"] and reward > 90
    with pytest.raises(ValueError):
        RobotNavEnv(observation="polar")


def test_sb3_checker_and_a_short_dqn_run_on_the_robot():
    sb3 = pytest.importorskip("stable_baselines3")
    from stable_baselines3.common.env_checker import check_env

    from cml_edge.robot.env import RobotNavEnv

    env = RobotNavEnv(observation="heading")
    check_env(env)
    model = sb3.DQN("MlpPolicy", env, learning_starts=50, buffer_size=500, seed=0,
                    policy_kwargs={"net_arch": [64, 64]}, device="cpu")
    model.learn(total_timesteps=200)
    assert model.num_timesteps == 200
    action, _ = model.predict(env.reset(seed=1)[0], deterministic=True)
    assert 0 <= int(action) < 8


def test_bench_robot_reports_actions_per_second(cli):
    code, out, err = cli("bench", "--backends", "float32", "--repeats", 1,
                         "--robot", "kinematic", "--json")
    assert code == 0, err
    robot = json.loads(out)["robot"]
    assert list(robot) == ["kinematic"] and robot["kinematic"]["train_actions"] == 9000
    assert robot["kinematic"]["train_actions_per_s"] > 0
    assert robot["kinematic"]["plan_actions_per_s"] > 0
    code, _, err = cli("bench", "--robot", "webots")
    assert code == 2 and "webots" in err


def test_cli_views_of_the_robot(model, tmp_path, cli):
    code, out, err = cli("robot", "train", *SMALL, "--out", tmp_path / "one.npz")
    assert code == 0, err
    assert out.startswith("robot train: 1 model (seed 0) on kinematic") and "{" not in out
    code, out, err = cli("robot", "evaluate", model, "--trials", 5)
    assert code == 0, err
    lines = out.splitlines()
    assert lines[0].startswith("robot evaluate: 2 models x 5 goals on kinematic")
    assert [line.split("  ")[1] for line in lines[1:]] == [
        "device", "success rate", "path ratio", "weight error", "decision agreement",
        "read SNR", "time"]
    code, out, err = cli("robot", "navigate", model, "--goals", 3)
    assert code == 0, err
    assert out.startswith("robot navigate: model 0 to 3 goals on kinematic")
    assert len(out.splitlines()) == 8  # the header, 3 rows, the goals' table of 3 and its head
