"""The fixed numbers of the evaluation protocol, in one place: the evaluation seed, the
random streams, and the DQN's rewards.

Every random draw of training and exploration (grid and robot), the robot's evaluation
goals, stochastic rounding and device noise is ``uniform(stream_key(seed, STREAM),
counter)`` (:mod:`cml_edge.jit.rng`), one stream per independent use, so that a draw depends
only on (seed, stream, counter). Five draws use NumPy generators seeded from the same
integers instead: the CML's initial weights (:meth:`cml_edge.core.cml.CML.create`, keyed
``[seed, STREAM_INIT]``), the states whose reads the read-SNR metric samples (keyed
``[seed, STREAM_FIDELITY]``, :mod:`cml_edge.core.fidelity`), the grid's evaluation pairs
(:func:`cml_edge.grid.metrics.draw_pairs`) and obstacle cells
(:meth:`cml_edge.grid.arena.GridArena.with_obstacles`), both from the evaluation seed,
and the DQN baseline's evaluation starts (:func:`cml_edge.baselines.dqn.fixed_goal_pairs`).
The gymnasium environments (:mod:`cml_edge.grid.env`, :mod:`cml_edge.robot.env`) draw
from their own ``np_random``, seeded through ``reset(seed=...)`` as gymnasium requires.
"""

from __future__ import annotations

EVAL_SEED = 123
"""Seed of the evaluation pairs, obstacles and robot goals: every method sees the same."""

# random streams (one per independent use) --------------------------------------------------
STREAM_WALK_START = 1
"""The grid: the start cell of each training walk (counter: walk)."""
STREAM_EXPLORE = 2
"""The grid: exploration moves (counters 4n, 4n + 1, 4n + 2 at training step n)."""
STREAM_INIT = 3
"""The CML's initial weights (a NumPy generator keyed [seed, STREAM_INIT])."""
STREAM_FIDELITY = 4
"""The states sampled for the read-SNR metric (a NumPy generator keyed [seed,
STREAM_FIDELITY]; :mod:`cml_edge.core.fidelity`)."""
STREAM_DEVICE = 16
"""Device noise of array ``index`` (0: W_q, 1: W_k, 2: W_v) on stream STREAM_DEVICE + index."""
STREAM_ROBOT_START = 48
"""The robot: start pose of each training walk (counters 3w .. 3w + 2)."""
STREAM_ROBOT_EXPLORE = 49
"""The robot: exploration actions (counter w x steps + t)."""
STREAM_ROBOT_GOALS = 50
"""The robot: evaluation goals of the evaluation seed (counters 2i, 2i + 1)."""
STREAM_DRONE_START = 60
"""The drone: start position of each training walk (counters 3w .. 3w + 2)."""
STREAM_DRONE_EXPLORE = 61
"""The drone: exploration actions (counter w x steps + t)."""
STREAM_DRONE_GOALS = 62
"""The drone: evaluation goals of the evaluation seed (counters 3i .. 3i + 2)."""

# the DQN baseline's rewards (paper Eqs. 6 and 7) ------------------------------------------
REWARDS = ("simplified", "tailored")
"""Eq. 6 (simplified) and Eq. 7 (tailored)."""
R_GOAL = 100.0
"""Eq. 7's reward for reaching the goal."""
