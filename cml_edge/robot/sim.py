"""The continuous robot arena (paper 2.5, 3.5): a differential-drive robot in a walled square.

The robot is the iRobot Create the paper drove in Webots. Its eight actions are the
wheel-speed pairs of the paper's Table 1, each held for 64 simulation steps. Two
simulators sit behind one interface (:class:`RobotSim`):

- ``kinematic`` (default): exact unicycle arcs, compiled with Numba. Within one
  simulation step the wheel speeds are constant, so the robot follows an arc of
  forward speed v = r (w_l + w_r) / 2 and turn rate w = r (w_r - w_l) / L exactly
  (no integration error; the only rounding is float64's).
- ``mujoco`` (the ``robot`` extra, imported only when asked for): a rigid-body model
  built from the MJCF string :data:`MJCF` below: a 2.3 kg chassis, two wheels on hinges
  driven by velocity-controlled motors with a torque limit, a frictionless front
  caster, wheel-floor friction, and four solid walls; physics step 4 ms (8 per 32 ms
  simulation step). The wheels collide as spheres of the wheel radius, one contact
  point each, so the track is the axle length (cylinder wheels touch the floor along
  their width and scrub in turns, turning less than commanded). It adds inertia, motor
  lag and, if the friction is lowered or the torque raised, slip. Starting from rest,
  an action ends 1-3 cm from the kinematic prediction and turns 1-6 % less; repeated
  in motion, the turn is within 1 %.

Choices the paper leaves open, made here (all are fields of :class:`RobotConfig`):

- Geometry. Wheel radius 0.031 m and axle length 0.271756 m (wheels at +-0.135878 m),
  the numbers of Webots' Create model (as read by public Webots wrappers of it). Webots
  caps the Create's wheels at 16 rad/s, so omega_max = 5 pi = 15.7 rad/s is within its
  range. Body radius 0.17 m (the Create is ~0.34 m across).
- Step length. 32 ms, the Webots default ``basicTimeStep``; an action lasts
  64 x 32 ms = 2.048 s, so action 2 (both wheels at 0.5 omega_max) drives
  0.031 x 7.854 x 2.048 = 0.499 m, one "cell" of the grid and twice the goal radius.
- Table 1's row 8 is printed as (0.75, 0.5), a duplicate of row 3. Read here as
  (-0.5, -0.75), the mirror of row 6, so the set is symmetric: forward-left, forward,
  forward-right, sharp left, sharp right, back-right, back, back-left.
- Walls. The arena is [0, 30] m square; the robot's disc must stay inside, so its
  centre stays in [0.17, 29.83]. An action is available when the kinematic prediction
  of its whole arc (checked at each of its 64 simulation steps; between two of them the
  arc bulges by < 0.1 mm) keeps the centre there. The planner masks unavailable
  actions; exploration draws only among available ones (as the grid does). In the
  MuJoCo mode the same kinematic prediction decides availability and the walls are
  also solid, so a slipping robot is stopped by them, not teleported.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import Any, NamedTuple, Protocol

import numpy as np
from numba import njit

from cml_edge.core.records import Record
from cml_edge.errors import InputError
from cml_edge.jit.rng import uniform
from cml_edge.jit.routing import routed
from cml_edge.protocol import STREAM_ROBOT_EXPLORE, STREAM_ROBOT_GOALS, STREAM_ROBOT_START

N_ROBOT_ACTIONS = 8

# Table 1 (omega_l / omega_max, omega_r / omega_max); row 8 is the mirror of row 6 (above).
WHEEL_FRACTIONS = np.array(
    [[0.5, 0.75], [0.5, 0.5], [0.75, 0.5], [0.2, 0.9], [0.9, 0.2], [-0.75, -0.5],
     [-0.5, -0.5], [-0.5, -0.75]], dtype=np.float64)
SIMS = ("kinematic", "mujoco")


@dataclass(frozen=True)
class RobotConfig(Record):
    """Arena, robot geometry and timing (sources in the module docstring)."""

    what = "robot config"

    arena: float = 30.0
    wheel_radius: float = 0.031
    axle_length: float = 0.271756
    body_radius: float = 0.17
    omega_max: float = 5.0 * math.pi
    dt: float = 0.032
    steps_per_action: int = 64

    def __post_init__(self) -> None:
        for name in ("arena", "wheel_radius", "axle_length", "omega_max", "dt"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) \
                    or v <= 0:
                raise InputError(f"robot {name} {v!r} is not a finite number > 0")
        if not math.isfinite(self.body_radius) or self.body_radius < 0:
            raise InputError(f"robot body_radius {self.body_radius!r} is not a finite number >= 0")
        if 2 * self.body_radius >= self.arena:
            raise InputError(f"robot body_radius {self.body_radius} does not fit in an arena of "
                             f"side {self.arena}")
        v = self.steps_per_action
        if isinstance(v, bool) or int(v) != v or v < 1:
            raise InputError(f"steps_per_action {v!r} is not a positive integer")

    @property
    def lo(self) -> float:
        """Lowest x or y the robot's centre may take."""
        return float(self.body_radius)

    @property
    def hi(self) -> float:
        """Highest x or y the robot's centre may take."""
        return float(self.arena - self.body_radius)

    @property
    def action_time(self) -> float:
        """Seconds one action lasts (64 x 32 ms = 2.048 s by default)."""
        return self.dt * self.steps_per_action

    def wheel_speeds(self) -> np.ndarray:
        """(8, 2) wheel speeds (omega_l, omega_r) in rad/s of the eight actions."""
        return WHEEL_FRACTIONS * self.omega_max

    def twists(self) -> np.ndarray:
        """(8, 2) forward speed v (m/s) and turn rate w (rad/s) of each action."""
        w = self.wheel_speeds()
        r = self.wheel_radius
        return np.stack([r * (w[:, 0] + w[:, 1]) / 2.0,
                         r * (w[:, 1] - w[:, 0]) / self.axle_length], axis=1)



def action_geometry(config: RobotConfig) -> dict[str, np.ndarray]:
    """Per action, in the robot's frame: the chord (dx forward, dy left), its length, the
    turn and the arc length of one full action (closed form; for documentation and tests)."""
    tw = config.twists()
    T = config.action_time
    turn = tw[:, 1] * T
    arc = tw[:, 0] * T
    chord = np.zeros((N_ROBOT_ACTIONS, 2))
    for a in range(N_ROBOT_ACTIONS):
        v, w = tw[a]
        if w == 0.0:
            chord[a] = (v * T, 0.0)
        else:
            chord[a] = (v / w * math.sin(w * T), v / w * (1.0 - math.cos(w * T)))
    return {"chord": chord, "chord_length": np.hypot(chord[:, 0], chord[:, 1]), "turn": turn,
            "arc_length": np.abs(arc)}


# compiled kinematics ---------------------------------------------------------------
@njit(cache=True)
def wrap_angle(th):
    """th wrapped to [-pi, pi)."""
    return (th + math.pi) % (2.0 * math.pi) - math.pi


@njit(cache=True)
def arc_step(x, y, th, v, w, dt):
    """One simulation step at constant wheel speeds: the exact unicycle arc."""
    if w == 0.0:
        return x + v * dt * math.cos(th), y + v * dt * math.sin(th), th
    th1 = th + w * dt
    rho = v / w
    return x + rho * (math.sin(th1) - math.sin(th)), y - rho * (math.cos(th1) - math.cos(th)), th1


@njit(cache=True)
def drive(pose, v, w, dt, n, lo, hi, out, path):
    """Hold the twist (v, w) for ``n`` simulation steps from ``pose`` (x, y, theta).

    Writes the end pose to ``out`` (theta wrapped) and, when ``path`` has n + 1 rows, every
    intermediate pose to it. Returns True when the centre stayed within [lo, hi]^2 at every
    simulation step (the pose is written either way).
    """
    x = pose[0]
    y = pose[1]
    th = pose[2]
    record = path.shape[0] == n + 1
    if record:
        path[0, 0] = x
        path[0, 1] = y
        path[0, 2] = th
    inside = True
    for i in range(n):
        x, y, th = arc_step(x, y, th, v, w, dt)
        if x < lo or x > hi or y < lo or y > hi:
            inside = False
        if record:
            path[i + 1, 0] = x
            path[i + 1, 1] = y
            path[i + 1, 2] = th
    out[0] = x
    out[1] = y
    out[2] = wrap_angle(th)
    return inside


@njit(cache=True)
def available_actions(pose, twists, dt, n, lo, hi, mask, work, nopath):
    """mask[a] = 1 when action a's predicted arc keeps the robot inside; returns how many.

    Shortcut (exact): no point of an action's path is farther from its start than its arc
    length |v| n dt, so a robot farther than the longest of them from every wall has all
    actions available, and the arcs need not be driven.
    """
    reach = 0.0
    for a in range(twists.shape[0]):
        reach = max(reach, abs(twists[a, 0]) * dt * n)
    room = min(pose[0] - lo, hi - pose[0], pose[1] - lo, hi - pose[1])
    if room > reach * (1.0 + 1e-9) + 1e-9:
        for a in range(twists.shape[0]):
            mask[a] = 1
        return twists.shape[0]
    count = 0
    for a in range(twists.shape[0]):
        ok = drive(pose, twists[a, 0], twists[a, 1], dt, n, lo, hi, work, nopath)
        mask[a] = 1 if ok else 0
        count += mask[a]
    return count


@njit(cache=True)
def nth_available(mask, r):
    """The r-th available action (ascending), -1 if there is none."""
    for a in range(mask.shape[0]):
        if mask[a]:
            if r == 0:
                return a
            r -= 1
    return -1


NO_PATH = np.zeros((0, 3))


# the simulator plug-ins of the loops ---------------------------------------------------
@routed
def sim_reset(sim, start, pose):
    """Place the robot at ``start``, at rest; ``pose`` gets the pose it is at."""


@routed
def sim_available(sim, pose, mask):
    """mask[a] = 1 when action a's predicted arc from ``pose`` stays inside; returns how many."""


@routed
def sim_step(sim, pose, a, new, path):
    """Hold action ``a`` from ``pose`` for one action time: ``new`` gets the pose after it
    and ``path`` ((steps per action + 1, 3), or (0, 3) for none) every simulation step."""


@routed
def sim_walk_start(sim, key, w, out):
    """``out`` gets the start pose of training walk ``w``, drawn from ``key``'s stream."""


@routed
def sim_pose_at(sim, row, out):
    """``out`` gets the pose a row of a ``sim_step`` path stands for (the robot's heading
    wrapped): where a run stopped mid-action."""


@njit(cache=True)
def walk_start(key, w, lo, hi, out):
    """Walk w's start pose: uniform over the positions the robot fits, uniform heading."""
    base = np.uint64(3) * np.uint64(w)
    out[0] = lo + (hi - lo) * uniform(key, base)
    out[1] = lo + (hi - lo) * uniform(key, base + np.uint64(1))
    out[2] = -math.pi + 2.0 * math.pi * uniform(key, base + np.uint64(2))


@njit(cache=True)
def pose_of_row(row, out):
    """The pose a path row stands for: (x, y) and the heading wrapped."""
    out[0] = row[0]
    out[1] = row[1]
    out[2] = wrap_angle(row[2])


class Kinematics(NamedTuple):
    """The exact kinematics as the loops' simulator (compiled): a function of the pose."""

    twists: np.ndarray  # (8, 2) forward speed and turn rate of each action
    dt: float
    n_sub: int  # simulation steps per action
    lo: float
    hi: float
    work: np.ndarray  # (3) work vector
    nopath: np.ndarray  # (0, 3)


@njit(cache=True, inline="always")
def set_pose(dst, src):
    """dst[:] = src for a pose (the robot's x, y, theta; any world's), element by element:
    an array copied into a slice allocates a temporary, which the loops, kernels
    (:mod:`cml_edge.jit.kernel`), cannot."""
    for i in range(dst.shape[0]):
        dst[i] = src[i]


@njit(cache=True, inline="always")
def kinematics_reset(k, start, pose):
    set_pose(pose, start)


@njit(cache=True, inline="always")
def kinematics_available(k, pose, mask):
    return available_actions(pose, k.twists, k.dt, k.n_sub, k.lo, k.hi, mask, k.work, k.nopath)


@njit(cache=True, inline="always")
def kinematics_step(k, pose, a, new, path):
    drive(pose, k.twists[a, 0], k.twists[a, 1], k.dt, k.n_sub, k.lo, k.hi, new, path)


@njit(cache=True, inline="always")
def kinematics_walk_start(k, key, w, out):
    walk_start(key, w, k.lo, k.hi, out)


@njit(cache=True, inline="always")
def kinematics_pose_at(k, row, out):
    pose_of_row(row, out)


sim_reset.register(Kinematics, kinematics_reset)
sim_available.register(Kinematics, kinematics_available)
sim_step.register(Kinematics, kinematics_step)
sim_walk_start.register(Kinematics, kinematics_walk_start)
sim_pose_at.register(Kinematics, kinematics_pose_at)


# the simulators --------------------------------------------------------------------
class RobotSim(Protocol):
    """What the CML drives: a robot with a pose (x, y, theta) and eight actions. The loops
    (:mod:`cml_edge.robot.training`, :mod:`cml_edge.robot.planning`) read its sizes and
    streams here, so another vehicle (:mod:`cml_edge.drone.sim`) is another simulator."""

    name: str
    world: str  # "robot"
    config: RobotConfig
    pose: np.ndarray
    pose_size: int  # 3: x, y, theta
    goal_dims: int  # 2: a goal is (x, y); distances are over the pose's first goal_dims
    n_actions: int  # 8
    streams: tuple[int, int, int]  # walk starts, exploration, evaluation goals
    compiled: bool  # its plug-in is a NamedTuple the compiled loops take

    def reset(self, pose: np.ndarray) -> None:
        """Place the robot at ``pose`` (x, y, theta), at rest."""

    def available(self) -> np.ndarray:
        """uint8 mask of the actions whose predicted arc keeps the robot in the arena."""

    def step(self, action: int, path: np.ndarray | None = None) -> np.ndarray:
        """Hold ``action`` for one action time; the new pose. ``path`` ((64 + 1, 3)) gets
        the pose at every simulation step."""

    @property
    def plugin(self) -> Any:
        """What the training and planning loops drive (:func:`sim_reset`, :func:`sim_step`,
        :func:`sim_available` are registered for its type)."""


class _ArcMask:
    """``available`` for both simulators: an action is available when its kinematic arc
    from the current pose stays inside the walls (the paper's unavailable moves)."""

    config: RobotConfig
    pose: np.ndarray
    twists: np.ndarray
    _work: np.ndarray
    world = "robot"
    pose_size = 3
    goal_dims = 2
    n_actions = N_ROBOT_ACTIONS
    streams = (STREAM_ROBOT_START, STREAM_ROBOT_EXPLORE, STREAM_ROBOT_GOALS)
    compiled = False

    def available(self) -> np.ndarray:
        c = self.config
        mask = np.zeros(N_ROBOT_ACTIONS, np.uint8)
        available_actions(self.pose, self.twists, c.dt, c.steps_per_action, c.lo, c.hi, mask,
                          self._work, NO_PATH)
        return mask


class KinematicSim(_ArcMask):
    """Exact unicycle-arc kinematics (compiled)."""

    name = "kinematic"
    compiled = True

    def __init__(self, config: RobotConfig | None = None) -> None:
        self.config = config or RobotConfig()
        self.twists = self.config.twists()
        self.pose = np.zeros(3)
        self._work = np.zeros(3)

    @property
    def plugin(self) -> Kinematics:
        """What the loops drive: the compiled kinematics."""
        c = self.config
        return Kinematics(self.twists, c.dt, c.steps_per_action, c.lo, c.hi, np.zeros(3),
                          NO_PATH)

    def reset(self, pose) -> None:
        self.pose = _check_pose(pose, self.config)

    def step(self, action: int, path: np.ndarray | None = None) -> np.ndarray:
        c = self.config
        a = _check_action(action)
        out = np.zeros(3)
        drive(self.pose, self.twists[a, 0], self.twists[a, 1], c.dt, c.steps_per_action, c.lo,
              c.hi, out, NO_PATH if path is None else path)
        self.pose = out
        return out.copy()


MJCF = """
<mujoco model="create-arena">
  <compiler angle="radian"/>
  <option timestep="{timestep}" integrator="implicitfast"/>
  <worldbody>
    <geom name="floor" type="plane" pos="{half} {half} 0" size="{halfw} {halfw} 0.1"
          friction="{friction} 0.005 0.0001"/>
    <geom name="wall_s" type="box" pos="{half} -0.05 0.15" size="{halfw} 0.05 0.15"/>
    <geom name="wall_n" type="box" pos="{half} {far} 0.15" size="{halfw} 0.05 0.15"/>
    <geom name="wall_w" type="box" pos="-0.05 {half} 0.15" size="0.05 {halfw} 0.15"/>
    <geom name="wall_e" type="box" pos="{far} {half} 0.15" size="0.05 {halfw} 0.15"/>
    <body name="chassis" pos="{half} {half} 0">
      <freejoint name="root"/>
      <inertial pos="{com_x} 0 0.05" mass="{mass}" diaginertia="0.025 0.025 0.04"/>
      <geom name="shell" type="cylinder" size="{body_radius} 0.03" pos="0 0 0.07"
            contype="1" conaffinity="1" friction="0.3 0.005 0.0001"/>
      <geom name="caster" type="sphere" size="{caster} 0 0" pos="{caster_x} 0 {caster}"
            contype="0" conaffinity="0"/>
      <body name="left_wheel" pos="0 {half_axle} {wheel_radius}">
        <joint name="left" type="hinge" axis="0 1 0"/>
        <geom type="sphere" size="{wheel_radius}" mass="0.1"
              friction="{friction} 0.0001 0.0001"/>
      </body>
      <body name="right_wheel" pos="0 -{half_axle} {wheel_radius}">
        <joint name="right" type="hinge" axis="0 1 0"/>
        <geom type="sphere" size="{wheel_radius}" mass="0.1"
              friction="{friction} 0.0001 0.0001"/>
      </body>
    </body>
  </worldbody>
  <contact>
    <pair geom1="caster" geom2="floor" condim="1"/>
  </contact>
  <actuator>
    <velocity name="left_motor" joint="left" kv="{kv}" forcelimited="true"
              forcerange="-{torque} {torque}"/>
    <velocity name="right_motor" joint="right" kv="{kv}" forcelimited="true"
              forcerange="-{torque} {torque}"/>
  </actuator>
</mujoco>
"""


@dataclass(frozen=True)
class MujocoOptions:
    """Physics settings of the MuJoCo robot (not in the paper; chosen for a Create-like
    robot that rolls without slipping at Table 1's speeds)."""

    timestep: float = 0.004  # physics step (s); 8 of them make one 32 ms simulation step
    friction: float = 1.0  # wheel-floor sliding friction coefficient
    kv: float = 1.0  # velocity servo gain (N m s / rad): stiff speed control, as a motor PID
    torque: float = 0.2  # motor torque limit (N m): 6.5 N at the rim, below mu m g / 2
    mass: float = 2.3  # chassis mass (kg); the Create is ~2.2 kg without payload
    com_x: float = 0.04  # centre of mass ahead of the axle, over the caster side (m)

    def __post_init__(self) -> None:
        for f in fields(self):
            v = getattr(self, f.name)
            if not math.isfinite(v) or (v <= 0 and f.name != "com_x"):
                raise InputError(f"mujoco {f.name} {v!r} is not a finite number > 0")


class MujocoSim(_ArcMask):
    """The Create on MuJoCo: velocity-controlled wheels, a caster, friction, solid walls."""

    name = "mujoco"

    def __init__(self, config: RobotConfig | None = None,
                 options: MujocoOptions | None = None) -> None:
        self.config = config or RobotConfig()
        self.options = options or MujocoOptions()
        c, o = self.config, self.options
        self._mj, self.model, self.data, self.substeps = load_mujoco(c.dt, o.timestep,
                                                                     mujoco_xml(c, o))
        self.twists = c.twists()
        self.wheels = c.wheel_speeds()
        self._work = np.zeros(3)
        self.pose = np.zeros(3)

    def reset(self, pose) -> None:
        pose = _check_pose(pose, self.config)
        mj, m, d = self._mj, self.model, self.data
        mj.mj_resetData(m, d)
        d.qpos[0:3] = (pose[0], pose[1], 0.0)
        half = pose[2] / 2.0
        d.qpos[3:7] = (math.cos(half), 0.0, 0.0, math.sin(half))
        d.ctrl[:] = 0.0
        mj.mj_forward(m, d)
        self.pose = self._read_pose()

    def _read_pose(self) -> np.ndarray:
        q = self.data.qpos
        w, x, y, z = q[3], q[4], q[5], q[6]
        th = math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
        return np.array([q[0], q[1], th])

    def step(self, action: int, path: np.ndarray | None = None) -> np.ndarray:
        a = _check_action(action)
        mj, m, d = self._mj, self.model, self.data
        d.ctrl[0] = self.wheels[a, 0]
        d.ctrl[1] = self.wheels[a, 1]
        n = self.config.steps_per_action
        if path is None:
            mj.mj_step(m, d, nstep=self.substeps * n)
        else:
            path[0] = self.pose
            for i in range(n):
                mj.mj_step(m, d, nstep=self.substeps)
                path[i + 1] = self._read_pose()
        self.pose = self._read_pose()
        return self.pose.copy()

    @property
    def plugin(self) -> MujocoSim:
        """What the loops drive: this object, through the Python functions registered below
        (the loops then run as plain Python, physics-bound anyway)."""
        return self

    def tilt(self) -> float:
        """The chassis's tilt from upright (radians): stays ~0 unless the robot tips."""
        zz = self.data.xmat[self.model.body("chassis").id][8]
        return float(math.acos(max(-1.0, min(1.0, zz))))


def _mujoco_reset(sim: MujocoSim, start: np.ndarray, pose: np.ndarray) -> None:
    sim.reset(start)
    pose[:] = sim.pose


def _mujoco_available(sim: MujocoSim, pose: np.ndarray, mask: np.ndarray) -> int:
    c = sim.config  # at ``pose``, not the robot's: the fidelity replay asks at recorded poses
    return int(available_actions(pose, sim.twists, c.dt, c.steps_per_action, c.lo, c.hi, mask,
                                 sim._work, NO_PATH))


def _mujoco_step(sim: MujocoSim, pose: np.ndarray, a: int, new: np.ndarray,
                 path: np.ndarray) -> None:
    new[:] = sim.step(a, path if path.shape[0] else None)


def _mujoco_walk_start(sim: MujocoSim, key, w, out: np.ndarray) -> None:
    walk_start(key, w, sim.config.lo, sim.config.hi, out)


sim_reset.register(MujocoSim, _mujoco_reset)
sim_available.register(MujocoSim, _mujoco_available)
sim_step.register(MujocoSim, _mujoco_step)
sim_walk_start.register(MujocoSim, _mujoco_walk_start)
sim_pose_at.register(MujocoSim, lambda sim, row, out: pose_of_row(row, out))


def load_mujoco(dt: float, timestep: float, xml: str) -> tuple[Any, Any, Any, int]:
    """MuJoCo (imported only now: the ``robot`` extra), the model of ``xml`` and its data,
    and how many physics steps of ``timestep`` make one simulation step ``dt``
    (InputError when MuJoCo is missing or the timestep does not divide the step)."""
    try:
        import mujoco
    except ImportError:
        raise InputError("the mujoco simulator needs the mujoco package "
                         "(pip install 'cml-edge[robot]')") from None
    substeps = dt / timestep
    if abs(substeps - round(substeps)) > 1e-9 or round(substeps) < 1:
        raise InputError(f"mujoco timestep {timestep} does not divide the simulation step {dt}")
    model = mujoco.MjModel.from_xml_string(xml)
    return mujoco, model, mujoco.MjData(model), int(round(substeps))


def mujoco_xml(config: RobotConfig, options: MujocoOptions) -> str:
    """The MJCF of the arena and robot for these settings."""
    half = config.arena / 2.0
    return MJCF.format(
        timestep=options.timestep, half=half, halfw=half + 0.1, far=config.arena + 0.05,
        friction=options.friction, com_x=options.com_x, mass=options.mass,
        body_radius=config.body_radius, caster=0.015, caster_x=0.8 * config.body_radius,
        half_axle=config.axle_length / 2.0, wheel_radius=config.wheel_radius, kv=options.kv,
        torque=options.torque)


def make_sim(name: str, config: RobotConfig | None = None, **options: Any) -> RobotSim:
    """The simulator called ``name`` (``kinematic`` or ``mujoco``)."""
    if name == "kinematic":
        if options:
            raise InputError(f"the kinematic simulator takes no options ({', '.join(options)})")
        return KinematicSim(config)
    if name == "mujoco":
        return MujocoSim(config, MujocoOptions(**options))
    raise InputError(f"unknown simulator {name!r}; allowed: {', '.join(SIMS)}")


def _check_pose(pose, config: RobotConfig) -> np.ndarray:
    p = np.array(pose, dtype=np.float64).reshape(-1)
    if p.shape != (3,) or not np.all(np.isfinite(p)):
        raise InputError(f"pose {pose!r} is not three finite numbers (x, y, theta)")
    if not (config.lo <= p[0] <= config.hi and config.lo <= p[1] <= config.hi):
        raise InputError(f"pose ({p[0]}, {p[1]}) puts the robot outside the arena (allowed: "
                         f"{config.lo:g}..{config.hi:g} m for x and y)")
    p[2] = wrap_angle(p[2])
    return p


def _check_action(action) -> int:
    if isinstance(action, bool) or int(action) != action or not 0 <= action < N_ROBOT_ACTIONS:
        raise InputError(f"action {action!r} is not an integer in 0..{N_ROBOT_ACTIONS - 1}")
    return int(action)
