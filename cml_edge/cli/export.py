"""``cml-edge export MODEL.npz --format lava --out DIR``: a loihi2 model's weights for Lava.

For each matrix (W_q, W_k, W_v) it writes ``NAME.npz`` (``weights``, ``mantissa``,
``weight_exp``, ``num_weight_bits``, ``sign_mode``, ``num_message_bits``, ``scale_exp``:
:meth:`cml_edge.backends.loihi2.array.Loihi2Array.to_lava`) and ``NAME.json`` (how to build
the ``Dense`` process from it and how a read maps to the CML's float read;
:func:`~cml_edge.backends.loihi2.array.lava_description`), and ``lava.json`` listing them
with the model's options, its CML config (the observation frame), the moves in action
order, its training record and what of its training Lava does not run
(``beyond_reference``, also in the command's output): what a plan step needs
(docs/devices/loihi2.md has a script that plans one in Lava without cml-edge).
Lava is not needed here (nor installable on Python 3.11): a user who has it builds
``Dense(weights=..., weight_exp=..., num_weight_bits=..., sign_mode=SignMode(...),
num_message_bits=...)`` from these files. Every file is written under a temporary name and
renamed into place.
"""

from __future__ import annotations

import argparse
import io
from pathlib import Path
from typing import Any

import numpy as np

from cml_edge.backends import beyond_reference
from cml_edge.cli.output import beyond_rows, labelled, plural
from cml_edge.core.finite import dumps
from cml_edge.core.model_file import MATRICES, load_model
from cml_edge.errors import InputError
from cml_edge.grid.arena import MOVES
from cml_edge.io.files import (
    atomic_folder,
    own_folder,
    writable_folder,
)

FORMATS = ("lava",)


def add_parsers(sub) -> None:
    """The export command."""
    p = sub.add_parser("export", help="write a loihi2 model's weights for another tool "
                       "(--format lava: Lava Dense parameters, .npz and JSON per matrix)")
    p.add_argument("model", help="model file (.npz) trained with --backend loihi2")
    p.add_argument("--format", choices=FORMATS, required=True,
                   help="lava: the integer weights, weight_exp, num_weight_bits, sign_mode and "
                        "num_message_bits of each Dense")
    p.add_argument("--out", required=True, metavar="DIR", help="folder to write into")
    p.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    p.set_defaults(run=cmd_export, show=show_export)


def _npz_bytes(arrays: dict[str, Any]) -> bytes:
    buf = io.BytesIO()
    np.savez(buf, **{k: np.asarray(v) for k, v in arrays.items()})
    return buf.getvalue()


def cmd_export(args: argparse.Namespace) -> dict[str, Any]:
    from cml_edge.backends.loihi2.array import Loihi2Array, lava_description

    out = writable_folder(args.out, "--out")
    own_folder(out, {f"{name}.{ext}" for name in MATRICES for ext in ("npz", "json")} |
               {"lava.json"}, "--out")
    cml, training = load_model(args.model)
    kinds = sorted({arr.name for arr in cml.arrays})
    if kinds != [Loihi2Array.name]:
        raise InputError(f"{args.model!r} holds {', '.join(kinds)} arrays (backend "
                         f"{cml.backend}); --format lava exports loihi2 models only (allowed: "
                         "a model trained with --backend loihi2)")
    members: dict[str, bytes] = {}
    described = []
    for name, arr in zip(MATRICES, cml.arrays):
        values = arr.to_lava()
        members[f"{name}.npz"] = _npz_bytes(values)
        members[f"{name}.json"] = dumps(lava_description(arr, name), indent=1).encode()
        described.append({k: values[k] for k in ("weight_exp", "num_weight_bits", "sign_mode",
                                                 "num_message_bits", "scale_exp",
                                                 "lsb_truncated")} | {"matrix": name})
    beyond = beyond_reference(cml.backend, cml.arrays[0].options(),
                              training.get("schedule", "step"))
    index = {"model": str(args.model), "format": "lava", "backend": cml.backend,
             "matrices": described, "options": cml.arrays[0].options(),
             "cml_config": cml.config.to_dict(), "moves": MOVES.tolist(),
             "training": {k: v for k, v in training.items() if k != "train_error"}, **beyond,
             "note": "one Dense per matrix (NAME.json says how); planning also reads W_v^T, "
                     "a second Dense of W_v's weights transposed"}
    members["lava.json"] = dumps(index, indent=1).encode()

    def write(folder: Path) -> None:
        for member, data in members.items():
            (folder / member).write_bytes(data)

    atomic_folder(out, write)  # all or nothing: a failure leaves --out as it was
    return {"model": str(args.model), "format": "lava", "out": str(out),
            "files": [str(out / member) for member in members], "matrices": described,
            **beyond}


def show_export(r: dict[str, Any]) -> None:
    """``export``: where the files are, each matrix's Dense parameters, and what of the
    model's training Lava does not run."""
    print(f"export: {r['model']} for Lava, in {r['out']}")
    print("\n".join(labelled([
        *((m["matrix"], f"weight_exp {m['weight_exp']}, num_weight_bits "
                        f"{m['num_weight_bits']}, {m['sign_mode']}, {m['num_message_bits']}-bit "
                        f"messages, {plural(m['lsb_truncated'], 'weight')} truncated")
          for m in r["matrices"]),
        *beyond_rows(r), ("files", ", ".join(Path(f).name for f in r["files"]))])))
