"""Model files and atomic writes.

A model is one ``.npz`` (no pickles) holding ``format`` ("cml-edge-model"),
``format_version``, ``meta`` (JSON: the CML config, the backend, how it was
trained) and each array's ``state_dict`` under ``W_q/``, ``W_k/``, ``W_v/``.
Loading checks all of it and raises :class:`ModelFileError` with one line naming
what is wrong. Every file cml-edge writes goes to a temporary name in the target
folder and is renamed into place, so an interrupted write leaves no half file.
"""

from __future__ import annotations

import json
import os
import tempfile
import zipfile
from collections.abc import Callable
from pathlib import Path
from typing import IO, Any

import numpy as np

from cml_edge.backends import array_from_state_dict
from cml_edge.cml import CML, CMLConfig

FORMAT = "cml-edge-model"
FORMAT_VERSION = 1
MATRICES = ("W_q", "W_k", "W_v")


class ModelFileError(ValueError):
    """A model file that is missing, corrupted, foreign or of another version."""


def atomic_write(path: str | Path, write: Callable[[IO[bytes]], None]) -> None:
    """Call ``write(file)`` on a temporary file beside ``path``, then rename it into place."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        os.chmod(tmp, 0o666 & ~_umask())  # mkstemp makes 0600; give what open() would
        with os.fdopen(fd, "wb") as f:
            write(f)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def atomic_write_text(path: str | Path, text: str) -> None:
    atomic_write(path, lambda f: f.write(text.encode()))


def save_model(path: str | Path, cml: CML, training: dict[str, Any]) -> None:
    """Save ``cml`` with the record of how it was trained (``training``, JSON-able)."""
    arrays: dict[str, np.ndarray] = {
        "format": np.array(FORMAT),
        "format_version": np.array(FORMAT_VERSION),
        "meta": np.array(json.dumps({"config": cml.config.to_dict(), "backend": cml.backend,
                                     "training": training}, sort_keys=True)),
    }
    for name, arr in zip(MATRICES, cml.arrays):
        for k, v in arr.state_dict().items():
            arrays[f"{name}/{k}"] = v
    atomic_write(path, lambda f: np.savez(f, **arrays))


def load_model(path: str | Path) -> tuple[CML, dict[str, Any]]:
    """Load and validate a model file; returns the CML and its training record."""
    path = Path(path)
    if not path.is_file():
        raise ModelFileError(f"model file {str(path)!r} does not exist")
    try:
        with np.load(path, allow_pickle=False) as z:
            data = {k: z[k] for k in z.files}
    except (OSError, ValueError, zipfile.BadZipFile, EOFError) as exc:
        raise ModelFileError(f"{str(path)!r} is not a readable .npz model file ({exc})") from None
    if str(data.get("format", "")) != FORMAT:
        raise ModelFileError(f"{str(path)!r} is not a cml-edge model (no format {FORMAT!r})")
    version = data.get("format_version")
    if version is None or int(version) != FORMAT_VERSION:
        raise ModelFileError(f"{str(path)!r} has model format version {version}, this cml-edge "
                             f"reads version {FORMAT_VERSION}")
    try:
        meta = json.loads(str(data["meta"]))
        config = CMLConfig.from_dict(meta["config"])
        arrays = []
        for name in MATRICES:
            prefix = f"{name}/"
            sd = {k[len(prefix):]: v for k, v in data.items() if k.startswith(prefix)}
            arrays.append(array_from_state_dict(sd))
        cml = CML(config, tuple(arrays), meta["backend"])
        for name, arr in zip(MATRICES, cml.arrays):
            if not np.all(np.isfinite(arr.to_float())):
                raise ValueError(f"{name} holds non-finite weights")
    except (KeyError, TypeError, ValueError, json.JSONDecodeError) as exc:
        raise ModelFileError(f"{str(path)!r} is a corrupted model file: {exc}") from None
    return cml, meta.get("training", {})
