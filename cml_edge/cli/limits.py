"""What a run will cost, from its sizes, before any work: memory and time.

:func:`estimate` reads a command's sizes (arena cells, seeds, chips, walks x steps,
trials x the step budget, goals x the action budget, devices) and prices them with
per-unit costs measured on this code; :func:`check` refuses a run whose memory would
exceed the machine's (InputError: one line naming the option that dominates and the
estimate) and returns, for a large but feasible run, the line to print on stderr before
going on. The command line checks once
the options are parsed (:func:`cml_edge.cli.main`), and a command that reads a file whose
contents set a size (a model's training record: its arena, walks and steps; a map's side;
a scenario file's problems) checks again with those sizes (:func:`recheck`) once it has
read them, before any work.

How the costs were measured (Python 3.11, the 2-core development machine, kernels
compiled), each a peak of ``tracemalloc`` over a run of N units divided by N, or a
median time per unit:

- :data:`TASK_BYTES`: ``scenario_tasks("paper", "crossbar", {"preset": "pcm"}, 1,
  chips=range(20000))`` peaks at 3.7 kB per task; a run keeps each task's result record
  as well (a few kB of JSON-able numbers): 8 kB per task;
- :data:`TRAIN_STEP_S`: a training step of the slowest device, all in (its share of the
  plans, the float64 twin and each model's setup): ``cml-edge emulate --backend crossbar
  --preset reram --chips 100 --walks 30 --trials 25`` (1,000 models of 30 x 900 steps,
  kernels cached) took 133 CPU s, 4.9 us a step; the same with the default ``pcm``
  115.8 CPU s (4.3 us), and with ``--chips 1000`` 1,257 CPU s, its compiling included
  (4.7 us): 5 us;
- :data:`PLAN_STEP_S`: the slowest device's planning step, 2.75 us (``cml-edge bench
  --backends crossbar --presets --repeats 3 --json``: crossbar reram), priced at the whole
  step budget of every trial although most plans end sooner: 3 us;
- :data:`PATH_BYTES`: a plan keeps its visited cells, two int64 per step
  (:class:`cml_edge.grid.planning.PlanResult`), and the fidelity twin's as many: 32 bytes
  per trial and step;
- :data:`CELL_BYTES`: an arena cell's arrays, counted rather than measured (the
  obstacles, the escape planner's visited map and values, the pair draws' distances:
  about 20 bytes), with room for the copies a run makes: 64 bytes;
- :data:`DEVICE_BYTES`, :data:`DEVICE_S`: ``characterize("pcm", devices=200000)`` peaks
  at 944 bytes per device (a column of devices per target and time, with its twin) and
  took 640 us per device on a core shared with two other jobs;
- :data:`DQN_STEP_S`: a DQN environment step with its gradient step (stable-baselines3 on
  torch's CPU build): 205 s of CPU for 100,000 steps (hw_reports/baselines/dqn_results.json,
  the simplified reward's seed 0), 2 ms;
- :data:`BASE_BYTES`: the interpreter, NumPy and Numba with their kernels loaded, 400 MB.

Those steps are the plane's, with its king moves. In another world (``--dims 3``,
``--moves face``) a training and a planning step are priced in proportion to the CML's
weights there (:func:`_weights_ratio`: 14,080 against 4,608 in the volume with its 26 king
moves, 3.1 times; ``cml-edge bench --dims 3`` measured the volume's training step at 2.0-4.6
times the plane's and its planning step at 1.2-2.9 times, benchmarks/README.md).

A scenario's or a break point's sizes are its budget's in the world it runs in (its runs
there, :meth:`~cml_edge.scenarios.registry.Scenario.runs`: walks x steps a model and its
float64 twin, trials x step budget in each part); a break point evaluates
:data:`BREAKPOINT_RUNS` knob values at most.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from types import SimpleNamespace
from typing import Any

from cml_edge.cli.args import hold_estimate
from cml_edge.engine.warmup import cores as usable_cores
from cml_edge.errors import InputError

TASK_BYTES = 8e3
TRAIN_STEP_S = 5e-6
PLAN_STEP_S = 3e-6
PATH_BYTES = 32.0
CELL_BYTES = 64.0
DEVICE_BYTES = 1e3
DEVICE_S = 640e-6
DQN_STEP_S = 2e-3
BREAKPOINT_RUNS = 10
BASE_BYTES = 400e6
LOUD_S = 600.0
"""A run estimated to take longer prints its estimate on stderr."""
PLAN_BUDGET = 100  # the planning step budget when none is given (grid/planning.py)
DEFAULT_WALKS, DEFAULT_STEPS = 100, 900  # the paper's exploration


def total_memory() -> int:
    """The machine's memory in bytes (``os.sysconf``; /proc/meminfo where that fails)."""
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemTotal:"):
                    return int(line.split()[1]) * 1024
    raise OSError("cannot read the machine's memory")


@dataclass(frozen=True)
class Estimate:
    """A run's memory (bytes) and time (seconds on ``workers`` cores); ``terms``: each
    option's share of the memory, (option as typed, bytes), largest first."""

    memory: float
    seconds: float
    terms: tuple[tuple[str, float], ...]
    workers: int = 1

    def text(self) -> str:
        return (f"~{size_text(self.memory)} of memory, ~{time_text(self.seconds)} on "
                f"{self.workers} {'core' if self.workers == 1 else 'cores'}")


def size_text(n: float) -> str:
    for unit, scale in (("TB", 1e12), ("GB", 1e9), ("MB", 1e6)):
        if n >= scale:
            return f"{n / scale:.3g} {unit}"
    return f"{n / 1e3:.3g} kB"


def time_text(s: float) -> str:
    for unit, scale in (("days", 86400.0), ("h", 3600.0), ("min", 60.0)):
        if s >= scale:
            return f"{s / scale:.3g} {unit}"
    return f"{s:.2g} s"


def _get(args: Any, name: str, default: float = 1) -> float:
    value = getattr(args, name, None)
    return default if value is None else float(value)


def estimate(args: Any) -> Estimate:
    """The estimate of the command ``args`` (an argparse namespace) from its sizes: any
    of ``seeds``, ``chips``, ``walks``, ``steps``, ``trials``, ``max_steps``, ``arena``
    (side^``dims`` cells) and ``devices`` it has (a missing size counts 1, or its default;
    a scenario or sweep trains the paper's 100 walks x 900 steps a model), each step priced
    in the world of ``dims`` and ``moves`` (:func:`_weights_ratio`; a scenario's: its
    runs')."""
    seeds, chips = _get(args, "seeds"), _get(args, "chips")
    if "navigate" in (getattr(args, "robot_command", None),  # goals one after another
                      getattr(args, "drone_command", None)):
        args = SimpleNamespace(**{**vars(args), "trials": _get(args, "goals")})
    models = seeds * chips
    step_s, cores = TRAIN_STEP_S, float(usable_cores())
    scale = _weights_ratio(_get(args, "dims", 2), getattr(args, "moves", None))
    trials = _get(args, "trials", 0)
    budget = _get(args, "max_steps", _get(args, "max_actions", PLAN_BUDGET))
    plans, plan_label = trials * budget, f"--trials {trials:g} x a step budget of {budget:g}"
    if hasattr(args, "walks"):  # a command that trains: its walks x steps
        walks, steps = _get(args, "walks", DEFAULT_WALKS), _get(args, "steps", DEFAULT_STEPS)
    elif getattr(args, "command", None) == "dqn":  # seeds one after another, on one core
        from cml_edge.baselines.settings import DEFAULT_STEPS as DQN_STEPS

        walks, step_s, cores = 1.0, DQN_STEP_S, 1.0
        steps = _get(args, "steps", DQN_STEPS.get(getattr(args, "reward", None), 0))
        if args.dqn_command != "train":  # evaluate: the trained seeds' plans only
            walks = steps = 0.0
    elif getattr(args, "command", None) in ("scenario", "breakpoint"):
        walks, steps, plans, scale, budget_name = _scenario_sizes(args)
        plan_label = f"--budget {budget_name}"
    elif hasattr(args, "seeds") and not hasattr(args, "steps"):  # a sweep
        walks, steps = DEFAULT_WALKS, DEFAULT_STEPS
    else:
        walks, steps = 1.0, _get(args, "steps", 0)
    side, dims = _get(args, "arena", 0), _get(args, "dims", 2)
    devices = _get(args, "devices", 0)
    workers = max(1.0, min(_get(args, "workers", cores), cores))
    terms = {
        f"--seeds {seeds:g}" + (f" x --chips {chips:g}" if chips > 1 else ""):
            models * TASK_BYTES,
        plan_label: plans * PATH_BYTES,
        f"--arena {side:g}" + (" --dims 3" if dims == 3 else ""): side ** dims * CELL_BYTES,
        f"--devices {devices:g}": devices * DEVICE_BYTES,
    }
    seconds = (models * scale * (walks * steps * step_s + plans * PLAN_STEP_S) / workers
               + devices * DEVICE_S)
    ranked = tuple(sorted(((k, v) for k, v in terms.items() if v > 0), key=lambda kv: -kv[1]))
    return Estimate(BASE_BYTES + sum(terms.values()), seconds, ranked, int(workers))


def _weights_ratio(dims: float, moves: str | None) -> float:
    """The CML's weights in the ``dims``-D world with the ``moves`` set (None: king) over
    the plane's with its king moves, where the per-step costs were measured (module
    docstring)."""
    moves = moves or "king"
    if (dims, moves) == (2, "king"):
        return 1.0
    from cml_edge.bench.timing import synapse_counts

    plane, world = synapse_counts(int(dims), moves)
    return world / plane


def _scenario_sizes(args: Any) -> tuple[float, float, float, float, str]:
    """(walks, steps, plan steps, scale, budget name) of a scenario's or break point's
    model seed in the world it runs in (``dims``, ``moves``): its runs' training with their
    float64 twins, its parts' trials x their step budgets; ``scale``, what they cost
    against as many steps on the plane: once (a break point: :data:`BREAKPOINT_RUNS` times)
    at that world's weights (:func:`_weights_ratio`). An unknown scenario, or one that does
    not run in that world, counts nothing (it is refused later)."""
    from cml_edge.scenarios.registry import BUDGETS, SCENARIOS

    scenario = SCENARIOS.get(getattr(args, "name", None) or getattr(args, "scenario", None))
    name = "quick" if getattr(args, "quick", False) else getattr(args, "budget", None) or "full"
    if scenario is None or name not in BUDGETS:
        return 0.0, 0.0, 0.0, 1.0, name
    b = BUDGETS[name]
    try:
        runs = [run for _, run in scenario.runs(b, getattr(args, "dims", None),
                                                getattr(args, "moves", None) or "king")]
    except InputError:
        return 0.0, 0.0, 0.0, 1.0, name
    world = runs[0]["run"]  # a grid run off the plane's king moves names its world
    scale = ((BREAKPOINT_RUNS if args.command == "breakpoint" else 1)
             * _weights_ratio(world.get("dims", 2), world.get("moves")))
    plan_steps = sum(p["trials"] * (p.get("max_steps") or PLAN_BUDGET)  # a robot drive:
                     for run in runs for p in run["parts"])  # robot.planning.MAX_ACTIONS
    return 2.0 * len(runs) * b.walks, float(b.steps), float(plan_steps), scale, name


def check(args: Any, memory: int | None = None, **read: float) -> str | None:
    """Refuse ``args`` when its :func:`estimate` exceeds the machine's memory (InputError
    naming the option that dominates, the estimate and the memory there is); else the
    line to print on stderr for a run estimated to take more than :data:`LOUD_S`
    (None for a small run). ``read``: sizes a command has read from its files, in place
    of the options' (``arena``, ``walks``, ``steps``, ``trials``)."""
    est = estimate(SimpleNamespace(**{**vars(args), **read}) if read else args)
    memory = total_memory() if memory is None else memory
    if est.memory > memory and est.terms:
        option, share = est.terms[0]
        raise InputError(f"{option} would need ~{size_text(share)} of memory; this machine "
                         f"has {size_text(memory)} (the whole run: {est.text()})")
    if est.seconds > LOUD_S or est.memory > memory / 2:
        return f"cml-edge: estimate: {est.text()}"
    return None


def recheck(args: Any, **read: float) -> None:
    """:func:`check` again with the sizes a command has read from its files (a model's
    record, a map, a scenario file), before its work: refuses what will not fit, and
    holds the estimate line to say when the work starts
    (:func:`~cml_edge.cli.args.say_estimate`)."""
    hold_estimate(check(args, **read))


__all__ = ["Estimate", "check", "estimate", "recheck", "total_memory"]
