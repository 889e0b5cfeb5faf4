"""Baselines the CML is compared with (paper 2.3): a DQN on stable-baselines3.

This package's ``__init__`` imports nothing heavy: the counts below and the stored
results are available without the optional ``dqn`` extra, so the hardware-budget report
can read them on a machine without torch. Training and evaluating the DQN
(:mod:`cml_edge.baselines.dqn`, ``cml-edge dqn``) import torch, stable-baselines3 and
gymnasium only when they run.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from cml_edge.baselines.settings import RESULTS_PATH
from cml_edge.errors import InputError

RESULTS_FORMAT = "cml-edge-dqn-results"
RESULTS_VERSION = 1


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
    if path.is_dir():
        raise InputError(f"{str(path)!r} is a folder, not a DQN results file")
    if not path.is_file():
        return None
    try:
        data = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise InputError(f"{str(path)!r} is not a readable DQN results file "
                         f"({type(exc).__name__})") from None
    if not isinstance(data, dict) or data.get("format") != RESULTS_FORMAT:
        raise InputError(f"{str(path)!r} is not a cml-edge DQN results file")
    for part in ("runs", "evaluations"):
        entries = data.get(part, {})
        if not (isinstance(entries, dict) and all(isinstance(e, dict) for e in entries.values())):
            raise InputError(f"{str(path)!r} is a corrupted DQN results file (its {part!r} is "
                             f"not a table of entries)")
    return data
