"""``cml-edge lava verify MODEL --epochs K``: a saved loihi2 model run in Intel Lava's own
CPU simulator and compared integer for integer (:mod:`cml_edge.backends.loihi2.conformance`).

Lava 0.10.0 runs on Python 3.10 in an environment of its own: ``bash scripts/lava_env.sh``
builds it; without it the command stops with one line naming that command (exit 2).
"""

from __future__ import annotations

import argparse
from typing import Any

from cml_edge.cli.args import nonneg_int, positive_int
from cml_edge.errors import InputError

MAX_COUNT = 1000  # epochs and reads: each epoch is one Lava run step of a few milliseconds


def add_parsers(sub) -> None:
    """The lava command group."""
    p = sub.add_parser("lava", help="run a loihi2 model in Intel Lava (optional environment: "
                       "bash scripts/lava_env.sh)")
    lava_sub = p.add_subparsers(dest="lava_command", required=True)
    v = lava_sub.add_parser("verify", help="compare a loihi2 model's reads and K learning "
                            "epochs with Lava 0.10.0's fixed_pt simulator, integer for integer")
    v.add_argument("model", help="model file (.npz) trained with --backend loihi2")
    v.add_argument("--epochs", type=positive_int, default=20, metavar="K",
                   help="learning epochs per matrix (t_epoch 1), 1..1000 (default 20)")
    v.add_argument("--reads", type=positive_int, default=16, metavar="N",
                   help="input vectors per read (W_q, W_k, W_v, W_v^T), 1..1000 (default 16)")
    v.add_argument("--seed", type=nonneg_int, default=0,
                   help="seed of the vectors and updates (default 0)")
    v.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    v.set_defaults(run=cmd_verify)


def cmd_verify(args: argparse.Namespace) -> dict[str, Any]:
    from cml_edge.backends.loihi2.conformance import verify
    from cml_edge.core.model_file import load_model

    for flag, value in (("--epochs", args.epochs), ("--reads", args.reads)):
        if value > MAX_COUNT:
            raise InputError(f"{flag} {value} is beyond {MAX_COUNT} (allowed: 1..{MAX_COUNT})")
    cml, training = load_model(args.model)
    return verify(cml, args.model, epochs=args.epochs, reads=args.reads, seed=args.seed,
                  schedule=training.get("schedule", "step"))
