"""Lava in the loop: a saved ``loihi2`` model run in Intel Lava 0.10.0's own CPU simulator,
compared integer for integer with this emulation (``cml-edge lava verify``).

Lava runs on Python 3.10 only: it lives in a virtual environment of its own
(``bash scripts/lava_env.sh`` builds it in ``.lava-venv/`` at the repository root, or where
``CML_EDGE_LAVA_VENV`` says), and this module talks to it by a subprocess and two ``.npz``
files (:mod:`cml_edge.backends.loihi2.lava_runtime` is the other side).

What is compared (:func:`verify`):

- reads: for W_q, W_k, W_v and W_v^T (planning's transposed read), one-hot and random
  vectors become graded-spike payloads as the emulation forms them; Lava's ``Dense``, built
  from the export (:meth:`~cml_edge.backends.loihi2.array.Loihi2Array.to_lava`), gives
  ``a_out`` and its ``LIF`` the 24-bit ``u``; each is compared with the emulation's (the
  dot product held in int32 as Lava's ``Dense`` holds it, wrapped past 2^31 and counted
  as ``dense_wraps``), and the emulation's float read with u 2^(e - scale_exp - 6);
- learning: K updates of each matrix from the model's own training, rerun from its record
  (:func:`cml_edge.grid.in_lava.training_updates`), become the rule literal and traces as
  the emulation forms them (:func:`~cml_edge.backends.loihi2.kernels.engine_traces`, with
  the array's own stream); Lava's ``LearningDense`` runs them one epoch each (t_epoch 1),
  from the weights the training had before them, with the rule ``m * 2^(k - 7) * x0 * x1
  * y1`` (``(x1 - 64)`` for a signed pre vector), the pre neurons' graded spikes carrying
  2 X (2 (X + 64) offset) and a source the post traces Y. The emulation's randomness is
  its own stream; the comparison puts Lava's draws in its place (the write-back's
  ``ConnVarRandom`` and the traces' decay ``TraceRandom``s, NumPy generators whose seeds
  and positions :func:`_compare_learning` names). Compared per epoch: the traces the rule
  read (x after the one step of decay the emulation models, y as written:
  ``traces_equal``), the weights
  Lava wrote against the emulation's engine arithmetic on Lava's traces
  (``engine_equal``), and against the same from the emulation's own traces, epoch after
  epoch (``equal`` of ``replayed``); how many negative pre and post trace entries were
  sent (``negative_pre``, ``negative_post``), how many epochs carried the offset
  (``offset``) and how many trace entries the decay moved (``decayed``). An epoch whose
  term shift is 16 or more (the emulation saturates the term; Lava's rule exponent stops
  at 8) is not expressible and is counted.
"""

from __future__ import annotations

import os
import subprocess
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

import cml_edge
from cml_edge.backends.fields import MATRICES
from cml_edge.backends.loihi2 import kernels as kern
from cml_edge.backends.loihi2.array import Loihi2Array
from cml_edge.backends.loihi2.config import lava_gaps
from cml_edge.backends.loihi2.lava import SIGN_MODES
from cml_edge.errors import InputError

BUILD_COMMAND = "bash scripts/lava_env.sh"
VENV_VARIABLE = "CML_EDGE_LAVA_VENV"
RUNTIME = Path(__file__).with_name("lava_runtime.py")
LAVA_DRAW_SEED = 2  # ConnVarRandom's seed in LearningConnectionModelBitApproximate
LAVA_RULE_SEED = 0  # the rule's rng_seed: TraceRandom's seeds are it (x) and it + 2 (y)
LEARN_BITS = (8, 9)  # a LearningDense's num_weight_bits (other modes, mixed): at these,
# truncate_weights keeps every weight the engine writes, whenever a process starts


def repo_root() -> Path:
    """The checkout this package runs from (where ``scripts/`` and ``.lava-venv/`` are)."""
    return Path(cml_edge.__file__).resolve().parents[1]


def venv_python() -> Path:
    """The Lava environment's interpreter; InputError naming the build command if absent."""
    venv = Path(os.environ.get(VENV_VARIABLE) or repo_root() / ".lava-venv")
    python = venv / "bin" / "python"
    if not python.exists():
        raise InputError(f"the Lava environment is missing ({venv}): build it with "
                         f"`{BUILD_COMMAND}` (Python 3.10, lava-nc 0.10.0)")
    return python


def run_lava(work: dict[str, np.ndarray], timeout: float = 1800.0) -> dict[str, np.ndarray]:
    """Run the work ``work`` (the inputs :mod:`lava_runtime` reads) in the Lava environment;
    its outputs. A failing run raises InputError with its last line of error output."""
    python = venv_python()
    with tempfile.TemporaryDirectory(prefix="cml-edge-lava-") as tmp:
        path_in, path_out = Path(tmp) / "in.npz", Path(tmp) / "out.npz"
        np.savez(path_in, **work)
        done = subprocess.run([str(python), "-I", str(RUNTIME), str(path_in), str(path_out)],
                              capture_output=True, text=True, timeout=timeout)
        if done.returncode != 0:
            last = (done.stderr.strip().splitlines() or ["no output"])[-1]
            raise InputError(f"the Lava run failed: {last}")
        with np.load(path_out) as f:
            return {k: f[k] for k in f.files}


def read_vectors(n: int, count: int, rng: np.random.Generator) -> np.ndarray:
    """``count`` input vectors of length n: one-hots first (the CML's observations and
    actions), then differences of two one-hots, then standard normal vectors."""
    out = np.zeros((count, n))
    for t in range(count):
        if t < min(n, count // 2):
            out[t, t] = 1.0
        elif t < 3 * count // 4:
            a, b = rng.choice(n, 2, replace=n < 2)
            out[t, a] += 1.0
            out[t, b] -= 1.0
        else:
            out[t] = rng.standard_normal(n)
    return out


def _payloads(arr: Loihi2Array, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The payloads and scales of the rows of X as the emulation encodes them."""
    p = arr.state.params
    pay = np.zeros(X.shape, np.int64)
    scales = np.zeros(len(X), np.int64)
    for t, x in enumerate(X):
        scales[t] = kern.encode(x, len(x), p.msg_qmax, p.l1_max, p.payload_scale == kern.SAFE,
                                pay[t])
    return pay, scales


def read_work(arr: Loihi2Array, name: str, X: np.ndarray, transposed: bool) -> dict:
    d = arr.to_lava()
    W = d["weights"].T if transposed else d["weights"]
    pay, _ = _payloads(arr, X)
    return {f"{name}/weights": W, f"{name}/payloads": pay,
            f"{name}/params": np.array([d["weight_exp"], d["num_weight_bits"],
                                        d["num_message_bits"]]),
            f"{name}/sign_mode": np.array(d["sign_mode"])}


def lava_floats(arr: Loihi2Array, X: np.ndarray, u: np.ndarray) -> np.ndarray:
    """The float reads of the input rows X from the ``u`` Lava's LIF holds for them, scaled
    as the emulation scales its own: u 2^(e - scale_exp - 6), e each payload's scale."""
    _, scales = _payloads(arr, X)
    return np.ldexp(np.asarray(u, np.float64),
                    (scales - int(arr.state.params.scale_exp) - kern.ACT_SHIFT)[:, None])


def compare_reads(arr: Loihi2Array, X: np.ndarray, transposed: bool, a_out: np.ndarray,
                   u: np.ndarray) -> dict[str, int]:
    p = arr.state.params
    W = arr.state.w.astype(np.int64)
    W = W.T if transposed else W
    pay, _ = _payloads(arr, X)
    floats = lava_floats(arr, X, u)
    same_a = same_u = same_read = wraps = dense_wraps = 0
    for t, x in enumerate(X):
        sums = W @ pay[t]
        a = np.array([kern.dense_output(int(s), int(p.exp)) for s in sums])
        dense_wraps += int(np.count_nonzero((sums < -(1 << 31)) | (sums >= 1 << 31)))
        mine = [kern.neuron_input(int(s), int(p.exp)) for s in sums]
        wraps += sum(w for _, w in mine)
        same_a += bool((a == a_out[t]).all())
        same_u += bool((np.array([v for v, _ in mine]) == u[t]).all())
        read = arr.rmatvec(x) if transposed else arr.matvec(x)
        same_read += bool((read == floats[t]).all())
    return {"vectors": len(X), "a_out_equal": same_a, "u_equal": same_u,
            "read_equal": same_read, "neuron_wraps": wraps, "dense_wraps": dense_wraps}


def engine_updates(arr: Loihi2Array, calls: list[tuple]) -> tuple[np.ndarray, ...]:
    """The rule literal (m, k, c) (c: the pre traces' offset, 0 or 64), pre traces X and
    post traces Y, as the neurons send them (before the rule's one step of trace decay), of
    each update ``(post, pre, lr, stream)`` of ``arr`` (``stream``: the array's random
    stream just before it), as the emulation forms them."""
    rows, cols = arr.shape
    p = arr.state.params
    rule = np.zeros((len(calls), 3), np.int64)
    Xs = np.zeros((len(calls), cols), np.int64)
    Ys = np.zeros((len(calls), rows), np.int64)
    stochastic = p.traces == kern.STOCHASTIC and p.terms != kern.EXACT
    for t, (post, pre, lr, stream) in enumerate(calls):
        m, k, c, _ = kern.engine_traces(post, pre, rows, cols, float(lr),
                                        int(p.scale_exp) - int(p.exp), stochastic,
                                        stream.copy(), Xs[t], Ys[t])
        rule[t] = (m, k, c)
    return rule, Xs, Ys


def lava_draws(seed: int, count: int) -> np.ndarray:
    """The first ``count`` numbers of one of Lava's generators (``TraceRandom``,
    ``ConnVarRandom``: NumPy's ``default_rng(seed).random(1)`` per draw, the first at
    construction)."""
    return np.random.default_rng(seed).random(count)


def _engine_epoch(w: np.ndarray, mode: int, m: int, k: int, X: np.ndarray, Y: np.ndarray,
                  r: float) -> np.ndarray:
    """One epoch of the emulation's engine arithmetic (kernels: engine_term, accumulate,
    write_back) on weights w with the pre factors X (x0: X != 0; signed, x1 - c), post
    traces Y and draw r, as the rule reads them."""
    lo, hi = (-256, 255) if mode == kern.MIXED else ((0, 255) if mode == kern.EXCITATORY
                                                     else (-255, 0))
    out = w.copy()
    for i in range(w.shape[0]):
        for j in range(w.shape[1]):
            a = int(w[i, j]) << kern.FRAC_BITS
            if X[j] != 0:
                term, _ = kern.engine_term(m, int(X[j]), int(Y[i]), k)
                a, _ = kern.accumulate(a, term)
            out[i, j], _, _ = kern.write_back(a, r, mode, lo, hi)
    return out


def _compare_learning(arr: Loihi2Array, rule, Xs, Ys, got: dict, name: str,
                      tau: int) -> dict[str, Any]:
    """Epoch t of a process ran its step n = draw[t]: Lava's write-back draw is
    ``ConnVarRandom``'s number n (seed 2), its x and y traces' decay draws the
    ``TraceRandom``s' number 2 n (two advances a step; seeds: the rule's rng_seed, 0, and
    rng_seed + 2). Lava shows the x traces as the rule read them and the y traces as
    written (its 3-factor model keeps the decayed y in the epoch's history): Lava's y
    traces are decayed here for its own engine arithmetic."""
    mode = int(arr.state.params.sign_mode)
    steps = got[f"{name}/draw"].astype(np.int64)
    draws = lava_draws(LAVA_DRAW_SEED, int(steps.max()) + 1)
    x_decay = lava_draws(LAVA_RULE_SEED, 2 * int(steps.max()) + 1)
    y_decay = lava_draws(LAVA_RULE_SEED + 2, 2 * int(steps.max()) + 1)
    d = float(np.exp(-1 / np.array([tau]))[0])  # as Lava's _decay_trace forms it
    w_lava = arr.state.w.astype(np.int64)
    w_own = w_lava.copy()
    same_traces = same_engine = same_weights = decays = 0
    for t in range(len(rule)):
        m, k, c = (int(v) for v in rule[t])
        n = int(steps[t])
        xs, ys = Xs[t].copy(), Ys[t].copy()  # the emulation's, as the rule reads them
        kern.decay_traces(xs, len(xs), c, ys, len(ys), d, x_decay[2 * n], y_decay[2 * n])
        decays += int((xs != Xs[t]).sum() + (ys != Ys[t]).sum())
        x1 = np.where(Xs[t] != 0, got[f"{name}/x1"][t] - c, 0)
        y1 = got[f"{name}/y1"][t].copy()
        same_traces += bool((x1 == xs).all() and (y1 == Ys[t]).all())
        # Lava's y as its rule read it (its x1 already is): the y traces alone, cols 0
        kern.decay_traces(x1, 0, c, y1, len(y1), d, 0.0, y_decay[2 * n])
        r = float(draws[n])
        lava_w = got[f"{name}/weights"][t]
        same_engine += bool((_engine_epoch(w_lava, mode, m, k, x1, y1, r) == lava_w).all())
        w_own = _engine_epoch(w_own, mode, m, k, xs, ys, r)
        same_weights += bool((w_own == lava_w).all())
        w_lava = lava_w
    return {"replayed": len(rule), "equal": same_weights, "traces_equal": same_traces,
            "engine_equal": same_engine, "negative_pre": int((Xs < 0).sum()),
            "negative_post": int((Ys < 0).sum()), "offset": int((rule[:, 2] != 0).sum()),
            "decayed": decays}


def check_replayable(cml: Any, model: str, schedule: str) -> None:
    """Refuse (InputError, one line) a model that is not loihi2's, or whose training
    (``schedule`` and its arrays' options) Lava does not run
    (:func:`~cml_edge.backends.loihi2.config.lava_gaps`)."""
    if any(not isinstance(arr, Loihi2Array) for arr in cml.arrays):
        raise InputError(f"{model!r} is a {cml.backend} model; lava verify runs loihi2 models "
                         "(allowed: a model trained with --backend loihi2)")
    gaps = [setting for setting, _, replayable in lava_gaps(cml.arrays[0].options(), schedule)
            if not replayable]
    if gaps:
        raise InputError(f"{model!r} was trained with {', '.join(gaps)}, which Lava does not "
                         "run (allowed: a model of --schedule step, t_epoch 1, shared draws "
                         "and the engine's terms)")


def verify(cml: Any, model: str, updates: dict[str, tuple[Loihi2Array, list[tuple]]],
           reads: int = 16, seed: int = 0, trace_tau: int = kern.TRACE_TAU) -> dict[str, Any]:
    """Run ``cml`` (a CML with loihi2 arrays, loaded from the file ``model``) in Lava and
    compare (module docstring); ``updates``: per matrix, the array as it was before a
    stretch of its own training and that stretch's updates ``(post, pre, lr, stream)``
    (:func:`cml_edge.grid.in_lava.training_updates`), replayed one epoch each.
    ``trace_tau``: the traces' decay time constant in Lava and in the comparison (the
    chip's 65535; a short one makes decays common, for testing their model)."""
    venv_python()  # before any work
    rng = np.random.default_rng(seed)
    work: dict[str, Any] = {}
    plan_reads = []
    for name, arr in zip(MATRICES, cml.arrays):
        plan_reads.append((name, arr, read_vectors(arr.shape[1], reads, rng), False))
    W_v = cml.arrays[2]
    plan_reads.append(("W_v^T", W_v, read_vectors(W_v.shape[0], reads, rng), True))
    for name, arr, X, transposed in plan_reads:
        work.update(read_work(arr, name, X, transposed))
    work["reads"] = np.array([n for n, *_ in plan_reads])
    plan_learn, skipped = [], {}
    for name in MATRICES:
        arr, calls = updates[name]
        rule, Xs, Ys = engine_updates(arr, calls)
        ok = (rule[:, 0] != 0) & (rule[:, 1] < kern.MAX_TERM_SHIFT)
        skipped[name] = int((~ok).sum())
        rule, Xs, Ys = rule[ok], Xs[ok], Ys[ok]
        if not len(rule):
            continue
        d = arr.to_lava()
        work.update({f"{name}/learn/weights": d["weights"],
                     f"{name}/learn/sign_mode": np.array(d["sign_mode"]),
                     f"{name}/learn/params": np.array([d["weight_exp"], LEARN_BITS[
                         d["sign_mode"] == "MIXED"]]),
                     f"{name}/learn/X": Xs, f"{name}/learn/Y": Ys,
                     f"{name}/learn/rule": rule, f"{name}/learn/tau": np.array(trace_tau)})
        plan_learn.append((name, arr, rule, Xs, Ys))
    work["learn"] = np.array([f"{n}/learn" for n, *_ in plan_learn])
    got = run_lava(work)
    result_reads = {name: compare_reads(arr, X, transposed, got[f"{name}/a_out"],
                                         got[f"{name}/u"])
                    for name, arr, X, transposed in plan_reads}
    result_learn = {}
    for name, arr, rule, Xs, Ys in plan_learn:
        result_learn[name] = _compare_learning(arr, rule, Xs, Ys, got, f"{name}/learn",
                                               trace_tau)
    for name in MATRICES:
        result_learn.setdefault(name, {"replayed": 0, "equal": 0, "traces_equal": 0,
                                       "engine_equal": 0, "negative_pre": 0,
                                       "negative_post": 0, "offset": 0, "decayed": 0})
        result_learn[name]["not_expressible"] = skipped[name]
    exact = all(r["a_out_equal"] == r["u_equal"] == r["read_equal"] == r["vectors"]
                for r in result_reads.values()) and all(
        r["equal"] == r["replayed"] for r in result_learn.values())
    return {"model": str(model), "lava": "lava-nc 0.10.0, Loihi2SimCfg(select_tag='fixed_pt')",
            "seed": seed, "reads": result_reads, "learning": result_learn,
            "sign_modes": sorted({SIGN_MODES[int(a.state.params.sign_mode)]
                                  for a in cml.arrays}),
            "bit_exact": bool(exact)}


__all__ = ["BUILD_COMMAND", "check_replayable", "compare_reads", "engine_updates",
           "lava_floats", "read_vectors", "read_work", "run_lava", "venv_python", "verify"]
