"""How the robot's pose becomes the CML's observation o (paper 2.5; choices made here).

The CML is the package's (:mod:`cml_edge.core.cml`), unchanged; what the robot adds is its
observation. The pose is (x, y, theta), p = (x, y), c = 15 m the arena centre, S = 30 m its
side, as the grid scales its cells. ``observation``:

- ``xy`` (the paper's, N_i = 2): o = (p - c) / S in the world frame.
- ``heading`` (N_i = 4): the robot observes (x, y, cos theta, sin theta) and reads every
  observation of a decision in the frame of its heading at that moment (as wheel
  odometry and a compass give it): o = (R(-theta_t) (p - c) / S, h cos(theta - theta_t),
  h sin(theta - theta_t)), with h = ``heading_scale``. At step t, o_t and o_{t+1} are
  both read in the frame of theta_t; in planning, o and o* in the frame of the current
  heading. Why: Table 1's actions are arcs relative to the heading, so in any fixed
  frame an action's displacement o_{t+1} - o_t depends on theta, and the CML's model
  s_{t+1} = s_t + W_v a_t (one fixed vector per action, with s = W_q o linear) can only
  learn its average over headings, which is ~0. Read in the heading's frame, the
  displacement of action a is the same for every pose (its chord and its turn), and the
  CML's model is exact.
- ``heading-world`` (N_i = 4): (x, y, h cos theta, h sin theta) in the world frame, the
  literal reading. Kept to measure the point above.

The goal (paper 2.1: o* is the goal's observation) has no heading. ``goal_heading``:

- ``bearing`` (default): o* carries the direction from the robot to the goal, re-read at
  every decision (the heading a straight drive would arrive with). Its heading part
  h (cos b - 1, sin b), b the goal's bearing in the robot's frame, rewards the actions
  that turn towards the goal; near the goal it dominates, so the robot faces the goal
  before the last moves.
- ``keep``: o* carries the robot's current heading, so the heading part of
  d = W_q (o* - o) is zero. A turning action's learned vector W_v a is mostly its turn,
  which then earns no utility (the normalised utility even divides it out), so the robot
  circles the goal at ~0.3 m; measured worse (docs/paper.md, "The wheeled robot").

Utility. The robot's default is the paper's ``raw`` inner product u = W_v^T d (the grid's
default divides by W_v's column norms). Near the goal the discrete arcs (0.41-0.60 m
chords) against the 0.25 m circle make 2-cycles; the normalised utility ranks actions by
direction alone and falls into them more often (measured in docs/paper.md).

Scaling. o is centred on the arena and divided by its side, as the grid does; the
heading's unit vector is divided by the side too (h = 1/30), so one radian of turning
weighs about as much in the embedding as one metre of travel. Eq. 3's per-walk summed
update has gain lr_q x steps x E|o|^2 <= 0.001 x 900 x (0.5 + h^2) = 0.45 < 1 anywhere
in the arena; training reports it (``eq3_gain``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, NamedTuple

from numba import njit

from cml_edge.core.cml import CMLConfig
from cml_edge.core.records import Record
from cml_edge.errors import InputError
from cml_edge.jit.routing import routed
from cml_edge.sizes import checked_float

OBSERVATIONS = ("xy", "heading", "heading-world")
XY, HEADING, HEADING_WORLD = 0, 1, 2
GOAL_HEADINGS = ("keep", "bearing")
KEEP, BEARING = 0, 1
DEFAULT_UTILITY = "raw"


class RobotFrame(NamedTuple):
    """What :func:`observe` needs of :class:`RobotCMLSettings`, for compiled code."""

    mode: int  # XY, HEADING or HEADING_WORLD
    goal_heading: int  # KEEP or BEARING
    origin: float
    scale: float
    hscale: float  # h, the weight of the heading's components


@dataclass(frozen=True)
class RobotCMLSettings(Record):
    """How the robot's pose is observed (module docstring)."""

    what = "robot CML settings"

    observation: str = "heading"
    goal_heading: str = "bearing"
    heading_scale: float = 1.0 / 30.0
    origin: float = 15.0
    scale: float = 30.0

    def __post_init__(self) -> None:
        if self.observation not in OBSERVATIONS:
            raise InputError(f"unknown observation {self.observation!r}; allowed: "
                             f"{', '.join(OBSERVATIONS)}")
        if self.goal_heading not in GOAL_HEADINGS:
            raise InputError(f"unknown goal heading {self.goal_heading!r}; allowed: "
                             f"{', '.join(GOAL_HEADINGS)}")
        checked_float("heading_scale", self.heading_scale, "heading-scale")
        checked_float("obs_scale", self.scale, "scale")
        if not math.isfinite(self.origin):
            raise InputError(f"origin {self.origin!r} is not finite")

    @property
    def mode(self) -> int:
        return OBSERVATIONS.index(self.observation)

    @property
    def goal_code(self) -> int:
        return GOAL_HEADINGS.index(self.goal_heading)

    @property
    def n_i(self) -> int:
        return 2 if self.observation == "xy" else 4

    def cml_config(self, **overrides: Any) -> CMLConfig:
        """The CML's configuration for this observation (N_i = 2 or 4, the same frame), with
        the robot's default utility, ``raw`` (module docstring)."""
        return CMLConfig(**{"n_i": self.n_i, "obs_scale": self.scale, "obs_origin": self.origin,
                            "utility": DEFAULT_UTILITY, **overrides})

    def frame(self) -> RobotFrame:
        """The numbers the compiled :func:`observe` takes."""
        return RobotFrame(self.mode, self.goal_code, self.origin, self.scale, self.heading_scale)



@njit(cache=True)
def observe_at(frame, ref, x, y, th, out):
    """The observation of the pose (x, y, th) read in the frame of the pose ``ref``."""
    px = (x - frame.origin) / frame.scale
    py = (y - frame.origin) / frame.scale
    if frame.mode == HEADING:
        c = math.cos(ref[2])
        s = math.sin(ref[2])
        out[0] = c * px + s * py
        out[1] = c * py - s * px
        d = th - ref[2]
        out[2] = frame.hscale * math.cos(d)
        out[3] = frame.hscale * math.sin(d)
    else:
        out[0] = px
        out[1] = py
        if frame.mode == HEADING_WORLD:
            out[2] = frame.hscale * math.cos(th)
            out[3] = frame.hscale * math.sin(th)


# the observation plug-ins of the loops, routed by the frame's type (the robot's here, the
# drone's in cml_edge.drone.observation) ------------------------------------------------
@routed
def observe(frame, ref, pose, out):
    """The observation of ``pose`` read in the frame of ``ref`` (module docstring)."""


@routed
def observe_goal(frame, ref, goal, out):
    """o*: the observation of the goal (a row of the goals) read from ``ref``."""


@njit(cache=True, inline="always")
def robot_observe(frame, ref, pose, out):
    observe_at(frame, ref, pose[0], pose[1], pose[2], out)


@njit(cache=True, inline="always")
def robot_observe_goal(frame, ref, goal, out):
    """The goal (x, y) with the heading of ``goal_heading``."""
    gx = goal[0]
    gy = goal[1]
    th = ref[2]
    if frame.goal_heading == BEARING:
        th = math.atan2(gy - ref[1], gx - ref[0])
    observe_at(frame, ref, gx, gy, th, out)


observe.register(RobotFrame, robot_observe)
observe_goal.register(RobotFrame, robot_observe_goal)
