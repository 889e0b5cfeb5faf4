"""The documented range of every count, size and seed the tool takes: the command line's
options (:mod:`cml_edge.cli.args` checks them as they are parsed) and the same numbers
when a file gives them (a model's training record, :mod:`cml_edge.core.model_file`)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from cml_edge.errors import InputError

MAX_IDLE_S = 3.15576e9
"""The longest idle time a run lets pass on its arrays (``--drift-time``, the drift-time
knob of the break points): 100 years. Drift is measured to ~1e6 s and its power law
extrapolated beyond; past a century it describes no device (a device maker's retention
figure is 10 years)."""

SEED_MAX = 2**62
"""The largest seed: stream keys and NumPy's generators take it from an int64 with room
for the run's seeds and chips added to it."""


def ascii_number(text: str, kind: type) -> Any:
    """``kind(text)`` (int or float) for ASCII text only: Python's ``int`` and ``float``
    also read other scripts' digits (``int("٣") == 3``, ``float("６")``), which a command
    line or a file of this tool does not mean. ValueError otherwise."""
    if not text.isascii():
        raise ValueError(f"{text!r} has characters other than ASCII")
    return kind(text)


@dataclass(frozen=True)
class Size:
    """The documented range of a count, size or seed option, and its reason."""

    lo: float
    hi: float
    why: str


SIZES: dict[str, Size] = {
    "seeds": Size(1, 100_000, "each seed trains one model: seconds to minutes of a core"),
    "seed": Size(0, SEED_MAX, "a seed of an int64 stream key"),
    "eval_seed": Size(0, SEED_MAX, "a seed of an int64 stream key"),
    "first_chip": Size(0, SEED_MAX, "a chip seed of an int64 stream key"),
    "chips": Size(1, 100_000, "each chip trains every model seed again"),
    "walks": Size(1, 100_000, "exploration walks (the paper's 100)"),
    "steps": Size(1, 100_000, "steps per walk (the paper's 900); a stop request may wait "
                              "for one walk (engine.stop.CHUNK_STEPS)"),
    "dqn:steps": Size(1, 100_000_000, "environment steps per seed (the paper's 1e5..2e5)"),
    "arena": Size(2, 1024, "cells a side: the largest MovingAI benchmark maps are 1024"),
    "trials": Size(1, 1_000_000, "(start, goal) pairs"),
    "max_steps": Size(1, 100_000, "actions per plan (100 for the 30 x 30 arena); a stop "
                                  "request may wait for one plan"),
    "max_actions": Size(1, 100_000, "actions per drive; a stop request may wait for one"),
    "obstacles": Size(0, 1024 * 1024, "at most every cell of the largest arena"),
    "devices": Size(2, 10_000_000, "devices per point of a characterization"),
    "workers": Size(1, 1024, "worker processes"),
    "repeats": Size(1, 10_000, "timed repeats"),
    "goals": Size(1, 100_000, "goals driven to"),
    "model_index": Size(0, 100_000, "an index into the saved models"),
    "eval_every": Size(1, 100_000_000, "training steps between curve points"),
    "drift_time": Size(0.0, MAX_IDLE_S, "seconds idle: up to 100 years, beyond any "
                                        "device's measured drift"),
    "radius": Size(0.01, 30.0, "metres: a centimetre up to the side of the robot's 30 m "
                               "arena"),
    "mujoco_timestep": Size(1e-5, 0.032, "seconds: at most one 32 ms simulation step"),
    "mujoco_friction": Size(1e-3, 10.0, "a sliding friction coefficient (rubber on a floor "
                                        "is about 1)"),
    "mujoco_kv": Size(1e-3, 1e3, "a velocity servo gain, N m s / rad"),
    "mujoco_torque": Size(1e-3, 100.0, "N m: a mobile robot's wheel motors (0.2 modelled)"),
    "heading_scale": Size(1e-4, 1.0, "the heading's weight against positions scaled to "
                                     "about 1 (1/30, a cell, by default)"),
    "sensor_weight": Size(0.0, 2.0, "the range sensors' inputs together against positions "
                          "scaled to [-0.5, 0.5]; Eq. 3 diverges well before 2"),
    "sensor_range": Size(1, 1024, "cells: at most the side of the largest arena"),
    "obs_scale": Size(1e-2, 1e4, "the length, in cells or metres, that maps positions to "
                                 "about -0.5..0.5: an arena side"),
}
"""The count, size, seed and physical options' ranges, by option name (``dest``; ``command:dest``
for a command whose option of that name counts something else), and the same numbers
where a file gives them (``obs_scale``: a model's observation frame)."""


def checked(name: str, value: Any, where: str) -> int:
    """``value`` as the integer ``name`` of :data:`SIZES` takes; InputError naming
    ``where`` (the file and field), the value and the range otherwise."""
    size = SIZES[name]
    if isinstance(value, bool) or not isinstance(value, int) or \
            not size.lo <= value <= size.hi:
        raise InputError(f"{where} {value!r} is not an integer in {size.lo:g}..{size.hi:g} "
                         f"({size.why})")
    return value


def checked_float(name: str, value: float, where: str) -> float:
    """``value`` within the range ``name`` of :data:`SIZES`; InputError naming ``where``,
    the value and the range otherwise (NaN and infinities are outside every range)."""
    size = SIZES[name]
    if not size.lo <= value <= size.hi:
        raise InputError(f"{where} {value!r} is outside {size.lo:g}..{size.hi:g} "
                         f"({size.why})")
    return value
