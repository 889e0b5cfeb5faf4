"""Model files: the format of a saved CML.

A model is one ``.npz`` (no pickles) holding ``format`` ("cml-edge-model"),
``format_version``, ``meta`` (JSON: the CML config, the backend, how it was
trained) and each array's ``state_dict`` under ``W_q/``, ``W_k/``, ``W_v/``.
Loading checks all of it and raises :class:`ModelFileError` with one line naming
what is wrong; a file of the one older layout is converted first
(:mod:`cml_edge.core.legacy`). Files are written atomically
(:func:`cml_edge.io.files.atomic_write`).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from cml_edge.backends import array_from_state_dict
from cml_edge.core.cml import CML, CMLConfig
from cml_edge.core.legacy import upgrade
from cml_edge.errors import InputError, PluginError
from cml_edge.io.files import atomic_write
from cml_edge.io.reading import MiB, npz_members
from cml_edge.sizes import checked

FORMAT = "cml-edge-model"
FORMAT_VERSION = 1
MATRICES = ("W_q", "W_k", "W_v")


class ModelFileError(InputError):
    """A model file that is missing, corrupted, foreign or of another version."""


def cml_arrays(cml: CML, prefix: str = "") -> dict[str, np.ndarray]:
    """Each array's ``state_dict`` under ``<prefix>W_q/``, ``<prefix>W_k/``, ``<prefix>W_v/``."""
    return {f"{prefix}{name}/{k}": v for name, arr in zip(MATRICES, cml.arrays)
            for k, v in arr.state_dict().items()}


def cml_from_arrays(data: dict[str, np.ndarray], config: CMLConfig, backend: str,
                    prefix: str = "") -> CML:
    """The CML stored by :func:`cml_arrays` under ``prefix``; InputError (or KeyError) when
    an array is missing or malformed or holds a non-finite weight."""
    arrays = []
    for name in MATRICES:
        head = f"{prefix}{name}/"
        arrays.append(array_from_state_dict({k[len(head):]: v for k, v in data.items()
                                             if k.startswith(head)}))
    cml = CML(config, tuple(arrays), backend)
    for name, arr in zip(MATRICES, cml.arrays):
        if not np.all(np.isfinite(arr.to_float())):
            raise InputError(f"{prefix}{name} holds non-finite weights")
    return cml


MAX_BYTES = 256 * MiB
"""The largest model file read (and the most its arrays may declare): a CML on the paper's
sizes is a few MB on any device, a robot model of ten seeds a few tens."""


def read_npz(path: str | Path, fmt: str, version: int, error: type[InputError],
             foreign: dict[str, str] | None = None) -> dict[str, np.ndarray]:
    """The arrays of the ``.npz`` file ``path`` after checking that it is a regular file of
    at most :data:`MAX_BYTES` (its arrays' declared sizes too), reads, and carries format
    ``fmt`` at ``version``; ``error`` otherwise, with the hint ``foreign`` gives for a known
    other format."""
    name = str(path)
    data = npz_members(path, "model file", MAX_BYTES, error)
    found = str(data.get("format", ""))
    if found != fmt:
        hint = (foreign or {}).get(found, "")
        raise error(f"{name!r} is not a {fmt.replace('-model', '')} model (no format "
                    f"{fmt!r}){hint}")
    stored = data.get("format_version")
    if stored is None or stored.shape != () or stored.dtype.kind not in "iu" or \
            int(stored) != version:
        shown = None if stored is None else (stored.tolist() if stored.size < 8 else "an array")
        raise error(f"{name!r} has {fmt} format version {shown!r}, this cml-edge reads "
                    f"version {version}")
    return data


def save_model(path: str | Path, cml: CML, training: dict[str, Any]) -> None:
    """Save ``cml`` with the record of how it was trained (``training``, JSON-able)."""
    arrays: dict[str, np.ndarray] = {
        "format": np.array(FORMAT),
        "format_version": np.array(FORMAT_VERSION),
        "meta": np.array(json.dumps({"config": cml.config.to_dict(), "backend": cml.backend,
                                     "training": training}, sort_keys=True)),
        **cml_arrays(cml),
    }
    atomic_write(path, lambda f: np.savez(f, **arrays))


def load_model(path: str | Path) -> tuple[CML, dict[str, Any]]:
    """Load and validate a model file; returns the CML and its training record."""
    data = read_npz(path, FORMAT, FORMAT_VERSION, ModelFileError,
                    {"cml-edge-robot-model": " (a robot model: use cml-edge robot evaluate)",
                     "cml-edge-drone-model": " (a drone model: use cml-edge drone evaluate)"})
    try:
        meta = json.loads(str(data["meta"]))
        if not isinstance(meta, dict):
            raise TypeError(f"its record is a {type(meta).__name__}, not an object")
        training = _training(meta.get("training", {}))
        cml = cml_from_arrays(upgrade(data, MATRICES), CMLConfig.from_dict(meta["config"]),
                              meta["backend"])
    except PluginError as exc:  # a device of a plugin that is not loaded
        raise ModelFileError(f"{str(path)!r}: {exc}") from None
    except (KeyError, TypeError, ValueError, json.JSONDecodeError) as exc:
        raise ModelFileError(f"{str(path)!r} is a corrupted model file: {exc}") from None
    return cml, training


TRAINING_SIZES = ("arena", "walks", "steps", "seed")
"""The training record's numbers, each held to the range its option has (:mod:`cml_edge.sizes`):
a model's record is what ``evaluate`` retrains its float64 twin with."""


def _training(record: Any) -> dict[str, Any]:
    """The training record of a model file, its numbers in their options' ranges
    (TypeError or InputError naming the field otherwise)."""
    if not isinstance(record, dict):
        raise TypeError(f"its training record is a {type(record).__name__}, not an object")
    for key in TRAINING_SIZES:
        if key in record:
            checked(key, record[key], f"its training record's {key}")
    for key in ("explore", "schedule"):
        if key in record and not isinstance(record[key], str):
            raise TypeError(f"its training record's {key} {record[key]!r} is not a name")
    return record
