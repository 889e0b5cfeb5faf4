"""Baselines the CML is compared with (paper 2.3): a DQN on stable-baselines3.

This package's ``__init__`` imports nothing heavy: the counts below and the stored
results are available without the optional ``dqn`` extra, so the hardware-budget report
can read them on a machine without torch. Training and evaluating the DQN
(:mod:`cml_edge.baselines.dqn`, ``cml-edge dqn``) import torch, stable-baselines3 and
gymnasium only when they run.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

from cml_edge.baselines.settings import RESULTS_PATH
from cml_edge.errors import InputError
from cml_edge.io.reading import MiB, read_text, strict_json

RESULTS_FORMAT = "cml-edge-dqn-results"
RESULTS_VERSION = 1
RESULTS_BYTES = 64 * MiB
"""The largest DQN results file read (a run's curves and evaluations: ~1 MB for ten)."""


def mlp_parameter_count(layers: Sequence[int]) -> int:
    """Weights and biases of a dense network: sum of n_in * n_out + n_out per layer.

    For (2, 64, 64, 8): 192 + 4,160 + 520 = 4,872. The paper (2.4.3, 3.1) prints 4,874:
    its formula adds 1 x N_i input "biases" (2 of them) that a dense layer does not have.
    """
    return sum(a * b + b for a, b in zip(layers[:-1], layers[1:]))


def mlp_inference_flops(layers: Sequence[int]) -> int:
    """FLOPs per forward pass by the paper's formula (2.4.3): 2 N_x N_y per dense layer
    (biases and ReLUs not counted). For (2, 64, 64, 8): 9,472."""
    return sum(2 * a * b for a, b in zip(layers[:-1], layers[1:]))


def load_results(path: str | Path = RESULTS_PATH) -> dict[str, Any] | None:
    """The stored DQN results (what ``cml-edge dqn train|evaluate`` wrote), or None.

    Needs no extra: this is how the hardware-budget report reads the baseline.
    """
    path = Path(path)
    if not path.exists() and not path.is_symlink():
        return None
    try:
        data = strict_json(read_text(path, "DQN results file", RESULTS_BYTES))
    except ValueError as exc:
        if isinstance(exc, InputError):
            raise
        raise InputError(f"{str(path)!r} is not a readable DQN results file ({exc})") from None
    if not isinstance(data, dict) or data.get("format") != RESULTS_FORMAT:
        raise InputError(f"{str(path)!r} is not a cml-edge DQN results file")
    problem = _problem(data)
    if problem:
        raise InputError(f"{str(path)!r} is a corrupted DQN results file ({problem})")
    return data


def _problem(data: dict[str, Any]) -> str | None:
    """What in a results file the report and the DQN commands could not use, or None."""
    for part in ("runs", "evaluations"):
        entries = data.get(part, {})
        if not (isinstance(entries, dict) and all(isinstance(e, dict) for e in entries.values())):
            return f"its {part!r} is not a table of entries"
    net, hyper = data.get("network", {}), data.get("hyperparameters", {})
    if data["evaluations"]:
        if not isinstance(net, dict) or not _layers(net.get("layers")):
            return "its network has no list of layer sizes"
        if not isinstance(hyper, dict) or not _count(hyper.get("learning_starts"), 0):
            return "its hyperparameters have no learning_starts"
    for key, ev in data["evaluations"].items():
        if not isinstance(ev.get("reward"), str) or not isinstance(ev.get("goal_conditioned"),
                                                                   bool):
            return f"evaluation {key!r} has no reward name or goal_conditioned flag"
        if ev["goal_conditioned"] and not _layers(net.get("goal_conditioned_layers")):
            return "its network has no goal-conditioned layer sizes"
        if "train_steps" in ev and not _count(ev["train_steps"], 1):
            return f"evaluation {key!r}: train_steps {ev['train_steps']!r}"
        rate = ev.get("success_rate")
        if rate is not None and not (isinstance(rate, (int, float)) and 0 <= rate <= 1):
            return f"evaluation {key!r}: success_rate {rate!r} is not in 0..1"
        conv = ev.get("convergence")
        if conv is not None and not (isinstance(conv, dict) and
                                     (conv.get("step") is None or _count(conv["step"], 0))):
            return f"evaluation {key!r}: its convergence has no step count"
    return None


def _count(v: Any, least: int) -> bool:
    return isinstance(v, int) and not isinstance(v, bool) and v >= least


def _layers(v: Any) -> bool:
    return isinstance(v, list) and len(v) >= 2 and all(_count(n, 1) for n in v)
