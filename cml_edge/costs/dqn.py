"""What the DQN baseline costs: its memory, its training traffic and energy (the ledger of
the report), and what it would pay to relearn after its weights drifted (an estimate,
not a run).

The settings are the baseline's own (:mod:`cml_edge.baselines.settings`): the paper's
network and the original stable-baselines hyperparameters.

Relearning. The recovery scenario measures the CML relearning on the device by its own local rule.
A DQN cannot do that on the chip: it needs its replay buffer (refilled by acting, or
kept in memory the whole time) and gradient steps through both networks. No DQN is
trained here. The estimate uses the stored baseline (``hw_reports/baselines/
dqn_results.json``, what ``cml-edge dqn train`` wrote) and the ledger of
:mod:`cml_edge.costs`:

- ``steps_to_converge``: for each stored DQN configuration, the environment steps its
  training took to first reach mean e_pos <= 0.5 cells (the ``convergence`` record of the
  baseline, seed mean curve). That is from scratch: it is an upper estimate of
  retraining from drifted weights, which start closer (how much closer is not measured);
- ``replay_refill_steps``: ``learning_starts`` environment steps, the least a DQN without
  its stored buffer acts before its first gradient step: the lower end;
- for each: gradient steps, MACs and energy by :func:`dqn_training_traffic`
  and :func:`dqn_energy_pj` (fp32 MACs, weights in SRAM, the replay
  buffer in DRAM), at the baseline's layer sizes.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from cml_edge.baselines import load_results, mlp_inference_flops, mlp_parameter_count
from cml_edge.baselines.settings import HYPERPARAMS, NET_ARCH, PAPER_LAYERS, RESULTS_PATH
from cml_edge.costs.ledger import COSTS, FLOPS_PER_MAC
from cml_edge.io.files import display_path


@dataclass(frozen=True)
class DQNSettings:
    """The network and training settings the ledger counts (default: the baseline's,
    :mod:`cml_edge.baselines.settings`)."""

    n_in: int = PAPER_LAYERS[0]
    hidden: tuple[int, ...] = NET_ARCH
    n_out: int = PAPER_LAYERS[-1]
    buffer_size: int = HYPERPARAMS["buffer_size"]
    batch_size: int = HYPERPARAMS["batch_size"]
    train_freq: int = HYPERPARAMS["train_freq"]
    target_update: int = HYPERPARAMS["target_update_interval"]
    learning_starts: int = HYPERPARAMS["learning_starts"]
    bytes_per_float: int = 4
    # SB3 ReplayBuffer per transition: obs and next obs (float32), action (int64),
    # reward, done and timeout (float32)
    transition_bytes: int = 2 * 2 * 4 + 8 + 3 * 4

    @property
    def layers(self) -> tuple[int, ...]:
        return (self.n_in, *self.hidden, self.n_out)


def dqn_parameter_count(s: DQNSettings) -> int:
    """Weights and biases of the dense layers: 4,872 for 2-64-64-8."""
    return mlp_parameter_count(s.layers)


def dqn_inference_flops(s: DQNSettings) -> int:
    """The paper's count, 2 N_x N_y per dense layer: 9,472 for 2-64-64-8."""
    return mlp_inference_flops(s.layers)


def dqn_memory(s: DQNSettings) -> dict[str, float]:
    """Bytes to hold the policy, and to train it at the settings used."""
    p = dqn_parameter_count(s)
    f = s.bytes_per_float
    activations = s.batch_size * (s.n_in + 2 * sum(s.hidden) + s.n_out) * f
    return {
        "parameter_bytes": p * f,
        "train_bytes": (p * f) * 5 + s.buffer_size * s.transition_bytes + activations,
        "train_bytes_networks": p * f * 2,
        "train_bytes_adam_and_grads": p * f * 3,
        "train_bytes_replay": s.buffer_size * s.transition_bytes,
        "train_bytes_activations": activations,
    }


def dqn_training_traffic(s: DQNSettings, total_steps: int) -> dict[str, float]:
    """Operations and bytes of DQN training per environment step and per run.

    Each step: one forward pass to act, one replay write. Each gradient step (every
    ``train_freq`` steps after ``learning_starts``): a minibatch read, forward passes of
    the online and target networks on it, a backward pass (2x the forward MACs), and
    Adam reading and writing parameters, gradients and two moments.
    """
    p = dqn_parameter_count(s)
    f = s.bytes_per_float
    fwd = dqn_inference_flops(s) // FLOPS_PER_MAC
    updates = max(0, total_steps - s.learning_starts) // s.train_freq
    macs = total_steps * fwd + updates * s.batch_size * fwd * (1 + 1 + 2)
    replay = total_steps * s.transition_bytes + updates * s.batch_size * s.transition_bytes
    weights = total_steps * p * f + updates * (2 * p * f * 2 + p * f * 4 * 2)
    return {"macs": macs, "replay_bytes": replay, "weight_bytes": weights,
            "gradient_steps": updates,
            "bytes_per_step": (replay + weights) / total_steps, "macs_per_step": macs / total_steps}


def dqn_energy_pj(traffic: dict[str, float]) -> tuple[float, list[str]]:
    """fp32 MACs, weights and gradients in SRAM, the replay buffer in DRAM."""
    total = (traffic["macs"] * COSTS["fp32_mac"].pj + traffic["weight_bytes"]
             * COSTS["sram_byte"].pj + traffic["replay_bytes"] * COSTS["dram_byte"].pj)
    return total, [COSTS[k].source for k in ("fp32_mac", "sram_byte", "dram_byte")]


ESTIMATE = ("estimate, no DQN trained: environment steps x the DQN ledger of costs/dqn.py "
            "(dqn_training_traffic, dqn_energy_pj); steps_to_converge is from scratch "
            "(an upper estimate of retraining from drifted weights), replay_refill_steps "
            "the lower end (learning_starts steps before the first gradient step)")


def _cost(settings: DQNSettings, steps: int) -> dict[str, Any]:
    traffic = dqn_training_traffic(settings, steps)
    pj, _ = dqn_energy_pj(traffic)
    return {"env_steps": int(steps), "gradient_steps": int(traffic["gradient_steps"]),
            "macs": int(traffic["macs"]), "energy_uJ": pj * 1e-6}


def dqn_retrain_estimate(path: str | None = None) -> dict[str, Any]:
    """The estimate (module docstring) for every configuration of the stored baseline;
    ``{"available": False}`` when there is none."""
    data = load_results(path or RESULTS_PATH)
    if data is None:
        return {"available": False, "method": ESTIMATE}
    configs = []
    for key, ev in data["evaluations"].items():
        net = data["network"]
        layers = tuple(net["goal_conditioned_layers"] if ev.get("goal_conditioned")
                       else net["layers"])
        settings = DQNSettings(n_in=layers[0], hidden=tuple(layers[1:-1]), n_out=layers[-1],
                               learning_starts=data["hyperparameters"]["learning_starts"],
                               transition_bytes=2 * layers[0] * 4 + 8 + 3 * 4)
        conv = ev.get("convergence") or {}
        row: dict[str, Any] = {"config": ev.get("config", key),
                               "goal_conditioned": ev.get("goal_conditioned"),
                               "layers": list(layers),
                               "tolerance_cells": conv.get("tolerance_cells"),
                               "replay_refill": _cost(settings, settings.learning_starts)}
        row["to_converge"] = _cost(settings, conv["step"]) if conv.get("step") else None
        configs.append(row)
    return {"available": True, "method": ESTIMATE, "source": display_path(path or RESULTS_PATH),
            "configs": configs}
