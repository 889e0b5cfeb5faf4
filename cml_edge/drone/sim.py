"""The drone world: a holonomic point mass with bounded speed and acceleration in a walled volume.

The paper's section 5 names drones as the agents a three-dimensional CML is for. The
vehicle here is a small quadrotor seen by its position controller: a point mass that
flies any velocity command (holonomic; attitude and thrust are the controller's
business), with |velocity| <= ``speed`` and |acceleration| <= ``accel`` (Euclidean
norms). Its 26 actions are velocity commands at ``speed`` along the unit directions of
the 3-D king moves (:func:`cml_edge.grid.arena.move_table`: the 6 faces, 12 edges and 8
corners of a cube, normalised, in the grid's order), each held for one action time.
Two simulators sit behind the robot's interface (:class:`cml_edge.robot.sim.RobotSim`),
so the robot's training, planning and fidelity loops drive them unchanged:

- ``kinematic`` (default): exact. Within an action the acceleration is piecewise
  constant (the profile below), so position and velocity at any time are closed-form
  polynomials of it: no integration error, only float64 rounding. Compiled with Numba.
- ``mujoco`` (the ``robot`` extra, imported only when asked for): a sphere of the body
  radius on three slide joints (a point mass that cannot spin), gravity compensated
  (``gravcomp``: the rotors' hover thrust), velocity servos with a force limit on each
  axis (the motors' lag and thrust margin), and six solid walls (floor and ceiling
  included). The flight controller sends, every simulation step (50 ms), the velocity
  that would bring the drone onto the kinematic reference trajectory at the end of the
  step. The servos' lag in the final braking stops an action that ends at rest 2.0 mm
  (at most 2.4 mm) from the kinematic prediction, and still drifting at up to 0.02 m/s (40
  random actions from the volume's centre); actions that end moving end on it (< 5 um).

The profile of an action (``ends``, a field of :class:`DroneConfig`):

- ``rest`` (default): accelerate at ``accel`` towards the command, cruise, brake at
  ``accel`` to rest at the end of the action (a trapezoid: 0.25 s ramps at the
  defaults). Every action starts and ends at rest, so its displacement is the same
  fixed vector, speed x (T - speed / accel) = 1 m along its direction, from every pose.
  That is what the CML's model s_{t+1} = s_t + W_v a assumes, exactly, with the position
  alone as its observation (:mod:`cml_edge.drone.observation`).
- ``moving``: accelerate at ``accel`` from the velocity the action starts with straight
  to the command (along the velocity difference), then cruise: the action ends at the
  commanded velocity, as a velocity-command interface usually flies. The displacement
  then depends on the previous action (speed x T minus half the velocity difference times
  its ramp, 0-0.25 m less), which the position observation does not contain, so the
  CML's linear model is only nearly right. Measured on float (docs/paper.md, "The
  drone"), it costs nothing there: every goal is still reached, in fewer and longer
  actions. The default stays ``rest`` because its model is exact, which the goal
  radius's argument (:mod:`cml_edge.drone.observation`) needs.
  An action is available in this mode only if the drone can still brake to rest inside
  the walls after it, so some action is always available (the reverse of the current
  velocity brakes first).

Choices, all fields of :class:`DroneConfig`, with their sources:

- ``speed`` 0.5 m/s and ``accel`` 2 m/s^2: the limits a Crazyswarm maintainer gives for
  trajectories on the Crazyflie 2.x nano quadrotor ("I use 2m/s^2 and 0.5m/s, but this
  is pretty conservative", W. Hoenig, bitcraze discussions #23, 2021).
- ``body_radius`` 0.1 m: the Crazyflie is 92 mm motor to motor, ~0.13 m across its
  propellers; 0.1 m keeps a margin.
- Step length and action time: ``dt`` 50 ms (a 20 Hz setpoint rate) and
  ``steps_per_action`` 45, so an action lasts T = 2.25 s and moves 1 m at rest-to-rest:
  one grid cell, and 48 actions cross the volume's diagonal, within the robot's budget
  of 100 actions.
- Walls. The volume is [0, 30] m cubed, the robot's 30 m square extended upwards; the
  drone's sphere must stay inside, so its centre stays in [0.1, 29.9] on every axis. An
  action is available when its whole trajectory keeps the centre there, checked
  exactly: on each constant-acceleration segment every coordinate is a quadratic in time,
  whose extremes are at the segment's ends or where its velocity component is zero. The
  planner masks unavailable actions; exploration draws only among available ones.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import Any, NamedTuple

import numpy as np
from numba import njit

from cml_edge.core.records import Record
from cml_edge.errors import InputError
from cml_edge.grid.arena import move_table
from cml_edge.jit.rng import uniform
from cml_edge.protocol import STREAM_DRONE_EXPLORE, STREAM_DRONE_GOALS, STREAM_DRONE_START
from cml_edge.robot.sim import (
    load_mujoco,
    set_pose,
    sim_available,
    sim_pose_at,
    sim_reset,
    sim_step,
    sim_walk_start,
)

N_DRONE_ACTIONS = 26
POSE_SIZE = 6  # x, y, z, vx, vy, vz
ENDS = ("rest", "moving")
SIMS = ("kinematic", "mujoco")
DIRECTIONS = move_table(3, "king") / np.linalg.norm(move_table(3, "king"), axis=1)[:, None]
"""(26, 3) unit directions of the actions: the 3-D king moves normalised."""


@dataclass(frozen=True)
class DroneConfig(Record):
    """Volume, vehicle limits and timing (sources in the module docstring)."""

    what = "drone config"

    arena: float = 30.0
    body_radius: float = 0.1
    speed: float = 0.5
    accel: float = 2.0
    dt: float = 0.05
    steps_per_action: int = 45
    ends: str = "rest"

    def __post_init__(self) -> None:
        for name in ("arena", "speed", "accel", "dt"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) \
                    or v <= 0:
                raise InputError(f"drone {name} {v!r} is not a finite number > 0")
        r = self.body_radius
        if isinstance(r, bool) or not isinstance(r, (int, float)) or not math.isfinite(r) \
                or r < 0:
            raise InputError(f"drone body_radius {r!r} is not a finite number >= 0")
        if 2 * r >= self.arena:
            raise InputError(f"drone body_radius {r} does not fit in a volume of side "
                             f"{self.arena}")
        v = self.steps_per_action
        if isinstance(v, bool) or int(v) != v or v < 1:
            raise InputError(f"steps_per_action {v!r} is not a positive integer")
        if self.ends not in ENDS:
            raise InputError(f"unknown action end {self.ends!r}; allowed: {', '.join(ENDS)}")
        if self.action_time < 2.0 * self.ramp * (1.0 - 1e-12):
            raise InputError(f"an action of {self.action_time:g} s cannot ramp up to "
                             f"{self.speed:g} m/s and back at {self.accel:g} m/s^2 (it "
                             f"needs {2 * self.ramp:g} s)")

    @property
    def lo(self) -> float:
        """Lowest x, y or z the drone's centre may take."""
        return float(self.body_radius)

    @property
    def hi(self) -> float:
        """Highest x, y or z the drone's centre may take."""
        return float(self.arena - self.body_radius)

    @property
    def action_time(self) -> float:
        """Seconds one action lasts (45 x 50 ms = 2.25 s by default)."""
        return self.dt * self.steps_per_action

    @property
    def ramp(self) -> float:
        """Seconds from rest to full speed at full acceleration (0.25 s)."""
        return self.speed / self.accel

    @property
    def step_length(self) -> float:
        """The displacement of one action from rest to rest (1 m by default)."""
        return self.speed * (self.action_time - self.ramp)

    def commands(self) -> np.ndarray:
        """(26, 3) commanded velocities (m/s) of the actions."""
        return DIRECTIONS * self.speed


# compiled kinematics ---------------------------------------------------------------
@njit(cache=True)
def profile(v0x, v0y, v0z, vc, accel, T, rest, seg):
    """The action's constant-acceleration segments from the velocity (v0x, v0y, v0z) under
    the command ``vc``: rows (duration, ax, ay, az) of ``seg``; returns how many. The
    first segment accelerates straight to the command, then the action cruises, and in
    the ``rest`` profile brakes to rest at its end (module docstring)."""
    dx = vc[0] - v0x
    dy = vc[1] - v0y
    dz = vc[2] - v0z
    dv = math.sqrt(dx * dx + dy * dy + dz * dz)
    n = 0
    used = 0.0
    if dv > 0.0:
        t1 = min(dv / accel, T)
        seg[n, 0] = t1
        seg[n, 1] = accel * dx / dv
        seg[n, 2] = accel * dy / dv
        seg[n, 3] = accel * dz / dv
        n += 1
        used = t1
    brake = 0.0
    vn = math.sqrt(vc[0] * vc[0] + vc[1] * vc[1] + vc[2] * vc[2])
    if rest and vn > 0.0:
        brake = vn / accel
    cruise = T - used - brake
    if cruise > 0.0:
        seg[n, 0] = cruise
        seg[n, 1] = 0.0
        seg[n, 2] = 0.0
        seg[n, 3] = 0.0
        n += 1
    if brake > 0.0:
        seg[n, 0] = brake
        seg[n, 1] = -accel * vc[0] / vn
        seg[n, 2] = -accel * vc[1] / vn
        seg[n, 3] = -accel * vc[2] / vn
        n += 1
    return n


@njit(cache=True)
def state_at(pose, seg, n, t, out):
    """The state (position, velocity) ``t`` seconds into the segments from ``pose``: each
    segment's closed form, p + v d + a d^2 / 2 and v + a d."""
    for k in range(6):
        out[k] = pose[k]
    left = t
    for s in range(n):
        if left <= 0.0:
            break
        d = min(left, seg[s, 0])
        for k in range(3):
            a = seg[s, 1 + k]
            out[k] = out[k] + out[3 + k] * d + 0.5 * a * d * d
            out[3 + k] = out[3 + k] + a * d
        left -= d


@njit(cache=True)
def segments_inside(pose, seg, n, lo, hi):
    """True when the centre stays in [lo, hi] on every axis along the segments from
    ``pose``: on each, a coordinate p + v t + a t^2 / 2 is checked at both ends and at its
    turning point t = -v / a when that falls inside the segment (exact)."""
    p0 = pose[0]
    p1 = pose[1]
    p2 = pose[2]
    v0 = pose[3]
    v1 = pose[4]
    v2 = pose[5]
    for s in range(n):
        d = seg[s, 0]
        for k in range(3):
            p = p0 if k == 0 else (p1 if k == 1 else p2)
            v = v0 if k == 0 else (v1 if k == 1 else v2)
            a = seg[s, 1 + k]
            end = p + v * d + 0.5 * a * d * d
            if end < lo or end > hi:
                return False
            if a != 0.0:
                tt = -v / a
                if 0.0 < tt < d:
                    top = p + v * tt + 0.5 * a * tt * tt
                    if top < lo or top > hi:
                        return False
        # advance to the next segment's start
        for k in range(3):
            a = seg[s, 1 + k]
            if k == 0:
                p0 = p0 + v0 * d + 0.5 * a * d * d
                v0 = v0 + a * d
            elif k == 1:
                p1 = p1 + v1 * d + 0.5 * a * d * d
                v1 = v1 + a * d
            else:
                p2 = p2 + v2 * d + 0.5 * a * d * d
                v2 = v2 + a * d
    return True


@njit(cache=True)
def fly(pose, vc, accel, dt, n_sub, rest, seg, out, path):
    """Hold the velocity command ``vc`` for ``n_sub`` simulation steps from ``pose``
    (x, y, z, vx, vy, vz): ``out`` gets the state at the end (its velocity exactly the
    profile's end: rest, or the command), and ``path``, when it has n_sub + 1 rows, the
    state at every simulation step, each in closed form from the action's start."""
    T = dt * n_sub
    n = profile(pose[3], pose[4], pose[5], vc, accel, T, rest, seg)
    if path.shape[0] == n_sub + 1:
        for k in range(6):
            path[0, k] = pose[k]
        for i in range(1, n_sub + 1):
            state_at(pose, seg, n, dt * i, path[i])
    state_at(pose, seg, n, T, out)
    for k in range(3):
        out[3 + k] = 0.0 if rest else vc[k]


@njit(cache=True)
def braking(pose, accel, seg):
    """The segment that brakes the state ``pose`` to rest at full deceleration; how many
    (0 at rest)."""
    vn = math.sqrt(pose[3] * pose[3] + pose[4] * pose[4] + pose[5] * pose[5])
    if vn == 0.0:
        return 0
    seg[0, 0] = vn / accel
    for k in range(3):
        seg[0, 1 + k] = -accel * pose[3 + k] / vn
    return 1


@njit(cache=True)
def drone_available(pose, commands, accel, T, rest, lo, hi, mask, seg, end):
    """mask[a] = 1 when action a's trajectory (and, in the ``moving`` profile, braking to
    rest after it) keeps the drone inside; returns how many.

    Shortcut (exact): no point of an action and its braking is farther from its start
    than speed x T + speed^2 / (2 accel), so a drone farther than that from every wall has
    every action available."""
    speed = 0.0
    for a in range(commands.shape[0]):
        speed = max(speed, math.sqrt(commands[a, 0] ** 2 + commands[a, 1] ** 2
                                     + commands[a, 2] ** 2))
    reach = speed * T + speed * speed / (2.0 * accel)
    room = hi - lo
    for k in range(3):
        room = min(room, pose[k] - lo, hi - pose[k])
    if room > reach * (1.0 + 1e-9) + 1e-9:
        for a in range(commands.shape[0]):
            mask[a] = 1
        return commands.shape[0]
    count = 0
    for a in range(commands.shape[0]):
        n = profile(pose[3], pose[4], pose[5], commands[a], accel, T, rest, seg)
        ok = segments_inside(pose, seg, n, lo, hi)
        if ok and not rest:
            state_at(pose, seg, n, T, end)
            for k in range(3):
                end[3 + k] = commands[a, k]
            ok = segments_inside(end, seg, braking(end, accel, seg), lo, hi)
        mask[a] = 1 if ok else 0
        count += mask[a]
    return count


NO_PATH = np.zeros((0, POSE_SIZE))


class DroneKinematics(NamedTuple):
    """The exact kinematics as the loops' simulator (compiled): a function of the state."""

    commands: np.ndarray  # (26, 3) commanded velocities
    accel: float
    dt: float
    n_sub: int  # simulation steps per action
    lo: float
    hi: float
    rest: bool  # the rest-to-rest profile
    seg: np.ndarray  # (3, 4) work: the profile's segments
    end: np.ndarray  # (6) work: an action's end state


@njit(cache=True)
def drone_walk_start(key, w, lo, hi, out):
    """Walk w's start: a uniform position where the drone fits, at rest."""
    base = np.uint64(3) * np.uint64(w)
    for k in range(3):
        out[k] = lo + (hi - lo) * uniform(key, base + np.uint64(k))
        out[3 + k] = 0.0


@njit(cache=True, inline="always")
def _k_reset(k, start, pose):
    set_pose(pose, start)


@njit(cache=True, inline="always")
def _k_available(k, pose, mask):
    return drone_available(pose, k.commands, k.accel, k.dt * k.n_sub, k.rest, k.lo, k.hi, mask,
                           k.seg, k.end)


@njit(cache=True, inline="always")
def _k_step(k, pose, a, new, path):
    fly(pose, k.commands[a], k.accel, k.dt, k.n_sub, k.rest, k.seg, new, path)


@njit(cache=True, inline="always")
def _k_walk_start(k, key, w, out):
    drone_walk_start(key, w, k.lo, k.hi, out)


@njit(cache=True, inline="always")
def _k_pose_at(k, row, out):
    set_pose(out, row)


sim_reset.register(DroneKinematics, _k_reset)
sim_available.register(DroneKinematics, _k_available)
sim_step.register(DroneKinematics, _k_step)
sim_walk_start.register(DroneKinematics, _k_walk_start)
sim_pose_at.register(DroneKinematics, _k_pose_at)


# the simulators --------------------------------------------------------------------
class _DroneBase:
    """What both drone simulators share: sizes, streams, the state check and the
    kinematic availability (the MuJoCo drone's actions are masked by the same exact
    prediction from its measured state)."""

    world = "drone"
    pose_size = POSE_SIZE
    goal_dims = 3
    n_actions = N_DRONE_ACTIONS
    streams = (STREAM_DRONE_START, STREAM_DRONE_EXPLORE, STREAM_DRONE_GOALS)
    compiled = False
    config: DroneConfig
    pose: np.ndarray

    def _setup(self, config: DroneConfig | None) -> None:
        self.config = config or DroneConfig()
        self.commands = self.config.commands()
        self.pose = np.zeros(POSE_SIZE)
        self._seg = np.zeros((3, 4))
        self._end = np.zeros(POSE_SIZE)

    def available_at(self, pose: np.ndarray, mask: np.ndarray) -> int:
        c = self.config
        return int(drone_available(pose, self.commands, c.accel, c.action_time,
                                   c.ends == "rest", c.lo, c.hi, mask, self._seg, self._end))

    def available(self) -> np.ndarray:
        """uint8 mask of the actions whose trajectory keeps the drone in the volume."""
        mask = np.zeros(N_DRONE_ACTIONS, np.uint8)
        self.available_at(self.pose, mask)
        return mask

    def predict(self, pose: np.ndarray, action: int, path: np.ndarray | None = None
                ) -> np.ndarray:
        """The kinematic state after ``action`` from ``pose`` (and every simulation step's
        in ``path``)."""
        c = self.config
        out = np.zeros(POSE_SIZE)
        fly(np.ascontiguousarray(pose, dtype=np.float64), self.commands[action], c.accel, c.dt,
            c.steps_per_action, c.ends == "rest", self._seg, out,
            NO_PATH if path is None else path)
        return out


class DroneKinematicSim(_DroneBase):
    """Exact piecewise-constant-acceleration kinematics (compiled)."""

    name = "kinematic"
    compiled = True

    def __init__(self, config: DroneConfig | None = None) -> None:
        self._setup(config)

    @property
    def plugin(self) -> DroneKinematics:
        """What the loops drive: the compiled kinematics."""
        c = self.config
        return DroneKinematics(self.commands, float(c.accel), float(c.dt), int(c.steps_per_action),
                               c.lo, c.hi, c.ends == "rest", np.zeros((3, 4)),
                               np.zeros(POSE_SIZE))

    def reset(self, pose) -> None:
        """Place the drone at ``pose``: (x, y, z) at rest, or (x, y, z, vx, vy, vz)."""
        self.pose = check_state(pose, self.config)

    def step(self, action: int, path: np.ndarray | None = None) -> np.ndarray:
        """Hold ``action`` for one action time; the new state. ``path`` ((45 + 1, 6)) gets
        the state at every simulation step."""
        self.pose = self.predict(self.pose, check_action(action), path)
        return self.pose.copy()


MJCF = """
<mujoco model="drone-volume">
  <option timestep="{timestep}" integrator="implicitfast"/>
  <worldbody>
    <geom name="floor" type="box" pos="{half} {half} -0.05" size="{halfw} {halfw} 0.05"/>
    <geom name="ceiling" type="box" pos="{half} {half} {far}" size="{halfw} {halfw} 0.05"/>
    <geom name="wall_s" type="box" pos="{half} -0.05 {half}" size="{halfw} 0.05 {halfw}"/>
    <geom name="wall_n" type="box" pos="{half} {far} {half}" size="{halfw} 0.05 {halfw}"/>
    <geom name="wall_w" type="box" pos="-0.05 {half} {half}" size="0.05 {halfw} {halfw}"/>
    <geom name="wall_e" type="box" pos="{far} {half} {half}" size="0.05 {halfw} {halfw}"/>
    <body name="drone" pos="0 0 0" gravcomp="1">
      <joint name="x" type="slide" axis="1 0 0"/>
      <joint name="y" type="slide" axis="0 1 0"/>
      <joint name="z" type="slide" axis="0 0 1"/>
      <geom name="hull" type="sphere" size="{radius}" mass="{mass}" friction="0.2 0.005 0.0001"/>
    </body>
  </worldbody>
  <actuator>
    <velocity name="vx" joint="x" kv="{kv}" forcelimited="true" forcerange="-{force} {force}"/>
    <velocity name="vy" joint="y" kv="{kv}" forcelimited="true" forcerange="-{force} {force}"/>
    <velocity name="vz" joint="z" kv="{kv}" forcelimited="true" forcerange="-{force} {force}"/>
  </actuator>
</mujoco>
"""


@dataclass(frozen=True)
class DroneMujocoOptions:
    """Physics settings of the MuJoCo drone (not from a source: a Crazyflie-sized body
    with a stiff velocity loop)."""

    timestep: float = 0.005  # physics step (s); 10 of them make one 50 ms simulation step
    kv: float = 1.5  # velocity servo gain (N s / m): a 20 ms time constant on 30 g
    mass: float = 0.03  # kg; the Crazyflie 2.1 is 27 g
    thrust_margin: float = 1.5  # force limit per axis over mass x accel

    def __post_init__(self) -> None:
        for f in fields(self):
            v = getattr(self, f.name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) \
                    or v <= 0:
                raise InputError(f"mujoco {f.name} {v!r} is not a finite number > 0")


class DroneMujocoSim(_DroneBase):
    """The drone in MuJoCo: a sphere on velocity servos tracking the kinematic reference,
    solid walls (module docstring)."""

    name = "mujoco"

    def __init__(self, config: DroneConfig | None = None,
                 options: DroneMujocoOptions | None = None) -> None:
        self._setup(config)
        self.options = options or DroneMujocoOptions()
        c, o = self.config, self.options
        self._mj, self.model, self.data, self.substeps = load_mujoco(c.dt, o.timestep,
                                                                     drone_xml(c, o))
        self._ref = np.zeros((c.steps_per_action + 1, POSE_SIZE))

    def _read(self) -> np.ndarray:
        return np.concatenate([self.data.qpos[:3], self.data.qvel[:3]])

    def reset(self, pose) -> None:
        state = check_state(pose, self.config)
        mj, m, d = self._mj, self.model, self.data
        mj.mj_resetData(m, d)
        d.qpos[:3] = state[:3]
        d.qvel[:3] = state[3:]
        d.ctrl[:] = state[3:]
        mj.mj_forward(m, d)
        self.pose = self._read()

    def step(self, action: int, path: np.ndarray | None = None) -> np.ndarray:
        """Track the kinematic reference of ``action`` from the measured state for one
        action time: each 50 ms the velocity that reaches the reference's next point."""
        a = check_action(action)
        c = self.config
        ref = self._ref
        self.predict(self.pose, a, ref)
        mj, m, d = self._mj, self.model, self.data
        if path is not None:
            path[0] = self.pose
        for i in range(c.steps_per_action):
            d.ctrl[:] = (ref[i + 1, :3] - d.qpos[:3]) / c.dt
            mj.mj_step(m, d, nstep=self.substeps)
            if path is not None:
                path[i + 1] = self._read()
        self.pose = self._read()
        return self.pose.copy()

    @property
    def plugin(self) -> DroneMujocoSim:
        """What the loops drive: this object, through the Python functions registered below
        (the loops then run as plain Python, physics-bound anyway)."""
        return self


def _mj_reset(sim: DroneMujocoSim, start: np.ndarray, pose: np.ndarray) -> None:
    sim.reset(start)
    pose[:] = sim.pose


def _mj_step(sim: DroneMujocoSim, pose: np.ndarray, a: int, new: np.ndarray,
             path: np.ndarray) -> None:
    new[:] = sim.step(a, path if path.shape[0] else None)


def _mj_walk_start(sim: DroneMujocoSim, key, w, out: np.ndarray) -> None:
    drone_walk_start(key, w, sim.config.lo, sim.config.hi, out)


sim_reset.register(DroneMujocoSim, _mj_reset)
sim_available.register(DroneMujocoSim, lambda sim, pose, mask: sim.available_at(pose, mask))
sim_step.register(DroneMujocoSim, _mj_step)
sim_walk_start.register(DroneMujocoSim, _mj_walk_start)
sim_pose_at.register(DroneMujocoSim, lambda sim, row, out: set_pose(out, row))


def drone_xml(config: DroneConfig, options: DroneMujocoOptions) -> str:
    """The MJCF of the volume and the drone for these settings."""
    half = config.arena / 2.0
    return MJCF.format(timestep=options.timestep, half=half, halfw=half + 0.1,
                       far=config.arena + 0.05, radius=config.body_radius, mass=options.mass,
                       kv=options.kv,
                       force=options.thrust_margin * options.mass * config.accel)


def make_drone_sim(name: str, config: DroneConfig | None = None,
                   **options: Any) -> DroneKinematicSim | DroneMujocoSim:
    """The simulator called ``name`` (``kinematic`` or ``mujoco``)."""
    if name == "kinematic":
        if options:
            raise InputError(f"the kinematic simulator takes no options ({', '.join(options)})")
        return DroneKinematicSim(config)
    if name == "mujoco":
        return DroneMujocoSim(config, DroneMujocoOptions(**options))
    raise InputError(f"unknown simulator {name!r}; allowed: {', '.join(SIMS)}")


def check_state(pose, config: DroneConfig) -> np.ndarray:
    """A state (x, y, z[, vx, vy, vz]) as six float64s, checked: inside the volume, at most
    the drone's speed (InputError otherwise)."""
    p = np.array(pose, dtype=np.float64).reshape(-1)
    if p.shape not in ((3,), (6,)) or not np.all(np.isfinite(p)):
        raise InputError(f"state {pose!r} is not three or six finite numbers "
                         f"(x, y, z[, vx, vy, vz])")
    if p.shape == (3,):
        p = np.concatenate([p, np.zeros(3)])
    if not np.all((p[:3] >= config.lo) & (p[:3] <= config.hi)):
        raise InputError(f"position ({p[0]:g}, {p[1]:g}, {p[2]:g}) puts the drone outside the "
                         f"volume (allowed: {config.lo:g}..{config.hi:g} m on every axis)")
    if float(np.sqrt((p[3:] ** 2).sum())) > config.speed * (1.0 + 1e-9):
        raise InputError(f"velocity ({p[3]:g}, {p[4]:g}, {p[5]:g}) is faster than the drone's "
                         f"{config.speed:g} m/s")
    return p


def check_action(action) -> int:
    if isinstance(action, bool) or int(action) != action or not 0 <= action < N_DRONE_ACTIONS:
        raise InputError(f"action {action!r} is not an integer in 0..{N_DRONE_ACTIONS - 1}")
    return int(action)
