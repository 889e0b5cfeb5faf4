"""Write the legacy model files of tests/data/legacy/ with the OLD release's code.

Run from the old release's checkout (commit 30f00e8, before the one-folder-per-device
layout), with its own ``cml_edge`` on ``sys.path``:

    cd OLD_CHECKOUT && PYTHONDONTWRITEBYTECODE=1 python \
        /path/to/tests/data/legacy/generate.py OLD_CHECKOUT /path/to/tests/data/legacy

It writes one ``.npz`` per case and ``expected.json``: what the old code read back from
each file (the sha256 of each matrix's ``to_float()``), what ``cml-edge evaluate FILE
--trials 20 --json`` printed for it, and a probe (a read, a transposed read, an in-place
and a deferred update and a commit on each array, then the weights and counters), so
that the test can check that the current code loads the same weights and continues
bit for bit.

Two files are trained by the old command line at the paper's sizes (``float32``,
``int8``); the others through the old Python API with N_s = 24 (so that a crossbar
file stays a few tens of kB), still with ``save_model``, the same function the command
line writes with. ``pcm-drift`` has drift compensation on and was left idle for an
hour before saving, so its saved drift factor alpha is not 1.
"""

from __future__ import annotations

import contextlib
import hashlib
import io
import json
import sys
from pathlib import Path

SRC, OUT = Path(sys.argv[1]).resolve(), Path(sys.argv[2]).resolve()
sys.path.insert(0, str(SRC))

import numpy as np  # noqa: E402

import cml_edge  # noqa: E402

assert Path(cml_edge.__file__).resolve().is_relative_to(SRC), cml_edge.__file__

from cml_edge.arena import GridArena  # noqa: E402
from cml_edge.cml import CML, CMLConfig  # noqa: E402
from cml_edge.training import TrainConfig, train  # noqa: E402

from cml_edge.cli import main  # noqa: E402
from cml_edge.core.model_file import load_model, save_model  # noqa: E402

ARGS = ["--arena", "10", "--walks", "2", "--steps", "50", "--seed", "1"]
CLI_CASES = {"float32": ["--backend", "float32"], "int8": ["--backend", "int8"]}
API_CASES = {  # name: (backend, options, idle seconds before saving)
    "float": ("float", {}, 0.0),
    "fixed6": ("fixed", {"bits": 6, "rounding": "nearest"}, 0.0),
    "pcm": ("crossbar", {"preset": "pcm"}, 0.0),
    "reram": ("crossbar", {"preset": "reram"}, 0.0),
    "pcm-drift": ("crossbar", {"preset": "pcm", "drift_compensation": True}, 3600.0),
}


def sha(a: np.ndarray) -> str:
    return hashlib.sha256(np.ascontiguousarray(a, dtype=np.float64).tobytes()).hexdigest()


def run_cli(*argv: str) -> dict:
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        code = main([str(a) for a in argv])
    assert code == 0, argv
    return json.loads(buf.getvalue())


def probe(path: Path) -> dict:
    cml, _ = load_model(path)
    out = {}
    for name, arr in zip(("W_q", "W_k", "W_v"), cml.arrays):
        rows, cols = arr.shape
        x = np.sin(np.arange(cols) + 1.0)
        y = np.cos(np.arange(rows) + 1.0)
        post, pre = np.linspace(-1.0, 1.0, rows), np.linspace(0.5, -0.5, cols)
        read = arr.matvec(x)
        tread = arr.rmatvec(y)
        arr.outer_update(post, pre, 0.01, defer=False)
        arr.outer_update(post, pre, 0.02, defer=True)
        arr.commit()
        out[name] = {"matvec": read.tolist(), "rmatvec": tread.tolist(),
                     "weights_after": sha(arr.to_float()), "counters": arr.counters}
    return out


def main_() -> None:
    OUT.mkdir(parents=True, exist_ok=True)
    expected = {"generated_by": "tests/data/legacy/generate.py", "commit": "30f00e8",
                "cml_edge_version": cml_edge.__version__, "files": {}}
    for name, extra in CLI_CASES.items():
        path = OUT / f"{name}.npz"
        run_cli("train", *ARGS, *extra, "--out", path, "--json")
    arena = GridArena.empty(10)
    for name, (backend, options, idle) in API_CASES.items():
        cml = CML.create(CMLConfig.for_arena(10, n_s=24), backend, 1, **options)
        path = "factored" if backend == "float" else "direct"
        errors = train(cml, arena, TrainConfig(2, 50), 1, path=path)
        for arr in cml.arrays:
            arr.elapse(idle)
        record = {"arena": 10, "walks": 2, "steps": 50, "explore": "random",
                  "schedule": "walk", "seed": 1, "path": path, "backend_options": options,
                  "train_error": errors.tolist(), "idle_s": idle,
                  "cml_edge_version": cml_edge.__version__, "command": "generate.py"}
        save_model(OUT / f"{name}.npz", cml, record)
    for name in [*CLI_CASES, *API_CASES]:
        path = OUT / f"{name}.npz"
        cml, _ = load_model(path)
        evaluation = run_cli("evaluate", path, "--trials", "20", "--json")
        evaluation.pop("model")
        expected["files"][name] = {
            "backend": cml.backend,
            "weights": {k: sha(v) for k, v in cml.weights().items()},
            "weight_sums": {k: float(v.sum()) for k, v in cml.weights().items()},
            "evaluate": evaluation,
            "probe": probe(path),
        }
    (OUT / "expected.json").write_text(json.dumps(expected, indent=1, sort_keys=True) + "\n")


if __name__ == "__main__":
    main_()
