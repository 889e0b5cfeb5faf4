"""The local rule (paper Eqs. 1-3), one training step, in the readable reference form.

With s_t = W_q o_t, g_t = sigmoid(W_k s_t), a_t one-hot and
e_t = s_{t+1} - s_hat_{t+1} = W_q (o_{t+1} - o_t) - W_v a_t:

- Eq. 1:  dW_k = lr_k (a_t - g_t) s_t^T
- Eq. 2:  dW_v = lr_v e_t a_t^T
- Eq. 3:  dW_q = lr_q (-e_t) o_{t+1}^T

All reads happen before any update, so a step sees one set of weights in both
schedules: ``walk`` (the paper: updates accumulated, applied when the walk ends by
``commit``) and ``step`` (applied in place at once, as an on-chip rule may).

:class:`ReferenceLearner` plugs :func:`learn_step` into a world's training loop (the
reference path); its compiled twin is :class:`cml_edge.core.step.SeamLearner`, and the tests
hold the two to bit equality.
"""

from __future__ import annotations

import numpy as np

from cml_edge.core.cml import CML, one_hot
from cml_edge.core.step import begin_walk, end_walk, learn
from cml_edge.errors import InputError

SCHEDULES = ("walk", "step")


def schedule_defers(name: str) -> bool:
    """True for the per-walk schedule (accumulate until commit); ValueError if unknown."""
    if name not in SCHEDULES:
        raise InputError(f"unknown schedule {name!r}; allowed: {', '.join(SCHEDULES)}")
    return name == "walk"


def check_walks(walks: int, steps: int) -> None:
    """A training budget: ``walks`` walks of ``steps`` steps, both positive integers."""
    for name, v in (("walks", walks), ("steps", steps)):
        if isinstance(v, bool) or int(v) != v or v < 1:
            raise InputError(f"{name} {v!r} is not a positive integer")


def learn_step(cml: CML, o_t: np.ndarray, o_next: np.ndarray, a: int, defer: bool) -> float:
    """One step of Eqs. 1-3 through the arrays; returns the training error ||e_t||."""
    c = cml.config
    action = one_hot(a, c.n_a)
    s = cml.embed(o_t)
    g = cml.affordance(s)
    e = cml.displacement(o_t, o_next) - cml.action_effect(a)
    cml.W_k.outer_update(action - g, s, c.lr_k, defer)  # Eq. 1
    cml.W_v.outer_update(e, action, c.lr_v, defer)  # Eq. 2
    cml.W_q.outer_update(-e, o_next, c.lr_q, defer)  # Eq. 3
    total = 0.0
    for x in e:
        total += float(x) * float(x)
    return float(np.sqrt(total))


class ReferenceLearner:
    """Eqs. 1-3 through the arrays' Python methods (:func:`learn_step`): the learner of the
    reference path, the readable statement the compiled :class:`~cml_edge.core.step.SeamLearner`
    is held to, bit for bit."""

    def __init__(self, cml: CML, defer: bool) -> None:
        self.cml = cml
        self.defer = bool(defer)

    def learn(self, o_t: np.ndarray, o_1: np.ndarray, a: int) -> float:
        return learn_step(self.cml, o_t, o_1, int(a), self.defer)

    def end_walk(self) -> float:
        """Apply the walk's accumulated updates (the paper's schedule)."""
        if self.defer:
            for arr in self.cml.arrays:
                arr.commit()
        return 0.0


begin_walk.register(ReferenceLearner, lambda learner: None)
learn.register(ReferenceLearner, ReferenceLearner.learn)
end_walk.register(ReferenceLearner, ReferenceLearner.end_walk)
