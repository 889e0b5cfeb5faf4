"""The eight scenarios as data: what each trains, how it evaluates, and why.

A scenario is a list of **runs** in one world (:mod:`cml_edge.core.world`: the grid or
the robot). A run is one training (``run``: the budget's walks and steps, on the grid an
arena and a schedule) and the **parts** that evaluate it: a part is one evaluation
condition (its problems: on the grid an arena, obstacles or a map, a planner; the time the
arrays sit idle before it, walks of in-situ relearning before it). The runner makes one
sweep task per (run x seed) (:mod:`cml_edge.scenarios.runner`); every part of a run
evaluates a copy of that run's trained model, so a part never sees another part's reads
or drift.

Every scenario is seeded (model seeds 0..N-1, evaluation seed 123 for pairs, obstacles
and robot goals) and runs on any device (``--backend``, ``--preset``, ``--set``).

**In space** (``--dims 3``, ``--moves face``; the paper's section 5): a scenario lists the
dimensions it runs in (:attr:`Scenario.dims`). The grid's run in an N x N x N volume:
its runs carry ``dims`` and ``moves`` (the plane's king moves carry neither, so the
plane's tasks, keys and results are as they were), its run ids end in the world's tag
(:func:`space_tag`: ``paper-3d``), and each kind says what it becomes there: the empty
volume, point obstacles at the plane's density (:data:`CLUTTER_3D`), the shipped voxel
maps (:data:`VOXEL_MAPS_SIDE`), a larger volume (:data:`LARGE_SIDES_3D`). The robot
drives on the plane only. :data:`SPACE_SCENARIOS` are the 3-D scenarios the report's
scorecard runs. A world that is three-dimensional by nature (a drone, through the
:class:`~cml_edge.core.world.World` protocol) registers its scenario with ``dims=(3,)``
and a kind of its own; the runner and the report take it as they take the grid's.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from cml_edge.core.world import WORLDS
from cml_edge.errors import InputError
from cml_edge.grid.arena import DIMS, MOVE_SETS
from cml_edge.grid.condition import Condition
from cml_edge.grid.maps import shipped_maps, shipped_path
from cml_edge.grid.planning import MAX_STEPS
from cml_edge.grid.voxels import shipped_voxel_maps, shipped_voxel_path
from cml_edge.protocol import EVAL_SEED

HOUR = 3600.0
DAY = 24 * HOUR
MONTH = 30 * DAY
YEAR = 365.25 * DAY
AGES = (("1h", HOUR), ("1d", DAY), ("1mo", MONTH), ("1y", YEAR), ("10y", 10 * YEAR))
"""The retention scenario's idle times, cumulative from the end of training."""
RECOVERY_AGE = YEAR
RECOVERY_WALKS = (0, 1, 2, 5, 10, 20)
"""K, the walks of in-situ relearning after a year of drift (cumulative: K = 5 is the
K = 2 model after three more walks)."""
LARGE_SIDES = (60, 120)
CLUTTER = (300, 400)
CLUTTER_3D = (9000, 12000)
"""Point obstacles in the 30 x 30 x 30 volume: 300 and 400 in 900 cells on the plane, at
the same density (a third and 4/9 of the cells)."""
LARGE_SIDES_3D = (60,)
"""The larger volume's side: 8 times the cells of 30 x 30 x 30 (as 60 x 60 is 4 times
the plane's), step budget 200."""
VOXEL_MAPS_SIDE = 16
"""The side of the shipped voxel maps (``cml_edge/data/maps3d``)."""
PLANE = (2, "king")


@dataclass(frozen=True)
class Budget:
    """Walks, steps per walk and evaluation trials of every run of a scenario."""

    walks: int
    steps: int
    trials: int


BUDGETS = {
    "full": Budget(100, 900, 100),
    "quick": Budget(30, 900, 50),
    "tiny": Budget(3, 100, 6),
}
"""``full``: the paper's protocol (100 walks x 900 steps, 100 pairs or goals). ``quick``:
30 walks (where the float64 model's e_pos reaches 0 on the 30 x 30 arena, docs/paper.md) and
50 trials, a third of the cost. ``tiny``: a smoke test of the machinery (tests), whose
numbers mean nothing about a device."""


@dataclass(frozen=True)
class Scenario:
    """A named, documented workload: ``runs(budget)`` lists (run id, task parameters)."""

    name: str
    doc: str
    """Workload, what is measured, why it tells devices apart."""
    world: str
    """The world its runs train and plan in (a key of :data:`~cml_edge.core.world.WORLDS`)."""
    kind: str
    """How its runs are made (a key of :data:`_RUNS`)."""
    dims: tuple[int, ...] = (2,)
    """The dimensions it runs in, its default first (the grid's: 2 and 3)."""
    space_doc: str = ""
    """What it is in 3-D, where that differs from ``doc`` (a grid scenario's 3-D form)."""

    def __post_init__(self) -> None:
        if self.world not in WORLDS:
            raise ValueError(f"scenario {self.name!r}: unknown world {self.world!r}")

    def space(self, dims: int | None = None, moves: str = "king") -> tuple[int, str]:
        """(dims, moves) it runs in: ``dims`` None, its default; InputError for dimensions
        it does not run in, or a move set off the grid."""
        dims = self.dims[0] if dims is None else dims
        if dims not in DIMS:
            raise InputError(f"dims {dims!r} is not allowed (allowed: 2, 3)")
        if dims not in self.dims:
            raise InputError(f"scenario {self.name!r} runs in {_dims_text(self.dims)} only, "
                             f"not in {dims}-D")
        if moves not in MOVE_SETS:
            raise InputError(f"unknown moves {moves!r}; allowed: {', '.join(MOVE_SETS)}")
        if moves != "king" and self.world != "grid":
            raise InputError(f"scenario {self.name!r} is in the {self.world} world; --moves "
                             "sets the grid's move set")
        return dims, moves

    def runs(self, budget: Budget, dims: int | None = None, moves: str = "king"
             ) -> list[tuple[str, dict[str, Any]]]:
        """(run id, ``{"run": training settings, "parts": [part, ...]}``) of each run, in
        ``dims`` dimensions with the ``moves`` set (:meth:`space`; module docstring)."""
        dims, moves = self.space(dims, moves)
        if self.world != "grid" or (dims, moves) == PLANE:
            return _RUNS[self.kind](budget)
        tag = space_tag(dims, moves)
        return [(f"{rid}{tag}", {**spec, "run": {**spec["run"], "dims": dims, "moves": moves}})
                for rid, spec in _SPACE_RUNS[self.kind](budget, dims)]


def _dims_text(dims: tuple[int, ...]) -> str:
    return " and ".join(f"{d}-D" for d in dims)


def space_tag(dims: int, moves: str) -> str:
    """What ends a run id off the plane's king moves: ``-3d``, ``-3d-face``, ``-face``
    (the plane's king moves: nothing)."""
    return ("" if dims == 2 else f"-{dims}d") + ("" if moves == "king" else f"-{moves}")


def part(name: str, *, size: int | None = None, obstacles: int = 0, map: str | None = None,
         scen: str | None = None, planner: str = "paper", max_steps: int | None = MAX_STEPS,
         trials: int = 100, age_s: float = 0.0, relearn_walks: int = 0) -> dict[str, Any]:
    """One part of a grid run as JSON: its evaluation condition
    (:class:`~cml_edge.grid.condition.Condition`; ``max_steps`` None: the map's
    :func:`~cml_edge.grid.maps.step_budget`), then the idle seconds and the walks of
    in-situ relearning before it."""
    return {**Condition(name, size, obstacles, map, scen, planner, max_steps, trials,
                        EVAL_SEED).to_dict(), "age_s": age_s, "relearn_walks": relearn_walks}


def _grid(arena: int, b: Budget, parts: list[dict[str, Any]], schedule: str = "walk"
          ) -> dict[str, Any]:
    return {"run": {"arena": arena, "walks": b.walks, "steps": b.steps, "schedule": schedule},
            "parts": parts}


def _paper(b: Budget) -> list[tuple[str, dict[str, Any]]]:
    return [("paper", _grid(30, b, [part("paper", trials=b.trials)]))]


def _in_situ(b: Budget) -> list[tuple[str, dict[str, Any]]]:
    return [("in-situ", _grid(30, b, [part("in-situ", trials=b.trials)], schedule="step"))]


def _retention(b: Budget) -> list[tuple[str, dict[str, Any]]]:
    parts = [part(name, trials=b.trials, age_s=t) for name, t in AGES]
    return [("retention", _grid(30, b, parts))]


def _clutter(b: Budget) -> list[tuple[str, dict[str, Any]]]:
    parts = [part(f"obst{n}", obstacles=n, planner="escape", trials=b.trials) for n in CLUTTER]
    return [("clutter", _grid(30, b, parts))]


def _maps(b: Budget) -> list[tuple[str, dict[str, Any]]]:
    parts = [part(name, map=str(shipped_path(name)), scen=str(shipped_path(name, ".map.scen")),
                  planner="escape", max_steps=None) for name in shipped_maps()]
    return [("maps", _grid(32, b, parts))]  # the shipped maps are 32 x 32


def _large(b: Budget) -> list[tuple[str, dict[str, Any]]]:
    return [(f"large{n}", _grid(n, b, [part(f"{n}x{n}", trials=b.trials, max_steps=None)]))
            for n in LARGE_SIDES]


def _recovery(b: Budget) -> list[tuple[str, dict[str, Any]]]:
    parts = [part(f"K{k}", trials=b.trials, age_s=RECOVERY_AGE, relearn_walks=k)
             for k in RECOVERY_WALKS]
    return [("recovery", _grid(30, b, parts))]


def _robot(b: Budget) -> list[tuple[str, dict[str, Any]]]:
    drive = {"name": "robot", "trials": b.trials, "eval_seed": EVAL_SEED, "age_s": 0.0,
             "relearn_walks": 0}  # from the base pose to the evaluation seed's goals
    return [("robot", {"run": {"walks": b.walks, "steps": b.steps}, "parts": [drive]})]


def _drone(b: Budget) -> list[tuple[str, dict[str, Any]]]:
    fly = {"name": "drone", "trials": b.trials, "eval_seed": EVAL_SEED, "age_s": 0.0,
           "relearn_walks": 0}  # from the base, at rest, to the evaluation seed's goals
    return [("drone", {"run": {"walks": b.walks, "steps": b.steps}, "parts": [fly]})]


def _space_same(runs: Callable[[Budget], list[tuple[str, dict[str, Any]]]]
                ) -> Callable[[Budget, int], list[tuple[str, dict[str, Any]]]]:
    """A kind whose runs are the plane's in the volume of the same side (the paper,
    in-situ, retention, recovery: the empty 30 x 30 x 30 volume)."""
    return lambda b, dims: runs(b)


def _clutter_3d(b: Budget, dims: int) -> list[tuple[str, dict[str, Any]]]:
    parts = [part(f"obst{n}", obstacles=n, planner="escape", trials=b.trials)
             for n in CLUTTER_3D]
    return [("clutter", _grid(30, b, parts))]


def _maps_3d(b: Budget, dims: int) -> list[tuple[str, dict[str, Any]]]:
    parts = [part(name, map=str(shipped_voxel_path(name)),
                  scen=str(shipped_voxel_path(name, ".3dscen")), planner="escape",
                  max_steps=None) for name in shipped_voxel_maps()]
    return [("maps", _grid(VOXEL_MAPS_SIDE, b, parts))]


def _large_3d(b: Budget, dims: int) -> list[tuple[str, dict[str, Any]]]:
    return [(f"large{n}", _grid(
        n, b, [part(f"{n}x{n}x{n}", trials=b.trials, max_steps=None)])) for n in LARGE_SIDES_3D]


_RUNS = {"paper": _paper, "in-situ": _in_situ, "retention": _retention, "clutter": _clutter,
         "maps": _maps, "large": _large, "robot": _robot, "recovery": _recovery,
         "drone": _drone}

_SPACE_RUNS: dict[str, Callable[[Budget, int], list[tuple[str, dict[str, Any]]]]] = {
    "paper": _space_same(_paper), "in-situ": _space_same(_in_situ),
    "retention": _space_same(_retention), "recovery": _space_same(_recovery),
    "clutter": _clutter_3d, "maps": _maps_3d, "large": _large_3d}
"""The grid's kinds in space (module docstring)."""

GRID_DIMS = (2, 3)
SCENARIOS: dict[str, Scenario] = {s.name: s for s in (
    Scenario("paper", "The paper's protocol (2.4): train on the empty 30 x 30 arena (random "
             "exploration, per-walk updates), plan the evaluation seed's pairs with the "
             "paper's planner in 100 actions. The baseline every other scenario departs "
             "from; success saturates here, so the fidelity metrics carry the ranking.",
             "grid", "paper", GRID_DIMS, "The paper's protocol in the empty 30 x 30 x 30 "
             "volume (N_i 3, 26 king moves)."),
    Scenario("in-situ", "The paper's protocol with every update applied on the device at "
             "the step it is computed (schedule step: no digital accumulator summing a "
             "walk's updates). Each update is one small outer product, so a device with "
             "coarse levels, pulse noise or asymmetric steps loses what the per-walk sum "
             "would have kept.", "grid", "in-situ", GRID_DIMS),
    Scenario("retention", "Train once (the paper's protocol), then let 1 hour, 1 day, 1 "
             "month (30 d), 1 year (365.25 d) and 10 years pass (each age a copy of the "
             "trained model, idle from the end of training) and plan. Drift and accumulated "
             "read noise act only on devices that have them; a digital array does not "
             "change.", "grid", "retention", GRID_DIMS),
    Scenario("clutter", "Train on the empty arena, plan among 300 and 400 point obstacles "
             "placed from the evaluation seed, with the escape planner (100 actions). The "
             "detours need the affordance and utility away from the straight line, where "
             "small weight errors change the decision.", "grid", "clutter", GRID_DIMS,
             "9,000 and 12,000 point obstacles in the 30 x 30 x 30 volume (the plane's "
             "densities), the escape planner (its LRTA* step at a stall), 100 actions."),
    Scenario("maps", "Train on the empty 32 x 32 arena, plan the shipped MovingAI maps' "
             "scenarios (rooms, utrap, maze) with the escape planner (step budget of the "
             "map). Success is over the connected problems.", "grid", "maps", GRID_DIMS,
             "Train on the empty 16 x 16 x 16 volume, plan the shipped voxel maps' problems "
             "(floors, pillars, shaft) with the escape planner."),
    Scenario("large", "Train and plan on 60 x 60 and 120 x 120 arenas (the budget's walks "
             "and steps, not scaled with the area, so the larger arena is explored less; "
             "step budget 200 and 400). The observation frame spreads over more cells, so "
             "neighbouring cells differ by less in o and a device's read and weight errors "
             "are larger against the differences planning must resolve.", "grid", "large",
             GRID_DIMS, "Train and plan in the 60 x 60 x 60 volume (step budget 200)."),
    Scenario("robot", "The continuous wheeled robot (paper 2.5, 3.5) with the CML's three "
             "arrays on the device: random-walk training on the kinematic simulator "
             "(heading observation, raw utility, per-walk updates), then drive from the "
             "base to the evaluation seed's goals (within 0.25 m, 100 actions). "
             "overhead_mean is the driven path over the straight distance (path_ratio).",
             "robot", "robot"),
    Scenario("drone", "The drone (a point mass in a walled 30 m cube, 26 velocity commands, "
             "rest to rest; cml_edge.drone) with the CML's three arrays on the device: "
             "random-walk training on the exact kinematics (position observation, "
             "normalised utility, per-walk updates), then fly from (2, 2, 2) m to the "
             "evaluation seed's goals (within 0.6 m, 100 actions). overhead_mean is the "
             "flown path over the straight distance.", "drone", "drone", (3,)),
    Scenario("recovery", "Train (the paper's protocol), let a year pass, then K = 0, 1, 2, "
             "5, 10, 20 self-supervised walks of in-situ relearning (schedule step, the "
             "seed's walk streams continued), planning after each K. Reports success "
             "against K and what the relearning cost on the device (pulses, cells written, "
             "energy from the arrays' counters and the energy model of cml_edge.costs), beside "
             "an estimate of what a DQN would need to retrain (``dqn_retrain``).",
             "grid", "recovery", GRID_DIMS),
)}


SPACE_SCENARIOS = ("paper", "clutter", "maps", "large", "drone")
"""The scenarios the report's scorecard runs in 3-D (``--dims 3``): the empty volume,
clutter, the voxel maps, a larger volume and the drone."""


def get(name: str) -> Scenario:
    """The scenario called ``name``; InputError naming the known ones otherwise."""
    if name not in SCENARIOS:
        raise InputError(f"unknown scenario {name!r}; allowed: {', '.join(SCENARIOS)}")
    return SCENARIOS[name]
