"""The parts of a grid run that compile apart, each as a tiny run of itself: what the
first run's warm-up (:mod:`cml_edge.engine.warmup`) compiles on every core.

A :class:`~cml_edge.grid.protocol.Protocol` compiles two chains of kernels that share
little: its device's training loop (with the update and the commit that the schedule
runs), and its evaluation (the drift of the idle time, the planning loop of its planner
and of the curve, and with the fidelity the float64 twin's training loop and the decision
replay). :func:`training_part` and :func:`evaluation_part` run each on the protocol made
tiny (:func:`cml_edge.engine.warmup.tiny`), through the functions the protocol runs
(:func:`~cml_edge.grid.seed_run.train_seed`,
:func:`~cml_edge.grid.seed_run.evaluate_seed`,
:func:`~cml_edge.grid.seed_run.run_fidelity`), so they compile what it compiles, for
the same types; the evaluation plans with the untrained model (the types are the same).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from cml_edge.core.cml import CML
from cml_edge.grid.metrics import draw_pairs
from cml_edge.grid.protocol import Protocol
from cml_edge.grid.seed_run import Evaluation, SeedRun, evaluate_seed, run_fidelity, train_seed


def training_part(protocol: dict[str, Any]) -> None:
    """Train the first seed's model of ``protocol`` (:meth:`Protocol.to_dict`, tiny) for its
    walks."""
    p = Protocol.from_dict(protocol)
    train_seed(p.seeds[0], p.training())


def evaluation_part(protocol: dict[str, Any]) -> None:
    """Evaluate an untrained model of ``protocol``'s first seed as the protocol does: the
    idle time, the curve's plans, the evaluation and, with the fidelity, its float64
    twin."""
    p = Protocol.from_dict(protocol)
    training = p.training()
    cml = CML.create(training.cml_config, training.backend, p.seeds[0], training.chip,
                     **training.backend_options)
    arena = training.arena
    Evaluation(arena, draw_pairs(arena, p.trials, p.eval_seed)).plan(cml, training.path)
    run = SeedRun(p.seeds[0], cml, training.path, np.zeros(0), [], [], [], {}, {}, [0.0],
                  [0.0])
    evaluation = p.evaluation()
    evaluate_seed(run, [evaluation], p.idle_s)
    if p.fidelity:
        run_fidelity(run, training, [evaluation])
