"""What a DQN would pay to relearn after its weights drifted: an estimate, not a run.

The recovery scenario measures the CML relearning on the device by its own local rule.
A DQN cannot do that on the chip: it needs its replay buffer (refilled by acting, or
kept in memory the whole time) and gradient steps through both networks. No DQN is
trained here. The estimate uses the stored baseline (``hw_reports/baselines/
dqn_results.json``, what ``cml-edge dqn train`` wrote) and the ledger of
:mod:`cml_edge.budget`:

- ``steps_to_converge``: for each stored DQN configuration, the environment steps its
  training took to first reach mean e_pos <= 0.5 cells (the ``convergence`` record of the
  baseline, seed mean curve). That is from scratch: it is an upper estimate of
  retraining from drifted weights, which start closer (how much closer is not measured);
- ``replay_refill_steps``: ``learning_starts`` environment steps, the least a DQN without
  its stored buffer acts before its first gradient step: the lower end;
- for each: gradient steps, MACs and energy by :func:`cml_edge.budget.dqn_training_traffic`
  and :func:`cml_edge.budget.dqn_energy_pj` (fp32 MACs, weights in SRAM, the replay
  buffer in DRAM), at the baseline's layer sizes.
"""

from __future__ import annotations

from typing import Any

from cml_edge.baselines import load_results
from cml_edge.budget import DQNSettings, dqn_energy_pj, dqn_training_traffic

ESTIMATE = ("estimate, no DQN trained: environment steps x the DQN ledger of budget.py "
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
    from cml_edge.report.build import DQN_RESULTS

    data = load_results(path or DQN_RESULTS)
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
    return {"available": True, "method": ESTIMATE, "source": str(path or DQN_RESULTS),
            "configs": configs}
