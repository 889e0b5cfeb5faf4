"""The DQN baseline's settings, in one place: the network, the training hyperparameters,
the budgets and where results and models go. What :mod:`cml_edge.baselines.dqn`
(results, pairs, the CML beside it), :mod:`cml_edge.baselines.dqn_sb3` (the torch side),
the DQN cost estimates (:mod:`cml_edge.costs.dqn`) and the report read.

Light to import (no torch): the two modules import this one and never each other at
load time, so the import graph is ``settings <- dqn_sb3 <- dqn`` (the last lazily, when
a command runs) and ``settings <- dqn``.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from cml_edge.errors import InputError
from cml_edge.protocol import EVAL_SEED, REWARDS

# The paper's DQN (2.3): 2 inputs (x, y), two hidden layers of 64 (ReLU), 8 actions.
PAPER_LAYERS = (2, 64, 64, 8)
GOAL_CONDITIONED_LAYERS = (4, 64, 64, 8)
RESULTS_PATH = Path(__file__).resolve().parents[2] / "hw_reports" / "baselines" / "dqn_results.json"
"""The DQN results file ``cml-edge dqn`` writes and the report and the recovery scenario's
retraining estimate read: the checkout's ``hw_reports/baselines/dqn_results.json``."""

# Training budgets of the paper (2.3): 100,000 steps with Eq. 6, 200,000 with Eq. 7.
DEFAULT_STEPS = {"simplified": 100_000, "tailored": 200_000}
EVAL_EVERY = 5_000
NET_ARCH = (64, 64)
MODELS_DIR = Path("runs") / "dqn"

# The original stable-baselines (v2) DQN defaults, passed to SB3's DQN. SB3's own
# defaults (lr 1e-4, buffer 1e6, train_freq 4, target update 10,000, final eps 0.05) are
# Atari settings. tau = 1 is a hard target copy; max_grad_norm 10 is the original's
# gradient clipping; loss is the Huber loss in both.
HYPERPARAMS: dict[str, Any] = {
    "learning_rate": 5e-4,
    "buffer_size": 50_000,
    "learning_starts": 1_000,
    "batch_size": 32,
    "gamma": 0.99,
    "train_freq": 1,
    "gradient_steps": 1,
    "target_update_interval": 500,
    "tau": 1.0,
    "exploration_fraction": 0.1,
    "exploration_initial_eps": 1.0,
    "exploration_final_eps": 0.02,
    "max_grad_norm": 10.0,
}


@dataclass(frozen=True)
class DQNRun:
    """One training configuration (what a results-file entry is keyed by)."""

    reward: str = "simplified"
    goal_conditioned: bool = False
    steps: int = DEFAULT_STEPS["simplified"]
    arena: int = 30
    trials: int = 100
    eval_seed: int = EVAL_SEED
    eval_every: int = EVAL_EVERY

    def __post_init__(self) -> None:
        if self.reward not in REWARDS:
            raise InputError(f"unknown reward {self.reward!r}; allowed: {', '.join(REWARDS)}")
        for name in ("steps", "trials", "eval_every"):
            v = getattr(self, name)
            if isinstance(v, bool) or int(v) != v or v < 1:
                raise InputError(f"{name} {v!r} is not a positive integer")
        if isinstance(self.arena, bool) or int(self.arena) != self.arena or self.arena < 2:
            raise InputError(f"arena {self.arena!r} is not an integer >= 2")

    @property
    def name(self) -> str:
        return ("goal_conditioned_" if self.goal_conditioned else "") + self.reward

    @property
    def key(self) -> str:
        """Results-file key: name, budget and evaluation set-up (short test runs never mix
        with full runs)."""
        return (f"{self.name}_{self.steps}_a{self.arena}_t{self.trials}_e{self.eval_seed}"
                f"_every{self.eval_every}")

    @property
    def layers(self) -> tuple[int, ...]:
        return GOAL_CONDITIONED_LAYERS if self.goal_conditioned else PAPER_LAYERS
